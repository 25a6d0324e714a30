"""The lab report of the notebook: ``odolab report``, the web's /report.html and
``/api/report`` all come from :func:`report_content`.

The report's Table I is the selection's (:func:`odolab.app.analysis.analyze`); its calibrations
are of one robot, chosen as every calibrate face chooses it
(:func:`odolab.app.calibration.choose_robot`: the one named by the selection's robot, else the
selection's one robot, else the one the user's parameters are of; several robots and none named:
no calibration, and the report says why), from that robot's trials and from the version they were driven with
(:func:`odolab.app.calibration.choose_base`): ratios, then UMBmark iterated from the ratios
result on the squares' encoder logs (the demo's order), or UMBmark's single step from the driven
version when a square has no log. What was chosen is written into the report (``extra``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from odolab.app.analysis import AnalysisResult, analyze_selection
from odolab.app.calibration import (
    BaseChoice,
    choose_base,
    choose_robot,
    umbmark_from_squares,
    umbmark_start,
)
from odolab.app.selection import (
    EVERY_CAMPAIGN,
    Selection,
    SelectionRequest,
    select_among,
    validation_campaigns,
)
from odolab.core.errors import NEUTRAL, CalibrationError, OdolabError
from odolab.core.trials import MotionKind, TrialStatus

if TYPE_CHECKING:
    from odolab.analysis import LabAnalysis
    from odolab.app.analysis import AnalysisCache
    from odolab.calibration import CalibrationResult, UmbmarkResult
    from odolab.core.params import RobotParams
    from odolab.core.trials import Trial
    from odolab.store import Notebook

__all__ = [
    "ReportContent",
    "ReportRequest",
    "report_calibrations",
    "report_content",
    "report_html",
    "report_results",
    "write_notebook_report",
]


@dataclass(frozen=True)
class ReportRequest:
    """Which trials (``selection``), the parameters to calibrate when the user names them
    (``params``, ``params_source``), ground-truth files to summarise, and whether to draw the
    figures (``figures``: most of a report's time)."""

    selection: SelectionRequest = field(default_factory=lambda: EVERY_CAMPAIGN)
    params: RobotParams | None = None
    params_source: str | None = None
    ground_truth: tuple[Path, ...] = ()
    figures: bool = True


@dataclass
class ReportContent:
    """Every number of the report before it is drawn."""

    analysis: AnalysisResult
    calibrations: dict[str, CalibrationResult | UmbmarkResult]
    notes: list[str]  #: why a calibration is missing (one sentence each)
    base: BaseChoice | None
    extra: dict[str, object] = field(default_factory=dict)

    @property
    def reference(self) -> Any:
        """The Jaguar lab report's Table I, beside a Jaguar's report (else None)."""
        from odolab.analysis.reference import LAB_REPORT_TABLE1

        jaguar = self.base is not None and self.base.params.name.startswith("jaguar")
        return LAB_REPORT_TABLE1 if jaguar else None


def report_calibrations(
    nb: Notebook,
    selection: Selection,
    trials: list[Trial],
    validation: set[str],
    request: ReportRequest,
    analysis: LabAnalysis | None = None,
) -> tuple[
    dict[str, CalibrationResult | UmbmarkResult], list[str], BaseChoice | None, BaseChoice | None
]:
    """The report's calibrations (see the module's rule), the notes on what is missing, the
    parameters they start from, and where UMBmark started
    (:func:`odolab.app.calibration.umbmark_start`; None: no UMBmark). ``analysis``: the
    selection's, reused when the robot's trials are the selection's."""
    from odolab.analysis import analyze_trials
    from odolab.calibration import ratios_from_analysis

    notes: list[str] = []
    if not selection.measured:
        return {}, ["no calibration: no measured trial"], None, None
    try:  # the calibrate faces' rule: several robots and none named is refused, and said
        robot = choose_robot(selection.trials, request.selection.robot, request.params)
    except CalibrationError as err:
        return {}, [f"no calibration: {err}"], None, None
    req = SelectionRequest(request.selection.campaigns, request.selection.exclude, robot)
    mine = select_among(trials, validation, req)
    try:
        base = choose_base(nb, robot, mine.trials, request.params, request.params_source)
    except CalibrationError as err:
        return {}, [f"no calibration: {err}"], None, None
    out: dict[str, CalibrationResult | UmbmarkResult] = {}
    ratios: CalibrationResult | None = None
    umb_start: BaseChoice | None = None
    try:
        same = [t.trial_id for t in mine.trials] == [t.trial_id for t in selection.trials]
        if analysis is None or not same:
            analysis = analyze_trials(mine.trials)
        ratios = out["ratios"] = ratios_from_analysis(analysis, base.params)
    except OdolabError as err:
        notes.append(f"no ratios calibration: {err}")
    squares = [
        t
        for t in mine.trials
        if t.command.kind is MotionKind.SQUARE
        and t.status is TrialStatus.MEASURED
        and t.measured is not None
    ]
    if squares:
        try:
            start = umbmark_start(
                nb,
                robot,
                squares,
                None if ratios is None else (ratios, base),
                request.params,
                request.params_source,
            )
            umb, _ = umbmark_from_squares(squares, start.params, None, start.scale_sd)
            out["umbmark"] = umb
            umb_start = start
        except CalibrationError as err:
            notes.append(f"no UMBmark calibration: {err}")
    return out, notes, base, umb_start


def report_content(
    nb: Notebook, request: ReportRequest = ReportRequest(), cache: AnalysisCache | None = None
) -> ReportContent:
    """Table I, the calibrations and the notes of the report of the notebook's selection
    (``cache``: a server's analysis cache)."""
    from odolab.report.ground_truth import ground_truth_summary

    truths = [ground_truth_summary(g) for g in request.ground_truth]  # checked first
    trials = nb.load_trials()
    validation = validation_campaigns(nb)
    selection = select_among(trials, validation, request.selection)
    analysis = analyze_selection(selection, cache)
    calibrations, notes, base, umb_start = report_calibrations(
        nb, selection, trials, validation, request, analysis.analysis
    )
    # (a file: the library's words for the options)
    extra: dict[str, object] = {"trials_used": NEUTRAL.say(selection.describe())}
    if base is not None:
        extra["calibrated_from"] = base.reason
    if umb_start is not None:
        extra["umbmark_from"] = umb_start.reason
    if notes:  # why a calibration is missing: on every face (results.json, /api/report)
        extra["not_calibrated"] = "; ".join(notes)
    if truths:
        extra["ground_truth"] = truths
    return ReportContent(analysis, calibrations, notes, base, extra)


def report_results(
    nb: Notebook, request: ReportRequest = ReportRequest(), cache: AnalysisCache | None = None
) -> dict[str, object]:
    """The numbers ``results.json`` holds (without the figures' file names): ``/api/report``."""
    from odolab.report import build_results

    c = report_content(nb, request, cache)
    return build_results(c.analysis.analysis, c.calibrations, extra=c.extra)


@dataclass(frozen=True)
class ReportOutcome:
    """Where the report went, and what it holds."""

    path: Path
    content: ReportContent


def write_notebook_report(
    nb: Notebook, out: str | Path, request: ReportRequest = ReportRequest()
) -> ReportOutcome:
    """Write the report (HTML, figures, ``results.json``) of the notebook to ``out``."""
    from odolab.report import write_report

    c = report_content(nb, request)
    path = write_report(
        out,
        c.analysis.analysis,
        c.calibrations,
        reference=c.reference,
        extra=c.extra,
        figures=request.figures,
    )
    return ReportOutcome(path, c)


def report_html(nb: Notebook, request: ReportRequest = ReportRequest()) -> bytes:
    """The report's HTML (self-contained), as :func:`write_notebook_report` writes it."""
    import tempfile

    with tempfile.TemporaryDirectory(prefix="odolab-report-") as tmp:
        try:
            out = write_notebook_report(nb, Path(tmp) / "report", request)
        except OSError as err:
            raise OdolabError(f"the report could not be written ({err})") from err
        return out.path.read_bytes()
