"""The report's kinematic-model section: which model the robot needs, and the open questions.

Self-contained pieces for whatever report layout is current (the report package is being
redesigned): HTML fragments (every piece of text escaped) and matplotlib figures.

- :func:`model_comparison_html` — the table of :func:`odolab.calibration.compare.compare_models`
  (held-out end-point error, RPE, drift, BIC with 95 % CIs) and the recommendation;
- :func:`questions_html` — each open question's conditions, effects and trend, in words;
- :func:`plot_model_comparison`, :func:`plot_questions` — the same as figures;
- :func:`models_section_html` — all of it as one ``<section>``.

For the lab report (:func:`odolab.report.write_report`): :class:`ModelEvidence` carries the model
comparison and the NEES of held-out runs; :func:`models_view` and :func:`consistency_view` turn
their ``results.json`` entries into cells for the template (text only, escaped by it);
:func:`plot_nees` draws the NEES of every piece against its chi-square bounds.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from html import escape
from typing import TYPE_CHECKING, Any

import numpy as np

from odolab.analysis.questions import ExperimentResult
from odolab.calibration.compare import UNDECIDED, Estimate, ModelComparison
from odolab.core import numfmt
from odolab.core.errors import NEUTRAL
from odolab.core.text import figure_text
from odolab.metrics.consistency import DOF, RunNees, first_order_note, nees_summary
from odolab.report.view import Cell

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "ModelEvidence",
    "consistency_view",
    "model_comparison_html",
    "models_section_html",
    "models_view",
    "plot_learning_curve",
    "plot_model_comparison",
    "plot_nees",
    "plot_questions",
    "questions_html",
    "slip_nees_sentence",
    "slip_view",
]


def _ci(e: Estimate | None, fmt: str) -> str:
    if e is None:
        return ""
    if not (math.isfinite(e.low) and math.isfinite(e.high)):
        return format(e.value, fmt)
    return f"{e.value:{fmt}} [{e.low:{fmt}}, {e.high:{fmt}}]"


def _recommendation_html(result: ModelComparison) -> str:
    if result.decided:
        return f"<p><b>Recommended: {escape(result.recommended)}</b> ({escape(result.reason)}).</p>"
    why = result.reason.removeprefix(f"{UNDECIDED}: ")
    return f"<p><b>Undecided: no model recommended</b> ({escape(why)}).</p>"


def model_comparison_html(result: ModelComparison) -> str:
    """An HTML table of every model's held-out scores and the recommendation (or why there is
    none: the data cannot separate the models)."""
    how = "cross-validated over" if result.cross_validated else "held out:"
    rows = []
    for s in result.scores:
        if s.problem is not None:
            rows.append(
                f"<tr><td>{escape(s.model)}</td><td>{s.n_params}</td>"
                f'<td colspan="8">{escape(s.problem)}</td></tr>'
            )
            continue
        h = s.held_out
        cells = [
            _ci(s.segment_error, ".4f"),
            _ci(s.ratio_to_best, ".3f"),
            s.verdict,
            _ci(h["endpoint_error"], ".4f"),
            _ci(h["rpe_rmse"], ".4f"),
            _ci(h["drift_pct"], ".2f"),
            _ci(h["drift_deg_per_m"], ".3f"),
            _ci(s.delta_bic, ".1f"),
        ]
        rows.append(
            f"<tr><td>{escape(s.model)}</td><td>{s.n_params}</td>"
            + "".join(f"<td>{escape(c)}</td>" for c in cells)
            + "</tr>"
        )
    params = []
    for s in result.scores:
        if s.fit is None:
            continue
        values = numfmt.coefficients_with_se(
            s.fit.values, s.fit.stderr, name=escape, plus_minus="&plusmn;"
        )
        params.append(f"<li><b>{escape(s.model)}</b>: {values}</li>")
    return (
        '<table class="models">'
        f"<caption>Kinematic models: {len(result.train)} training runs, {how} "
        f"{len(result.held_out)} runs, {result.segments} segments (mean, 95 % CI)</caption>"
        "<tr><th>model</th><th>k</th><th>segment error (m)</th><th>error / best</th>"
        "<th>verdict</th><th>end-point error (m)</th><th>RPE (m)</th>"
        "<th>drift (%)</th><th>drift (deg/m)</th><th>&Delta;BIC vs diff</th></tr>"
        + "".join(rows)
        + "</table>"
        + f"<ul>{''.join(params)}</ul>"
        + f"<p>{escape(_DECISION)}</p>"
        + _recommendation_html(result)
        + learning_curve_html(result.learning_curve)
    )


def learning_curve_html(rows: Sequence[Mapping[str, Any]]) -> str:
    """The learning curve of :func:`odolab.calibration.compare.compare_models` (``curve=``):
    held-out mean end-point error against seconds of exploration data; empty without one."""
    if not rows:
        return ""
    seconds = sorted({float(r["seconds"]) for r in rows})
    models = list(dict.fromkeys(str(r["model"]) for r in rows))
    body = []
    for m in models:
        cells = {float(r["seconds"]): r["endpoint_error"] for r in rows if r["model"] == m}
        body.append(
            f"<tr><td>{escape(m)}</td>"
            + "".join(
                "<td>not fitted</td>" if cells.get(x) is None else f"<td>{cells[x]:.3f}</td>"
                for x in seconds
            )
            + "</tr>"
        )
    return (
        '<table class="models"><caption>Learning curve: held-out mean end-point error (m) of '
        "each model fitted on the first seconds of the exploration run</caption><tr><th>model</th>"
        + "".join(f"<th>{x:g} s</th>" for x in seconds)
        + "</tr>"
        + "".join(body)
        + "</table>"
    )


#: How the recommendation is made, in words (the report and the HTML fragment).
_DECISION = (
    "Decided on the held-out segments (each 1 m of path or 90 degrees of turn; error "
    "sqrt(e_t^2 + (1 m e_r)^2)): the simplest model whose mean error is within 5 % of the best's "
    "(95 % CI of the ratio, paired bootstrap over segments); undecided when the CI neither "
    "rules that out nor shows it."
)


def questions_html(results: Sequence[ExperimentResult]) -> str:
    """Each open question with its conditions (slip %, 95 % CI) and answers."""
    parts = []
    for res in results:
        rows = []
        for c in res.conditions:
            slip = f"{c.mean:.1f} [{c.low:.1f}, {c.high:.1f}]" if c.slip else "stalled"
            stalled = f"{c.stalled} / {c.n}"
            rows.append(
                f"<tr><td>{escape(c.label)}</td><td>{escape(c.condition.terrain)}</td>"
                f"<td>{escape(slip)}</td><td>{stalled}</td></tr>"
            )
        answers = [e.sentence() for e in res.effects]
        if res.trend is not None:
            answers.append(res.trend.sentence())
        parts.append(
            f"<h3>{escape(res.experiment.question)}</h3>"
            '<table class="questions"><tr><th>condition</th><th>terrain</th>'
            "<th>slip (%), 95 % CI</th><th>stalled</th></tr>"
            + "".join(rows)
            + "</table><ul>"
            + "".join(f"<li>{escape(a)}</li>" for a in answers)
            + "</ul>"
        )
    return "".join(parts)


def models_section_html(
    comparison: ModelComparison | None, questions: Sequence[ExperimentResult] = ()
) -> str:
    """The whole section (either part may be absent)."""
    body = ['<section id="kinematic-model"><h2>Kinematic model</h2>']
    if comparison is not None:
        body.append(model_comparison_html(comparison))
    if questions:
        body.append(f"<h2>Open questions (truth: {escape(questions[0].truth)})</h2>")
        body.append(questions_html(questions))
    body.append("</section>")
    return "".join(body)


def plot_model_comparison(result: ModelComparison, ax: Axes | None = None) -> Axes:
    """Held-out segment error of each model (what decides): mean with its 95 % CI."""
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(5.6, 3.6))
    ok = [s for s in result.scores if s.problem is None and s.segment_error is not None]
    for i, s in enumerate(ok):
        e = s.segment_error
        assert e is not None
        lo = e.value - e.low if math.isfinite(e.low) else 0.0
        hi = e.high - e.value if math.isfinite(e.high) else 0.0
        color = "tab:green" if s.model == result.recommended else "tab:blue"
        ax.errorbar([i], [e.value], yerr=[[lo], [hi]], fmt="o", capsize=5, color=color)
    ax.set_xticks(range(len(ok)), [s.model for s in ok])
    ax.set_ylabel(f"held-out segment error (m), {result.segments} segments")
    ax.set_ylim(bottom=0)
    title = result.recommended if result.decided else "undecided (the data cannot separate them)"
    ax.set_title(f"recommended: {title}")
    return ax


def plot_questions(results: Sequence[ExperimentResult]) -> Figure:
    """One panel per question: slip (%) per condition with its 95 % CI (stalls marked)."""
    import matplotlib.pyplot as plt

    n = max(len(results), 1)
    fig, axes = plt.subplots(n, 1, figsize=(7.0, 2.6 * n), squeeze=False)
    for ax, res in zip(axes[:, 0], results, strict=False):
        for i, c in enumerate(res.conditions):
            if c.slip:
                ax.errorbar(
                    [i], [c.mean], yerr=[[c.mean - c.low], [c.high - c.mean]], fmt="o", capsize=4
                )
            else:
                ax.text(i, 0.0, "stalled", ha="center", va="bottom", color="tab:red")
        ax.axhline(0.0, color="0.7", lw=0.8)
        labels = [figure_text(c.label) for c in res.conditions]  # a user's TOML wrote them
        ax.set_xticks(range(len(res.conditions)), labels, fontsize=8)
        ax.set_ylabel("slip (%)")
        question = figure_text(res.experiment.question, limit=270)
        ax.set_title(textwrap.fill(question, 90, break_long_words=False), fontsize=9)
    fig.tight_layout()
    return fig


# -- the lab report's sections -------------------------------------------------------------------


@dataclass(frozen=True)
class ModelEvidence:
    """What the report's model and covariance sections show (either part may be missing).

    ``comparison``: :func:`odolab.calibration.compare.compare_models` on runs with ground truth;
    ``nees``: :func:`odolab.metrics.consistency.run_nees` of held-out runs with parameters that
    have ``[noise]``; ``about_models``/``about_nees``: one sentence each on where the runs and the
    parameters come from; ``missing``: why a part is absent (shown as a note)."""

    comparison: ModelComparison | None = None
    nees: tuple[RunNees, ...] = ()
    about_models: str = ""
    about_nees: str = ""
    missing: tuple[str, ...] = ()
    #: the lab's open questions answered on the virtual robot (:func:`run_open_questions`)
    questions: tuple[ExperimentResult, ...] = ()
    about_questions: str = ""
    #: the slip model against the kinematic ones from an exploration run: the ``slip`` entry of
    #: ``results.json`` (:meth:`odolab.app.models.SlipComparison.to_dict`), None when none ran
    slip: Mapping[str, Any] | None = None
    #: why no exploration was run (or why the slip comparison failed); empty when it ran
    slip_note: str = ""

    def questions_dict(self) -> dict[str, object] | None:
        """The ``questions`` entry of ``results.json`` (None without experiments)."""
        if not self.questions:
            return None
        return {
            "about": self.about_questions,
            "experiments": [r.to_dict() for r in self.questions],
        }

    def models_dict(self) -> dict[str, object] | None:
        """The ``models`` entry of ``results.json`` (None without a comparison)."""
        if self.comparison is None:
            return None
        return {**self.comparison.to_dict(), "about": self.about_models}

    def slip_dict(self) -> dict[str, object] | None:
        """The ``slip`` entry of ``results.json`` (None when no exploration was run)."""
        return dict(self.slip) if self.slip is not None else None

    def consistency_dict(self) -> dict[str, object] | None:
        """The ``consistency`` entry of ``results.json`` (None without NEES)."""
        if not self.nees:
            return None
        beyond, note = first_order_note(self.nees)
        return {
            "summary": {**nees_summary(self.nees).to_dict(), "pieces_past_first_order": beyond},
            "runs": [r.to_dict() for r in self.nees],
            "about": self.about_nees,
            "first_order_note": NEUTRAL.say(note) if note else note,  # (a file's words)
        }


def _est(e: object, unit: str = "") -> str:
    """An :class:`Estimate` as JSON (value, ci95 with None for NaN) with its unit."""
    if not isinstance(e, Mapping) or e.get("value") is None:
        return "-"
    lo, hi = (e.get("ci95") or [None, None])[:2]
    value = float(e["value"])
    bounded = lo is not None and hi is not None and math.isfinite(lo) and math.isfinite(hi)
    if not bounded or (hi - lo) / 2.0 < 1e-6 * max(abs(value), 1.0):
        # no interval, or one too narrow to print (a model that equals the best one); a
        # difference of rounding noise (1e-13) is 0
        value = 0.0 if abs(value) < 1e-9 else value
        return f"{numfmt.plain(value, 4, strip=True)}{unit}"
    return f"{numfmt.with_ci(value, lo, hi)}{unit}"


#: More fitted values than this are shortened in the table (the slip model has 24) ...
_MAX_VALUES = 8
#: ... to these: the coefficients of the speed question (straight driving's slip)
_SPEED_KEYS = ("fwd_v", "fwd_absv", "fwd_v_absv")


def models_view(m: Mapping[str, Any], *, problems_in_table: bool = False) -> dict[str, object]:
    """The "Which kinematic model?" section from ``results["models"]``: one row per model that
    could be fitted, the fitted values, the recommendation, and why the others could not (a
    list beside the table, or with ``problems_in_table`` a row that says it in one sentence)."""
    rows: list[list[Cell]] = []
    problems: list[tuple[str, str]] = []
    for s in m.get("models", []):
        name = str(s.get("model"))
        if s.get("problem") and problems_in_table:
            rows.append(_not_fitted_row(name, s))
            continue
        if s.get("problem"):
            problems.append((name, str(s["problem"])))
            continue
        h = s.get("held_out") or {}
        values = s.get("values") or {}
        stderr = s.get("stderr") or {}
        shown = {k: v for k, v in values.items() if v is not None}
        rest = 0
        if len(shown) > _MAX_VALUES:  # the slip model's 24: the speed question's few
            keys = [k for k in _SPEED_KEYS if k in shown] or list(shown)[:3]
            rest = len(shown) - len(keys)
            shown = {k: shown[k] for k in keys}
        fitted = "; ".join(
            f"{k} {numfmt.with_uncertainty(float(v), float(stderr[k]), show=True)}"
            if stderr.get(k) is not None and float(stderr[k]) > 0
            else f"{k} {numfmt.plain(float(v))}"
            for k, v in shown.items()
        )
        if rest:
            fitted += f"; {rest} more in results.json"
        best = s.get("ratio_to_best")
        rows.append(
            [
                Cell("model", name, "l"),
                Cell("parameters", str(s.get("n_params", "-"))),
                Cell("held-out segment error (m)", _est(s.get("segment_error"))),
                Cell("error / best", _est(best)),
                Cell("verdict", str(s.get("verdict") or "-"), "l"),
                Cell("held-out end-point error (m)", _est(h.get("endpoint_error"))),
                Cell("RPE over 1 m (m)", _est(h.get("rpe_rmse"))),
                Cell("drift (%)", _est(h.get("drift_pct"))),
                Cell("ΔBIC vs diff", _est(s.get("delta_bic"))),
                Cell("fitted values (± std. error)", fitted or "-", "l"),
            ]
        )
    how = "cross-validated over" if m.get("cross_validated") else "scored on"
    n_train, n_held = len(m.get("train") or []), len(m.get("held_out") or [])
    runs = f"fitted on {numfmt.count(n_train, 'run')}, {how} {numfmt.count(n_held, 'held-out run')}"
    recommended = str(m.get("recommended", "-"))
    reason = str(m.get("reason", ""))
    if recommended == UNDECIDED:  # "Recommended: undecided (why)", no "undecided" twice
        reason = reason.removeprefix(f"{UNDECIDED}: ")
    return {
        "rows": rows,
        "problems": problems,
        "recommended": recommended,
        "reason": reason,
        "runs": runs,
        "about": str(m.get("about", "")),
    }


def _not_fitted_row(name: str, s: Mapping[str, object]) -> list[Cell]:
    """A model that could not be fitted, as a row of the models table: why, in one sentence."""
    why = str(s.get("problem") or "").rstrip(".")
    return [
        Cell("model", name, "l"),
        Cell("parameters", str(s.get("n_params", "-"))),
        *(Cell(label, "-") for label in _SCORE_LABELS[:2]),
        Cell("verdict", "not fitted", "l"),
        *(Cell(label, "-") for label in _SCORE_LABELS[2:]),
        Cell("fitted values (± std. error)", f"Not fitted from these runs: {why}.", "l"),
    ]


_SCORE_LABELS = (
    "held-out segment error (m)",
    "error / best",
    "held-out end-point error (m)",
    "RPE over 1 m (m)",
    "drift (%)",
    "ΔBIC vs diff",
)


def learning_curve_view(rows: Sequence[Mapping[str, Any]]) -> dict[str, object]:
    """The learning curve as a table (one row per model, one column per number of seconds:
    held-out mean end-point error, m) and one sentence per model that could not be fitted at
    some length (at which seconds, and why at the longest)."""
    seconds = sorted({float(r["seconds"]) for r in rows})
    models = list(dict.fromkeys(str(r["model"]) for r in rows))
    table: list[list[Cell]] = []
    notes: list[str] = []
    for m in models:
        mine = {float(r["seconds"]): r for r in rows if str(r["model"]) == m}
        cells = [Cell("model", m, "l")]
        missing: list[float] = []
        for x in seconds:
            r = mine.get(x)
            value = None if r is None else r.get("endpoint_error")
            if value is None:
                missing.append(x)
                cells.append(Cell(f"{x:g} s", "not fitted"))
            else:
                cells.append(Cell(f"{x:g} s", numfmt.plain(float(value), 3)))
        table.append(cells)
        if missing:
            last = mine.get(missing[-1]) or {}
            why = str(last.get("problem") or "no fit").rstrip(".")
            at = ", ".join(f"{x:g}" for x in missing)
            notes.append(f"{m}: not fitted at {at} s (at {missing[-1]:g} s: {why}).")
    return {"rows": table, "notes": notes, "seconds": seconds}


def plot_learning_curve(rows: Sequence[Mapping[str, Any]], ax: Axes | None = None) -> Axes:
    """Held-out mean end-point error against seconds of exploration: one line per model (the
    points where it could not be fitted left out; a model never fitted says so in the
    legend)."""
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(6.0, 4.0))
    markers = {"diff": "o", "extended": "s", "icr": "^", "slip": "D"}
    colors = {"diff": "tab:blue", "extended": "tab:green", "icr": "tab:red", "slip": "tab:orange"}
    for m in dict.fromkeys(str(r["model"]) for r in rows):
        pts = sorted(
            (float(r["seconds"]), float(r["endpoint_error"]))
            for r in rows
            if str(r["model"]) == m and r.get("endpoint_error") is not None
        )
        if not pts:
            ax.plot([], [], markers.get(m, "o"), color="0.6", label=f"{m} (not fitted)")
            continue
        xs, ys = zip(*pts, strict=True)
        ax.plot(xs, ys, "-", marker=markers.get(m, "o"), ms=5, color=colors.get(m), label=m)
    ax.set_xlabel("seconds of exploration the model is fitted on")
    ax.set_ylabel("held-out mean end-point error (m)")
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    ax.legend()
    return ax


def _pp(value: float | None, ci: Sequence[float | None] | None) -> str:
    """A difference in percentage points with its 95 % interval."""
    if value is None:
        return "-"
    lo, hi = [*list(ci or []), None, None][:2]
    if lo is None or hi is None or not (math.isfinite(lo) and math.isfinite(hi)):
        return f"{float(value):+.1f}"
    return f"{float(value):+.1f} [{float(lo):+.1f}, {float(hi):+.1f}]"


def slip_view(sl: Mapping[str, Any]) -> dict[str, object]:
    """The "slip model from an exploration" section from ``results["slip"]``: the comparison
    (slip beside the kinematic models, failures as rows), the learning curve, the speed
    question from the slip model's coefficients beside the simulator's measured answer."""
    cmp = sl.get("comparison") or {}
    models = models_view({**cmp, "about": ""}, problems_in_table=True)
    curve = learning_curve_view(cmp.get("learning_curve") or [])
    sq = sl.get("speed_question") or {}
    v_low, v_high = sq.get("v_low"), sq.get("v_high")
    head = f"slip {v_high:g} m/s − slip {v_low:g} m/s (pp, 95 % CI)"
    speed_rows = [
        [
            Cell("answer from", "the slip model's coefficients (this exploration's fit)", "l"),
            Cell(head, _pp(sq.get("gain_pct"), sq.get("ci95"))),
        ]
    ]
    measured = sq.get("measured") or {}
    if measured:
        speed_rows.append(
            [
                Cell(
                    "answer from",
                    "the simulator's speed experiment (measured as the lab would, section IX)",
                    "l",
                ),
                Cell(head, _pp(measured.get("difference_pct"), measured.get("ci95"))),
            ]
        )
    answers = [str(sq["answer"])] if sq.get("answer") else []
    if sq.get("problem"):
        answers.append(str(sq["problem"]))
    ex = sl.get("exploration") or {}
    return {
        "nees": slip_nees_sentence(sl.get("nees") or {}),
        "nees_command": str(sl.get("nees_command", "")).split(),
        "about": str(sl.get("about", "")),
        "models": models,
        "curve": curve,
        "speed_rows": speed_rows,
        "speed_answers": answers,
        "measured_answer": str(measured.get("answer", "")),
        "command": str(sl.get("command", "")).split(),
        "seconds": ex.get("seconds"),
    }


def slip_nees_sentence(n: Mapping[str, Any]) -> str:
    """One sentence on the slip fit's predictive covariance on the held-out runs."""
    if not n:
        return ""
    piece = f"{float(n.get('piece_s', 0.0)):g}"
    if n.get("problem"):
        return f"No NEES on pieces of {piece} s: {n['problem']}"
    lo, hi = n["mean_bounds95"]
    return (
        f"On the held-out runs, pieces of {piece} s each started at the ground truth's pose: "
        f"mean NEES {numfmt.plain(float(n['mean_nees']), 3)} over {n['n']} pieces (expected "
        f"{numfmt.plain(float(n['dof']) / float(n['n']), 3)}, 95 % bounds "
        f"[{numfmt.plain(float(lo), 3)}, {numfmt.plain(float(hi), 3)}]): the covariance is "
        f"{n['verdict']}."
    )


