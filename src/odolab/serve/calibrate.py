"""The calibration and report pages' work: the library calls ``odolab calibrate`` and
``odolab report`` make, on the notebook's trials."""

from __future__ import annotations

import contextlib
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

from odolab.errors import CalibrationError, OdolabError, StoreError
from odolab.trials import MotionKind, TrialStatus

if TYPE_CHECKING:
    from odolab.calibration import CalibrationResult
    from odolab.store import Notebook

__all__ = ["METHODS", "calibrate_notebook", "report_bytes"]

#: The calibrations the page offers.
METHODS = ("ratios", "umbmark")


def calibrate_notebook(
    nb: Notebook, method: str, robot: str, terrain: str | None = None
) -> dict[str, Any]:
    """Calibrate ``robot``'s latest parameters from the notebook's measured trials.

    ``ratios``: from the fits of Table I (on ``terrain`` when given), as ``odolab calibrate
    ratios --db``; ``umbmark``: from the square trials, iterated on their encoder logs when every
    one has a log, as ``odolab calibrate umbmark --db``. The result is recorded as a new
    parameter version; returns what the page shows (version, old and new parameters, how).
    """
    from odolab.analysis import analyze_trials
    from odolab.calibration import (
        ratios_from_analysis,
        umbmark,
        umbmark_errors_from_trials,
        umbmark_iterated,
    )
    from odolab.calibration.record import record_calibration

    if method not in METHODS:
        raise CalibrationError(f"method is {method!r}; expected one of {', '.join(METHODS)}")
    if robot not in nb.robots():
        raise StoreError(f"no parameters of robot {robot!r} in {nb.path}")
    base = nb.latest_params(robot)
    how = ""
    result: CalibrationResult
    if method == "ratios":
        analysis = analyze_trials(nb.load_trials(with_logs=False))
        result = ratios_from_analysis(analysis, base, terrain=terrain)
        version = record_calibration(nb, result, base, trials="all")
    else:
        trials = nb.load_trials()
        squares = [
            t
            for t in trials
            if t.command.kind is MotionKind.SQUARE and t.status is TrialStatus.MEASURED
        ]
        if squares and all(t.encoder_log is not None for t in squares):
            umb = umbmark_iterated(squares, base)
            how = (
                f"iterated on the encoder logs of {len(squares)} square trials: converged in "
                f"{umb.calibration.provenance['n_iterations']} steps; E_max,syst "
                f"{umb.e_max_syst:.4g} m -> {umb.e_max_syst_after:.4g} m"
            )
        else:
            cw, ccw, side = umbmark_errors_from_trials(trials)
            umb = umbmark(cw, ccw, side, base)
            how = f"single linearized step; E_max,syst {umb.e_max_syst:.4g} m"
        result = umb.calibration
        version = record_calibration(nb, result, base, trials="squares")
    return {
        "method": result.method,
        "robot": base.name,
        "version": version,
        "old": base,
        "new": result.params,
        "how": how,
        "provenance": {
            k: v for k, v in result.provenance.items() if isinstance(v, str | int | float)
        },
    }


def report_bytes(nb: Notebook) -> bytes:
    """The lab report (self-contained HTML) of the notebook's trials, as ``odolab report``."""
    from odolab.analysis import analyze_trials
    from odolab.calibration import (
        ratios_from_analysis,
        umbmark,
        umbmark_errors_from_trials,
        umbmark_iterated,
    )
    from odolab.report import write_report

    trials = nb.load_trials()
    analysis = analyze_trials(trials)
    base = analysis.params
    calibrations: dict[str, Any] = {}
    with contextlib.suppress(CalibrationError):  # the report says why there is none
        calibrations["ratios"] = ratios_from_analysis(analysis, base)
    if analysis.square_trials and base is not None:
        with contextlib.suppress(CalibrationError):
            if all(t.encoder_log is not None for t in analysis.square_trials):
                start = calibrations["ratios"].params if "ratios" in calibrations else base
                calibrations["umbmark"] = umbmark_iterated(analysis.square_trials, start)
            else:
                cw, ccw, side = umbmark_errors_from_trials(analysis.square_trials)
                calibrations["umbmark"] = umbmark(cw, ccw, side, base)
    with tempfile.TemporaryDirectory(prefix="odolab-report-") as tmp:
        try:
            path = write_report(Path(tmp) / "report", analysis, calibrations)
        except OSError as err:
            raise OdolabError(f"the report could not be written ({err})") from err
        return path.read_bytes()
