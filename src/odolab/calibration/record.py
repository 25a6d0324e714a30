"""Keep a calibration in the lab notebook: a new parameter version with its source trials.

Shared by ``odolab calibrate ... --db`` and ``odolab serve`` (its calibration page).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Literal

from odolab.core.trials import MotionKind, Trial, TrialStatus

if TYPE_CHECKING:
    from odolab.calibration.ratios import CalibrationResult
    from odolab.core.params import RobotParams
    from odolab.store import Notebook

__all__ = ["record_calibration"]


def record_calibration(
    nb: Notebook,
    result: CalibrationResult,
    base: RobotParams,
    *,
    trials: Literal["all", "squares"] | Sequence[Trial] | None,
) -> int:
    """Add ``result`` as a new version of ``base``'s robot; return the version number.

    ``trials`` names the measured trials it comes from: every one (``"all"``), the UMBmark
    squares (``"squares"``), none (ratios typed by hand), or the trials themselves (those a
    ``--campaign`` selection used; the measured ones are recorded). The trials a separated
    ``[noise]`` fit used (``provenance["noise_fit"]``) are added, and the notes say which
    constant came from how many trials or stays unknown.
    """
    if trials is not None and not isinstance(trials, str):
        used = [t.trial_id for t in trials if t.status is TrialStatus.MEASURED]
    else:
        used = [
            t.trial_id
            for t in nb.load_trials(status=TrialStatus.MEASURED, with_logs=False)
            if trials == "all" or (trials == "squares" and t.command.kind is MotionKind.SQUARE)
        ]
    notes = str(result.provenance.get("source", ""))
    fit = result.provenance.get("noise_fit")
    if isinstance(fit, dict):  # the [noise] came from other trials: record them too
        extra: list[str] = []
        for key in ("k_left", "k_right", "k_scrub"):
            entry = fit.get(key, {})
            extra += [t for t in entry.get("trials", []) if "value" in entry]
            n = len(entry.get("trials", []))
            notes += f"; {key} from {n} trials" if "value" in entry else f"; {key} unknown"
        have = set(used)
        used += [t for t in dict.fromkeys(extra) if t not in have]
    return nb.add_params_version(
        result.params.with_(name=base.name),
        method=result.method,
        source_trials=used,
        notes=notes.lstrip("; "),
    )