def consistency_view(c: Mapping[str, Any]) -> dict[str, object]:
    """The "Is the covariance honest?" section from ``results["consistency"]``."""
    s = c["summary"]
    lo, hi = s["mean_bounds95"]
    s_lo, s_hi = s["single_bounds95"]
    rows = [
        [
            Cell("pieces", str(s["n"])),
            Cell("mean NEES", numfmt.plain(float(s["mean_nees"]), 3)),
            Cell(
                f"95 % bounds of the mean (χ², {int(s['dof'])} dof)",
                numfmt.interval(lo, hi, numfmt.decimals_for((hi - lo) / 2.0) + 1),
            ),
            Cell("inside one piece's bounds", f"{100.0 * float(s['fraction_inside']):.0f} %"),
            Cell("above", f"{100.0 * float(s['fraction_above']):.0f} %"),
            Cell("verdict", str(s["verdict"]), "l"),
        ]
    ]
    per_run = [
        f"{r['name']} {numfmt.plain(float(r['mean_nees']), 3)} ({len(r['nees'])})"
        for r in c.get("runs", [])
        if r.get("mean_nees") is not None
    ]
    return {
        "rows": rows,
        "single": f"[{numfmt.plain(s_lo, 3)}, {numfmt.plain(s_hi, 3)}]",
        "expected_inside": "95 %",
        "per_run": "; ".join(per_run),
        "about": str(c.get("about", "")),
        "first_order_note": str(c.get("first_order_note") or ""),
    }


