"""The lab report: one self-contained HTML file (figures embedded), the PNGs, and results.json.

Every number the HTML shows is read from the same dict that is written to ``results.json``, so
the text, the tables and the JSON agree by construction.
"""

from __future__ import annotations

import base64
import io
import textwrap
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

from odolab.analysis.core import MOTIONS, LabAnalysis, MotionAnalysis
from odolab.analysis.table1 import table1
from odolab.calibration.ratios import CalibrationResult
from odolab.calibration.umbmark import UmbmarkResult
from odolab.core import numfmt
from odolab.core.errors import OdolabError
from odolab.core.text import safe_file_name
from odolab.core.writing import (
    given_folder,
    strict_json,
    strict_value,
    sub_folder,
    write_bytes_file,
    write_png,
    write_text_file,
)
from odolab.report import figures as F
from odolab.report.models_section import (
    ModelEvidence,
    consistency_view,
    models_view,
    plot_learning_curve,
    plot_model_comparison,
    plot_nees,
    questions_view,
    slip_view,
)
from odolab.report.view import (
    MOTION_NAMES,
    SIGN_CONVENTION,
    extra_view,
    fits_rows,
    fmt,
    iteration_header,
    provenance_rows,
    table1_rows,
    validation_view,
    verdict,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["build_results", "jsonable", "summary_sentences", "write_report"]

Calibration = CalibrationResult | UmbmarkResult
Progress = Callable[[str], None]


def jsonable(obj: object) -> object:
    """``obj`` as JSON holds it: NumPy values as Python's, tuples as lists, NaN/inf as None
    (:func:`odolab.core.writing.strict_value`, the one rule)."""
    return strict_value(obj)


# kept for callers of the old names: one formatting rule now (odolab.report.view)
_jsonable = jsonable
_fmt = fmt
_validation_view = validation_view
_extra_view = extra_view


def _calib_dict(c: Calibration) -> dict[str, object]:
    if isinstance(c, UmbmarkResult):
        d = c.to_dict()
        d["old_params"] = c.calibration.old_params.to_dict()
        d["method"] = "umbmark"
        return d
    return c.to_dict()


def summary_sentences(results: Mapping[str, Any]) -> list[str]:
    """Plain-language findings built from ``results`` (the numbers are the JSON's, formatted
    by :mod:`odolab.core.numfmt`: the digits each interval supports)."""
    out: list[str] = []
    what = {
        "rotation": "actual/predicted rotation",
        "pivot": "actual/predicted pivot rotation",
        "x": "actual/predicted x",
        "y_forward": "y error per metre travelled forward",
        "y_reverse": "y error per metre travelled in reverse",
    }
    for row in results["table1"]:
        lo, hi = row["ratio_ci95"]
        s = (
            f"{what[row['motion']]} on {row['terrain']}: "
            f"{numfmt.with_ci(row['ratio'], lo, hi)} {row['ratio_unit']} (n = {row['n']})"
        )
        if "sigma" in row:
            s += (
                f"; random error σ = {numfmt.with_ci(row['sigma'], *row['sigma_ci95'])} "
                f"{row['unit']} at {fmt(row['sigma_at'])} {row['unit']}"
            )
        out.append(s + ".")
    for m in results["analysis"]["motions"]:
        if m["growth"] is not None:
            out.append(
                f"Growth of σ with distance/angle, {MOTION_NAMES.get(m['motion'], m['motion'])} "
                f"on {m['terrain']}: "
                f"{m['growth']['verdict']}."
            )
    for t in results["analysis"]["terrain_tests"]:
        name = MOTION_NAMES.get(t["motion"], t["motion"])  # not the internal "y_forward"
        rest = t["verdict"].split(": ", 1)[-1]
        out.append(f"{name[0].upper()}{name[1:]}: {rest}.")
    for name, c in results["calibration"].items():
        p = c["params"]
        out.append(
            f"Calibration '{name}': left/right wheel radius {fmt(p['left_wheel_radius'], 5)}/"
            f"{fmt(p['right_wheel_radius'], 5)} m, track width {fmt(p['track_width'], 5)} m."
        )
    models = results.get("models")
    if models:
        out.append(f"Kinematic model: {models['recommended']} ({models['reason']}).")
    slip = results.get("slip")
    if slip:
        c = slip["comparison"]
        seconds = slip["exploration"]["seconds"]
        out.append(
            f"Slip model from {fmt(seconds)} s of exploration: against diff, extended and icr "
            f"fitted on the same runs, recommended {c['recommended']} ({c['reason']})."
        )
        answer = slip["speed_question"].get("answer")
        if answer:
            out.append(f"Speed question: {answer}.")
        from odolab.report.models_section import slip_nees_sentence

        nees = slip_nees_sentence(slip.get("nees") or {})
        if nees:
            out.append(f"Slip model's covariance: {nees}")
    cons = results.get("consistency")
    if cons:
        s = cons["summary"]
        lo, hi = s["mean_bounds95"]
        out.append(
            f"Propagated covariance: mean NEES {numfmt.plain(s['mean_nees'], 3)} over "
            f"{s['n']} pieces (95 % bounds {numfmt.plain(lo, 3)} to {numfmt.plain(hi, 3)}), "
            f"{100.0 * s['fraction_inside']:.0f} % of pieces inside their own bounds: "
            f"{s['verdict']}."
        )
    return out


def build_results(
    analysis: LabAnalysis,
    calibrations: Mapping[str, Calibration],
    validation: Mapping[str, object] | None = None,
    extra: Mapping[str, object] | None = None,
    evidence: ModelEvidence | None = None,
) -> dict[str, object]:
    """The dict written to results.json: every number in the report."""
    ev = evidence or ModelEvidence()
    res = {
        "generated": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "table1": table1(analysis),
        "analysis": analysis.to_dict(),
        "calibration": {name: _calib_dict(c) for name, c in calibrations.items()},
        "validation": dict(validation) if validation is not None else None,
        "extra": dict(extra) if extra is not None else None,
        "models": ev.models_dict(),
        "consistency": ev.consistency_dict(),
        "questions": ev.questions_dict(),
        "slip": ev.slip_dict(),
        "slip_note": ev.slip_note or None,
        "evidence_missing": list(ev.missing),
    }
    doc = jsonable(res)
    assert isinstance(doc, dict)  # (jsonable keeps a dict a dict)
    doc["summary"] = summary_sentences(doc)
    return doc


@dataclass
class _Figure:
    name: str
    title: str
    caption: str
    b64: str = ""
    group: str = "evidence"  #: the section it belongs to


@dataclass(frozen=True)
class _Plan:
    """One figure to draw: its file name, title, caption, drawing function, section and size."""

    name: str
    title: str
    caption: str
    draw: Callable[[Axes], object]
    group: str = "evidence"
    size: tuple[float, float] = (6.0, 4.0)


#: figure text legible when the figure is shown at 100 % of a phone's width: the plans' sizes
#: are drawn _SCALE times smaller (6 in -> 4.5 in) at a dpi as much higher (the same pixels),
#: so 10 pt is 11.4 px where a phone shows the figure 368 px wide (9 pt on 6 in was 7.7 px)
_RC: dict[str, float] = {
    "font.size": 10,
    "axes.titlesize": 11,
    "axes.labelsize": 10,
    "legend.fontsize": 10,
}
_SCALE = 0.75
_DPI = 160
_LEGEND_WRAP = 44  #: characters of a legend line (a 4.5 in figure holds about 50 at 10 pt)
_TITLE_WRAP = 50  #: characters of a title line (at 11 pt)


def _legend_below(fig: Figure, ax: Axes, size: tuple[float, float]) -> None:
    """Move the legend under the plot (it never hides data) and grow the figure to hold it."""
    leg = ax.get_legend()
    if leg is None:
        return
    title = leg.get_title().get_text() or None
    rows = F.legend_outside(ax, fontsize=_RC["legend.fontsize"], title=title, wrap=_LEGEND_WRAP)
    if rows:
        fig.set_size_inches(size[0], size[1] + 0.2 * rows + 0.3)


_PAD_IN = 0.06  #: inches between the figure's edge and the outermost text


def _fit_margins(fig: Figure, ax: Axes) -> None:
    """Place ``ax`` so that its labels, title and the legend under it just fit the figure.

    One measurement of the decorations' extent, then the margins: what matplotlib's constrained
    layout does for one axes, without its second pass and its extra draw at save time (the
    report's figures took 1.56x the CPU with it; benchmarks/bench_report_figures.py). Each margin
    is capped (a quarter of the width on either side, a quarter of the height above, half of it
    below, where the legend goes): a label longer than that is cut at the figure's edge rather
    than the plot squeezed to nothing."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    renderer = FigureCanvasAgg(fig).get_renderer()  # type: ignore[no-untyped-call]
    w, h = fig.get_size_inches() * fig.dpi
    box = ax.get_window_extent(renderer)
    tight = ax.get_tightbbox(renderer)
    if tight is None:
        return
    pad = _PAD_IN * fig.dpi
    left = min((box.x0 - tight.x0 + pad) / w, 0.25)
    right = min((tight.x1 - box.x1 + pad) / w, 0.25)
    bottom = min((box.y0 - tight.y0 + pad) / h, 0.5)
    top = min((tight.y1 - box.y1 + pad) / h, 0.25)
    fig.subplots_adjust(left=left, right=1.0 - right, bottom=bottom, top=1.0 - top)


def _render(fig_dir: Path, plans: list[_Plan]) -> list[_Figure]:
    import matplotlib as mpl
    from matplotlib.figure import Figure

    done: list[_Figure] = []
    with mpl.rc_context(_RC):  # type: ignore[arg-type]
        for p in plans:
            size = (p.size[0] * _SCALE, p.size[1] * _SCALE)
            fig = Figure(figsize=size, dpi=_DPI)
            ax = fig.add_subplot()
            p.draw(ax)
            # a user's name (cut by figure_text) can make a title longer than the figure
            title = ax.get_title()
            if len(title) > _TITLE_WRAP and "\n" not in title:
                ax.set_title(textwrap.fill(title, _TITLE_WRAP, break_long_words=False))
            _legend_below(fig, ax, size)
            _fit_margins(fig, ax)
            name = safe_file_name(p.name, what="figure name")  # terrains are user text
            png = io.BytesIO()
            write_png(fig, png)  # encoded once: the file and the page's copy
            write_bytes_file(fig_dir / f"{name}.png", png.getvalue(), what="report figure")
            b64 = base64.b64encode(png.getvalue()).decode("ascii")
            done.append(_Figure(name, p.title, p.caption, b64, p.group))
    return done


def _motion_plans(m: MotionAnalysis) -> list[_Plan]:
    key = f"{m.motion}_{m.terrain}".replace(" ", "_")
    unit = MOTIONS[m.motion]["unit"]
    where = f"{MOTION_NAMES.get(m.motion, m.motion)} on {m.terrain}"
    plans = [
        _Plan(
            f"fit_{key}",
            f"{where}: fit",
            "Trials, least-squares line with an intercept (slope with 95% CI) and the ideal line"
            + (
                "; dashed: the proportional fit actual = ratio × predicted through the origin, "
                "Table I's ratio."
                if m.ratio_fit is not None
                else "."
            ),
            partial(F.plot_fit, m),
            "systematic",
        ),
        _Plan(
            f"residuals_{key}",
            f"{where}: residuals",
            "Residuals of the fit with the fitted ±1.96 σ(d) band.",
            partial(F.plot_residuals, m),
            "random",
        ),
    ]
    if m.groups:
        g = max(m.groups, key=lambda g: (g.n, g.at))
        plans.append(
            _Plan(
                f"histogram_{key}",
                f"{where}: error histogram",
                f"Errors of the {g.n} trials at {fmt(g.at)} {unit} with the fitted Gaussian and "
                "its 95% interval.",
                partial(F.plot_histogram, g, unit),
                "random",
            )
        )
    if m.growth is not None:
        plans.append(
            _Plan(
                f"growth_{key}",
                f"{where}: growth of σ",
                "σ at each repeated distance/angle (95% CI), the ML fit σ = a·d^p and the "
                "candidate laws p = 0.5, 1, 1.5.",
                partial(F.plot_growth, m),
                "random",
            )
        )
    return plans


def _terrain_plans(analysis: LabAnalysis) -> list[_Plan]:
    plans: list[_Plan] = []
    for terrain in analysis.terrains:
        if analysis.get("x", terrain) and (
            analysis.get("y_forward", terrain) or analysis.get("y_reverse", terrain)
        ):
            plans.append(
                _Plan(
                    f"ellipses_{terrain}",
                    f"End-point errors on {terrain}",
                    "x and y errors of each trial, grouped by commanded distance, with 95% "
                    "covariance ellipses where a distance was repeated at least 3 times.",
                    partial(F.plot_error_ellipses, analysis, terrain),
                    "random",
                    (6.0, 5.0),
                )
            )
    for t in analysis.terrain_tests:
        through_origin = all(
            m.ratio_fit is not None for m in analysis.motions if m.motion == t.motion
        )
        plans.append(
            _Plan(
                f"terrains_{t.motion}",
                f"{MOTION_NAMES.get(t.motion, t.motion)}: terrains side by side",
                "Each terrain's trials and its line with an intercept.",
                partial(F.plot_terrains, analysis, t.motion),
                "terrain",
            )
        )
        plans.append(
            _Plan(
                f"terrain_slopes_{t.motion}",
                f"{MOTION_NAMES.get(t.motion, t.motion)}: slope per terrain",
                t.verdict().split(": ", 1)[-1]
                + (
                    ". The F-test compares the slopes of the lines with an intercept; squares: "
                    "the ratios through the origin (Table I)."
                    if through_origin
                    else "."
                ),
                partial(F.plot_terrain_slopes, analysis, t.motion),
                "terrain",
                (6.0, 3.2),
            )
        )
    return plans


def _calibration_plans(
    analysis: LabAnalysis, calibrations: Mapping[str, Calibration]
) -> list[_Plan]:
    plans: list[_Plan] = []
    news = {n: c.params for n, c in calibrations.items()}
    if analysis.params is not None and news:
        used = [
            c.provenance.get("terrain")
            for c in calibrations.values()
            if isinstance(c, CalibrationResult)
        ]
        both = [
            t for t in analysis.terrains if analysis.get("rotation", t) and analysis.get("x", t)
        ]
        cal_terrain = next((t for t in used if t), both[0] if both else None)
        for motion in ("rotation", "x"):
            if analysis.get(motion, cal_terrain) is not None:
                plans.append(
                    _Plan(
                        f"calibration_{motion}",
                        f"Old vs new parameters: {motion} ({cal_terrain})",
                        "Predictions of the same trials re-scaled with each new parameter set "
                        "(both wheels alike).",
                        partial(
                            F.plot_calibration_effect,
                            analysis,
                            analysis.params,
                            news,
                            motion,
                            terrain=cal_terrain,
                        ),
                        "calibration",
                    )
                )
    for name, c in calibrations.items():
        if isinstance(c, UmbmarkResult):
            after = c.e_max_syst_after
            plans.append(
                _Plan(
                    f"umbmark_{name}",
                    f"UMBmark ({name})",
                    "Return-position errors (odometry − measured) and their centres: "
                    f"E_max,syst = {numfmt.plain(c.e_max_syst, 3)} m"
                    + (
                        f", after correction {numfmt.plain(after, 3)} m."
                        if after is not None
                        else "."
                    ),
                    partial(F.plot_umbmark, c.cw_errors, c.ccw_errors, after=c.after),
                    "calibration",
                    (6.0, 5.0),
                )
            )
    return plans


def _figure_plan(
    analysis: LabAnalysis,
    calibrations: Mapping[str, Calibration],
    validation_figure: Callable[[Axes], Axes] | None,
    extra_figures: Mapping[str, tuple[str, str, Callable[[Axes], object]]] | None = None,
    evidence: ModelEvidence | None = None,
) -> list[_Plan]:
    plans = [p for m in analysis.motions for p in _motion_plans(m)]
    plans += _terrain_plans(analysis)
    plans += _calibration_plans(analysis, calibrations)
    if validation_figure is not None:
        plans.append(
            _Plan(
                "validation",
                "Validation",
                "The old and the new parameters against the IMU.",
                validation_figure,
                "validation",
                (6.4, 4.2),
            )
        )
    for name, (title, caption, draw) in (extra_figures or {}).items():
        plans.append(_Plan(name, title, caption, draw, "validation", (6.4, 4.2)))
    plans += _evidence_plans(evidence)
    return plans


def _evidence_plans(evidence: ModelEvidence | None) -> list[_Plan]:
    """The model comparison's and the NEES figures, when there is data for them."""
    plans: list[_Plan] = []
    if evidence is not None and evidence.comparison is not None:
        cmp = evidence.comparison
        plans.append(
            _Plan(
                "model_comparison",
                "Held-out segment error per kinematic model",
                "Mean over the held-out segments (1 m of path or 90 degrees of turn each) with "
                "its 95 % bootstrap CI; green: the recommended model (the simplest that is not "
                "worse than the best; none when the data cannot separate them).",
                partial(plot_model_comparison, cmp),
                "models",
                (6.0, 3.6),
            )
        )
    curve = (
        ((evidence.slip or {}).get("comparison") or {}).get("learning_curve") if evidence else None
    )
    if curve:
        plans.append(
            _Plan(
                "learning_curve",
                "Learning curve: held-out error against seconds of exploration",
                "Each model fitted on the first seconds of the exploration run alone; mean "
                "end-point error over the held-out runs. A model missing at a length could not "
                "be fitted from that much data (the table says why); lines that coincide (diff "
                "and extended: the same motion in other units) are drawn one over the other.",
                partial(plot_learning_curve, curve),
                "slip",
                (6.0, 4.0),
            )
        )
    if evidence is not None and evidence.nees:
        plans.append(
            _Plan(
                "nees_pieces",
                "NEES of every piece, per run",
                "Each dot one piece (log scale); if the covariance is honest about 95 % of them "
                "lie in the green band and their mean is near 3.",
                partial(plot_nees, evidence.nees),
                "consistency",
                (6.0, 4.0),
            )
        )
    return plans


def _report_folder(out_dir: str | Path, figures: bool = True) -> tuple[Path, Path | None]:
    out = given_folder(
        out_dir, expected="the report folder", cannot="the report folder", error=OdolabError
    )
    return out, sub_folder(out, "figures", what="report figures") if figures else None


def _page(
    results: Mapping[str, Any],
    analysis: LabAnalysis,
    calibrations: Mapping[str, Calibration],
    figs: list[_Figure],
    reference: Mapping[tuple[str, str], Any] | None,
    figures_left_out: bool = False,
) -> str:
    import jinja2

    from odolab.core.text import display_value

    env = jinja2.Environment(
        loader=jinja2.PackageLoader("odolab.report", "templates"),
        # every template escaped (report.html.j2's ".j2" never matched select_autoescape(["html"]))
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        finalize=display_value,  # control and bidi characters shown, as the CLI shows them
    )
    cal_views = []
    for name, c in calibrations.items():
        prov = (c.calibration if isinstance(c, UmbmarkResult) else c).provenance
        rows, iterations = provenance_rows(prov)
        cal_views.append(
            {
                "name": name,
                "provenance": rows,
                "iterations": iterations,
                "iteration_header": iteration_header(prov),
            }
        )
    return env.get_template("report.html.j2").render(
        r=results,
        sign=SIGN_CONVENTION,
        verdict=verdict(
            analysis, calibrations, results["table1"], results["validation"], results["extra"]
        ),
        table1=table1_rows(results["table1"], reference),
        reference=reference is not None,
        fits=fits_rows(analysis),
        calibrations=cal_views,
        figures=figs,
        figures_left_out=figures_left_out,
        fmt=fmt,
        p_value=numfmt.p_value,
        with_ci=numfmt.with_ci,
        with_open_ci=numfmt.with_open_ci,
        val=validation_view(results["validation"]) if results["validation"] else None,
        ext=extra_view(results["extra"]) if results["extra"] else None,
        mdl=models_view(results["models"]) if results.get("models") else None,
        cons=consistency_view(results["consistency"]) if results.get("consistency") else None,
        qst=questions_view(results["questions"], results.get("slip"))
        if results.get("questions")
        else None,
        slp=slip_view(results["slip"]) if results.get("slip") else None,
        slip_note=results.get("slip_note") or "",
        missing=results.get("evidence_missing") or [],
    )


def _numbers_only(results: dict[str, object]) -> dict[str, object]:
    """``results`` for results.json: a ground truth's embedded photo (base64 PNG, megabytes) is
    the page's, not a number; results.json says its size instead."""
    extra = results.get("extra")
    if not isinstance(extra, dict) or not isinstance(extra.get("ground_truth"), list):
        return results
    truths = [
        {k: v for k, v in g.items() if k != "image"}
        | ({"image_base64_chars": len(g["image"])} if isinstance(g.get("image"), str) else {})
        if isinstance(g, dict)
        else g
        for g in extra["ground_truth"]
    ]
    return {**results, "extra": {**extra, "ground_truth": truths}}


def write_report(
    out_dir: str | Path,
    analysis: LabAnalysis,
    calibrations: Mapping[str, Calibration] | None = None,
    validation: Mapping[str, object] | None = None,
    *,
    validation_figure: Callable[[Axes], Axes] | None = None,
    extra_figures: Mapping[str, tuple[str, str, Callable[[Axes], object]]] | None = None,
    extra: Mapping[str, object] | None = None,
    reference: Mapping[tuple[str, str], Any] | None = None,
    evidence: ModelEvidence | None = None,
    progress: Progress | None = None,
    figures: bool = True,
) -> Path:
    """Write ``report.html``, ``figures/*.png`` and ``results.json`` to ``out_dir``.

    ``validation`` is any JSON-able mapping (e.g. an IMU comparison's ``to_dict()``);
    ``validation_figure`` draws its figure on a given axes, ``extra_figures`` (name -> title,
    caption, draw) more figures beside it; ``reference`` is a published
    Table I to set beside this one (:data:`odolab.analysis.reference.LAB_REPORT_TABLE1`);
    ``evidence`` the comparison of kinematic models and the NEES of runs with ground truth
    (:class:`odolab.report.models_section.ModelEvidence`), each shown when present.
    ``figures=False`` draws none (most of a report's time): the page says so at its top, and
    its tables and ``results.json`` hold the same numbers. Returns the HTML path.
    """
    say = progress or (lambda _: None)
    calibrations = dict(calibrations or {})
    out, fig_dir = _report_folder(out_dir, figures)
    results = build_results(analysis, calibrations, validation, extra, evidence)
    figs: list[_Figure] = []
    if fig_dir is not None:
        plans = _figure_plan(analysis, calibrations, validation_figure, extra_figures, evidence)
        say(f"drawing {len(plans)} figures")
        figs = _render(fig_dir, plans)
    else:
        say("figures left out")
    results["figures"] = {f.name: f"figures/{f.name}.png" for f in figs}
    # through a temporary file in ``out``: a link planted at either name is replaced, not followed
    write_text_file(out / "results.json", strict_json(_numbers_only(results)),
                    what="report results")  # fmt: skip
    path = out / "report.html"
    page = _page(results, analysis, calibrations, figs, reference, fig_dir is None)
    write_text_file(path, page, what="report")
    say(f"report written to {path}")
    return path
