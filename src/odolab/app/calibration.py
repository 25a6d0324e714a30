"""A calibration from the notebook: ``odolab calibrate ratios|umbmark --db``, the web's
/calibrate form and ``POST /api/calibrate`` all call :func:`calibrate`.

The rule for where a calibration starts: the parameter version the trials were DRIVEN with (the
one their predictions were computed with: Table I's ratios are relative to it), unless the user
names parameters. Never the robot's latest version, which may be an earlier calibration of the
same trials (applying the ratios to it would correct twice). The result says which version it
started from and why.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from odolab.app.selection import (
    EVERY_CAMPAIGN,
    Selection,
    SelectionRequest,
    check_robot,
    robots_among,
    select_among,
    validation_campaigns,
)
from odolab.core.errors import CalibrationError, opt
from odolab.core.trials import MotionKind, Trial, TrialStatus

if TYPE_CHECKING:
    from odolab.analysis import LabAnalysis
    from odolab.app.analysis import AnalysisCache
    from odolab.calibration import CalibrationResult, UmbmarkResult
    from odolab.core.params import RobotParams
    from odolab.store import Notebook

__all__ = [
    "METHODS",
    "BaseChoice",
    "CalibrationOutcome",
    "CalibrationRequest",
    "calibrate",
    "choose_base",
    "choose_robot",
    "umbmark_start",
]

#: The calibrations from the notebook's trials.
METHODS = ("ratios", "umbmark")


@dataclass(frozen=True)
class CalibrationRequest:
    """What to calibrate: ``method`` (ratios or umbmark) of ``robot`` (None: the one robot of
    the selected trials) from the trials ``selection`` picks; ``terrain`` of the ratios' fits
    (None: the first terrain, alphabetically, with both a rotation and an x fit); ``params``:
    start from these instead of the version the trials were driven with (``params_source`` says
    where the user named them); ``record``: keep the result as a new parameter version;
    ``side``: UMBmark's square side to check against the trials' (m)."""

    method: str
    selection: SelectionRequest = field(default_factory=lambda: EVERY_CAMPAIGN)
    robot: str | None = None
    terrain: str | None = None
    params: RobotParams | None = None
    params_source: str | None = None
    record: bool = True
    side: float | None = None


@dataclass(frozen=True)
class BaseChoice:
    """The parameters a calibration starts from, and why those."""

    params: RobotParams
    robot: str
    version: int | None  #: the notebook's version number (None: parameters the user gave)
    reason: str  #: one sentence, shown by every face
    #: the relative standard error of the scale of ``params`` when a ratios calibration fixed
    #: it (UMBmark chained from it carries it into its intervals); None: taken as exact
    scale_sd: float | None = None

    def to_dict(self) -> dict[str, object]:
        return {
            "robot": self.robot,
            "version": self.version,
            "reason": self.reason,
            "params": self.params.to_dict(),
        }


@dataclass(frozen=True)
class CalibrationOutcome:
    """A calibration from the notebook: where it started, what it gave, where it was kept."""

    method: str
    robot: str
    base: BaseChoice
    result: CalibrationResult
    selection: Selection
    umbmark: UmbmarkResult | None = None
    version: int | None = None  #: the new parameter version (None: not recorded)
    how: str = ""  #: how UMBmark was done (iterated or a single step)
    terrain: str | None = None  #: the terrain of the ratios' fits

    @property
    def params(self) -> RobotParams:
        return self.result.params

    def to_dict(self) -> dict[str, object]:
        """The JSON of ``calibrate ... --json`` and ``POST /api/calibrate`` (the same keys)."""
        from odolab.report.html import jsonable

        p = self.result.params
        out: dict[str, object] = {
            "method": self.method,
            "robot": self.robot,
            "base": self.base.to_dict(),
            "params": p.to_dict(),
            "wheel_radius": [p.left_wheel_radius, p.right_wheel_radius],
            "track_width": p.track_width,
            "terrain": self.terrain,
            "recorded_version": self.version,
            "how": self.how,
            "selection": self.selection.to_dict(),
            "provenance": jsonable(
                {k: v for k, v in self.result.provenance.items() if k != "created"}
            ),
        }
        if self.umbmark is not None:
            u = self.umbmark
            out["umbmark"] = jsonable(
                {
                    "e_d": u.e_d,
                    "e_b": u.e_b,
                    "e_max_syst": u.e_max_syst,
                    "e_max_syst_after": u.e_max_syst_after,
                    "side": u.side,
                    "n_cw": u.n_cw,
                    "n_ccw": u.n_ccw,
                }
            )
        return out

    def describe(self) -> str:
        """One sentence: what was calibrated from what, and where it was kept."""
        p = self.result.params
        text = (
            f"{self.method} calibration of {self.robot}, starting from {self.base.reason}: "
            f"wheel radius L/R {p.left_wheel_radius:.5g}/{p.right_wheel_radius:.5g} m, "
            f"track width {p.track_width:.5g} m"
        )
        if self.version is not None:
            text += f"; recorded as {self.robot} parameters version {self.version}"
        return text


def _measured(trials: list[Trial]) -> list[Trial]:
    return [t for t in trials if t.status is TrialStatus.MEASURED and t.measured is not None]


def choose_robot(trials: list[Trial], robot: str | None, params: RobotParams | None) -> str:
    """The robot a calibration is for: the one named; else the one robot of ``trials``'
    measured ones (:func:`~odolab.app.selection.robots_among`, the count the trials-used
    sentence says); else the robot ``params`` are of, when it is among them. Several robots and
    none named is an error (a calibration of one robot from another's trials would be wrong)."""
    robots = robots_among(trials)
    if robot is not None:
        return robot
    if len(robots) == 1:
        return robots[0]
    if params is not None and params.name in robots:
        return params.name
    if not robots:
        raise CalibrationError("the selection has no measured trial to calibrate from")
    raise CalibrationError(
        f"the selected trials are of {len(robots)} robots ({', '.join(robots)}); name the one "
        "to calibrate ({{robot}}, or the form's robot)"
    )


def choose_base(
    nb: Notebook,
    robot: str,
    trials: list[Trial],
    params: RobotParams | None = None,
    params_source: str | None = None,
) -> BaseChoice:
    """Where a calibration of ``robot`` from ``trials`` starts: ``params`` when the user named
    them, else the parameter version the measured trials were driven with (the most common one
    when they were driven with several, which the reason then says)."""
    if params is not None:
        where = params_source or "the parameters given"
        return BaseChoice(params, robot, None, f"{where} (named by the user)")
    measured = [t for t in _measured(trials) if t.params.name == robot]
    if not measured:
        raise CalibrationError(
            f"no measured trial of robot {robot!r} in the selection to calibrate from"
        )
    counts = Counter(t.params for t in measured).most_common()
    base, n = counts[0]
    version = nb.find_params_version(base)
    reason = (
        f"{robot} parameters version {version}, the one its {n} measured trials were driven with"
    )
    if len(counts) > 1:
        others = ", ".join(f"version {nb.find_params_version(p)} ({k})" for p, k in counts[1:])
        reason = (
            f"{robot} parameters version {version}, the one most of its measured trials were "
            f"driven with ({n} of {len(measured)}; the others: {others})"
        )
    return BaseChoice(base, robot, version, reason)


def umbmark_start(
    nb: Notebook,
    robot: str,
    squares: list[Trial],
    ratios: tuple[CalibrationResult, BaseChoice] | None,
    params: RobotParams | None = None,
    params_source: str | None = None,
) -> BaseChoice:
    """Where UMBmark of ``robot`` from ``squares`` starts, for every face (``calibrate umbmark
    --db``, the web, the report, the demo): when every square has its encoder log (UMBmark
    iterated on the logs, which integrates them again) and a ``ratios`` calibration of the same
    trials could be made, that ratios result: UMBmark fixes the track and the wheels' ratio,
    never the scale, and the ratios fix the scale (``ratios``: that result and where it
    started, from the ``params`` the user named when named, so that naming the parameters the
    trials were driven with gives what the report gives); else ``base``: the ``params`` the user
    named, or the version the squares were driven with (the single linearized step corrects the
    predictions they were driven with, and correcting an earlier calibration of them would
    correct twice)."""
    base = choose_base(nb, robot, squares, params, params_source)
    logs = bool(squares) and all(t.encoder_log is not None for t in squares)
    if not logs or ratios is None:
        return base
    from odolab.calibration import scale_sd_from

    result, start = ratios
    terrain = result.provenance.get("terrain")
    on = f" on {terrain}" if terrain else ""
    return BaseChoice(
        result.params,  # named as the ratios result, so the provenance says where it started
        base.robot,
        None,
        f"the ratios calibration of the same trials{on} (UMBmark iterated on the squares' "
        f"encoder logs fixes the track and the wheels' ratio, not the scale), itself from "
        f"{start.reason}",
        scale_sd_from(result),
    )


def _ratios(
    nb: Notebook,
    sel: Selection,
    req: CalibrationRequest,
    robot: str,
    analysis: LabAnalysis | None = None,
) -> tuple[CalibrationResult, BaseChoice, list[Trial], LabAnalysis]:
    from odolab.analysis import analyze_trials
    from odolab.calibration import ratios_from_analysis

    base = choose_base(nb, robot, sel.trials, req.params, req.params_source)
    if analysis is None:
        analysis = analyze_trials(sel.trials)
    result = ratios_from_analysis(analysis, base.params, terrain=req.terrain)
    # the trials it comes from: those of the two fits on its terrain (record_calibration adds
    # the [noise] fit's), not every trial of the selection (the squares were listed too)
    terrain = str(result.provenance.get("terrain") or "")
    ids: set[str] = set()
    for motion in ("x", "rotation"):
        fit = analysis.get(motion, terrain)
        if fit is not None:
            ids.update(fit.fit.trial_ids)
    used = [t for t in sel.trials if t.trial_id in ids] if ids else sel.trials
    return result, base, used, analysis


def umbmark_from_squares(
    squares: list[Trial],
    start: RobotParams,
    side: float | None = None,
    scale_sd: float | None = None,
) -> tuple[UmbmarkResult, str]:
    """UMBmark on measured square trials: iterated on their encoder logs when every one has
    a log, else the single linearized step; returns the result and a sentence saying which.
    ``scale_sd``: the start's scale uncertainty (:attr:`BaseChoice.scale_sd`), carried into the
    intervals."""
    from odolab.calibration import umbmark, umbmark_errors_from_trials, umbmark_iterated

    no_log = [t for t in squares if t.encoder_log is None]
    if squares and not no_log:
        result = umbmark_iterated(squares, start, scale_sd=scale_sd)
        if side is not None and abs(side - result.side) > 1e-6:
            raise CalibrationError(
                f"{opt('side')} {side:g} m disagrees with the notebook's squares ({result.side:g} m)"
            )
        after = result.e_max_syst_after
        how = (
            f"UMBmark iterated on the encoder logs of {len(squares)} square trials: converged "
            f"in {result.calibration.provenance['n_iterations']} steps; E_max,syst "
            f"{result.e_max_syst:.4g} m -> "
            f"{'?' if after is None else format(after, '.4g')} m with the new parameters "
            "(same runs)"
        )
        return result, how
    cw, ccw, sq_side = umbmark_errors_from_trials(squares)
    result = umbmark(cw, ccw, side or sq_side, start, scale_sd=scale_sd)
    how = (
        f"UMBmark single linearized step: {len(no_log)} of {len(squares)} square trials have no "
        f"encoder log to iterate on; E_max,syst {result.e_max_syst:.4g} m"
    )
    return result, how


def calibrate(
    nb: Notebook, request: CalibrationRequest, cache: AnalysisCache | None = None
) -> CalibrationOutcome:
    """Calibrate a robot from the notebook's selected trials (see the module's rule).

    ``ratios``: from Table I's rotation and x fits on one terrain; ``umbmark``: from the
    measured square trials. Recorded as a new parameter version when ``request.record``.
    ``cache``: a server's analysis cache (the same trials are not analysed twice).
    """
    from odolab.calibration.record import record_calibration

    if request.method not in METHODS:
        raise CalibrationError(
            f"method is {request.method!r}; expected one of {', '.join(METHODS)}"
        )
    if request.robot is not None:
        check_robot(nb, request.robot)
    trials = nb.load_trials(with_logs=request.method == "umbmark")
    validation = validation_campaigns(nb)
    everything = select_among(trials, validation, request.selection)
    robot = choose_robot(everything.trials, request.robot, request.params)
    sel = select_among(trials, validation, _with_robot(request.selection, robot))
    umb: UmbmarkResult | None = None
    how = ""
    terrain: str | None = None
    if request.method == "ratios":
        known = None if cache is None else cache.get(sel.trials)
        result, base, used, _ = _ratios(nb, sel, request, robot, known)
        terrain = str(result.provenance.get("terrain") or "") or None
    else:
        squares = [t for t in _measured(sel.trials) if t.command.kind is MotionKind.SQUARE]
        if not squares:
            raise CalibrationError(
                f"UMBmark needs measured square trials of robot {robot!r} in both directions; "
                "the selection has none"
            )
        from odolab.analysis import analyze_trials

        # one analysis of the selection: the ratios start and the [noise] (straight runs, turns)
        analysis = analyze_trials(sel.trials) if cache is None else cache.get(sel.trials)
        ratios: tuple[CalibrationResult, BaseChoice] | None = None
        if all(t.encoder_log is not None for t in squares):
            try:  # the ratios of the same selection fix the scale UMBmark cannot
                by_ratios, ratios_base, _, _ = _ratios(nb, sel, request, robot, analysis)
                ratios = (by_ratios, ratios_base)
            except CalibrationError:
                ratios = None
        base = umbmark_start(nb, robot, squares, ratios, request.params, request.params_source)
        umb, how = umbmark_from_squares(squares, base.params, request.side, base.scale_sd)
        umb = umb.with_noise(analysis)
        result, used = umb.calibration, squares
    version = None
    if request.record:
        version = record_calibration(nb, result, base.params.with_(name=robot), trials=used)
    return CalibrationOutcome(
        method=request.method,
        robot=robot,
        base=base,
        result=result,
        selection=sel,
        umbmark=umb,
        version=version,
        how=how,
        terrain=terrain,
    )


def _with_robot(req: SelectionRequest, robot: str) -> SelectionRequest:
    return SelectionRequest(req.campaigns, req.exclude, robot)