def plot_nees(runs: Sequence[RunNees], ax: Axes | None = None) -> Axes:
    """NEES of every piece (log scale) per run, the single-piece 95 % chi-square band and 3."""
    import matplotlib.pyplot as plt

    from odolab.core.distributions import chi2_mean_bounds

    if ax is None:
        _, ax = plt.subplots(figsize=(6.0, 4.0))
    lo, hi = chi2_mean_bounds(DOF, 1)  # one piece
    ax.axhspan(lo, hi, color="tab:green", alpha=0.12, label="95 % band of one piece (χ², 3 dof)")
    pieces = sum(int(np.asarray(r.nees).size) for r in runs)
    removed = sum(r.dof_removed for r in runs if np.asarray(r.nees).size)
    expected = (DOF * pieces - removed) / pieces if pieces else float(DOF)
    label = (
        f"expected mean ({expected:.3g}: {removed} fitted yaw offsets)" if removed
        else f"expected mean ({DOF})"
    )  # fmt: skip
    ax.axhline(expected, color="tab:green", lw=1.0, label=label)
    for i, r in enumerate(runs):
        v = np.asarray(r.nees, dtype=float)
        v = v[np.isfinite(v) & (v > 0)]
        jitter = np.linspace(-0.25, 0.25, v.size) if v.size > 1 else np.zeros(v.size)
        ax.plot(i + jitter, v, "o", ms=3, color="tab:blue", alpha=0.7)
    ax.set_yscale("log")
    ax.set_xticks(range(len(runs)), [figure_text(r.name) for r in runs], fontsize=8)
    ax.set_xlabel("run")
    ax.set_ylabel("NEES of one piece")
    ax.legend()
    return ax


def questions_view(
    q: Mapping[str, Any], slip_model: Mapping[str, Any] | None = None
) -> dict[str, object]:
    """The "open questions" section from ``results["questions"]``: per question, a row per
    condition (slip with its 95 % CI, or how many runs stalled) and the answers in words; with
    ``slip_model`` (``results["slip"]``) the speed question also has the slip model's answer."""
    model_answer = str(((slip_model or {}).get("speed_question") or {}).get("answer") or "")
    out = []
    for e in q.get("experiments", []):
        rows = []
        for c in e.get("conditions", []):
            lo, hi = c.get("ci95") or [None, None]
            n, stalled = int(c.get("n", 0)), int(c.get("stalled", 0))
            if c.get("slip_pct") is None or stalled == n:
                slip = "stalled"
            elif lo is None or hi is None or not (math.isfinite(lo) and math.isfinite(hi)):
                slip = numfmt.plain(float(c["slip_pct"]), 3)
            else:
                slip = numfmt.with_ci(float(c["slip_pct"]), float(lo), float(hi))
            rows.append(
                [
                    Cell("condition", str(c.get("label", "")), "l"),
                    Cell("terrain", str(c.get("terrain", "")), "l"),
                    Cell("runs", str(n)),
                    Cell("slip (%) [95 % CI]", slip),
                    Cell("stalled", f"{stalled} of {n}"),
                ]
            )
        answers = [str(a["answer"]) for a in e.get("effects", [])]
        if e.get("trend"):
            answers.append(str(e["trend"]["answer"]))
        if model_answer and e.get("experiment") == "speed-sweep":
            answers.append(f"From one minute of exploration, {model_answer}.")
        out.append(
            {"id": str(e.get("experiment", "")), "question": str(e.get("question", "")),
             "rows": rows, "answers": answers}
        )  # fmt: skip
    return {"about": str(q.get("about", "")), "experiments": out}
