"""The report's kinematic-model section: which model the robot needs, and the open questions.

Self-contained pieces for whatever report layout is current (the report package is being
redesigned): HTML fragments (every piece of text escaped) and matplotlib figures.

- :func:`model_comparison_html` — the table of :func:`odolab.calibration.compare.compare_models`
  (held-out end-point error, RPE, drift, BIC with 95 % CIs) and the recommendation;
- :func:`questions_html` — each open question's conditions, effects and trend, in words;
- :func:`plot_model_comparison`, :func:`plot_questions` — the same as figures;
- :func:`models_section_html` — all of it as one ``<section>``.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence
from html import escape
from typing import TYPE_CHECKING

from odolab.analysis.questions import ExperimentResult
from odolab.calibration.compare import Estimate, ModelComparison

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "model_comparison_html",
    "models_section_html",
    "plot_model_comparison",
    "plot_questions",
    "questions_html",
]


def _ci(e: Estimate | None, fmt: str) -> str:
    if e is None:
        return ""
    if not (math.isfinite(e.low) and math.isfinite(e.high)):
        return format(e.value, fmt)
    return f"{e.value:{fmt}} [{e.low:{fmt}}, {e.high:{fmt}}]"


def model_comparison_html(result: ModelComparison) -> str:
    """An HTML table of every model's held-out scores and the recommendation."""
    how = "cross-validated over" if result.cross_validated else "held out:"
    rows = []
    for s in result.scores:
        if s.problem is not None:
            rows.append(
                f"<tr><td>{escape(s.model)}</td><td>{s.n_params}</td>"
                f'<td colspan="6">{escape(s.problem)}</td></tr>'
            )
            continue
        h = s.held_out
        cells = [
            _ci(h["endpoint_error"], ".4f"),
            _ci(h["rpe_rmse"], ".4f"),
            _ci(h["drift_pct"], ".2f"),
            _ci(h["drift_deg_per_m"], ".3f"),
            _ci(s.delta_bic, ".1f"),
            _ci(s.ratio_to_best, ".3f"),
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
        values = ", ".join(
            f"{escape(k)} = {v:.6g} &plusmn; {s.fit.stderr[k]:.2g}" for k, v in s.fit.values.items()
        )
        params.append(f"<li><b>{escape(s.model)}</b>: {values}</li>")
    return (
        '<table class="models">'
        f"<caption>Kinematic models: {len(result.train)} training runs, {how} "
        f"{len(result.held_out)} runs (mean, 95 % CI)</caption>"
        "<tr><th>model</th><th>k</th><th>end-point error (m)</th><th>RPE (m)</th>"
        "<th>drift (%)</th><th>drift (deg/m)</th><th>&Delta;BIC vs diff</th>"
        "<th>error / best</th></tr>"
        + "".join(rows)
        + "</table>"
        + f"<ul>{''.join(params)}</ul>"
        + f"<p><b>Recommended: {escape(result.recommended)}</b> ({escape(result.reason)}).</p>"
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
    """Held-out end-point error of each model: mean with its 95 % CI."""
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(5.6, 3.6))
    ok = [s for s in result.scores if s.problem is None]
    for i, s in enumerate(ok):
        e = s.held_out["endpoint_error"]
        lo = e.value - e.low if math.isfinite(e.low) else 0.0
        hi = e.high - e.value if math.isfinite(e.high) else 0.0
        color = "tab:green" if s.model == result.recommended else "tab:blue"
        ax.errorbar([i], [e.value], yerr=[[lo], [hi]], fmt="o", capsize=5, color=color)
    ax.set_xticks(range(len(ok)), [s.model for s in ok])
    ax.set_ylabel("held-out end-point error (m)")
    ax.set_ylim(bottom=0)
    ax.set_title(f"recommended: {result.recommended}")
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
        ax.set_xticks(range(len(res.conditions)), [c.label for c in res.conditions], fontsize=8)
        ax.set_ylabel("slip (%)")
        ax.set_title(textwrap.fill(res.experiment.question, 90), fontsize=9)
    fig.tight_layout()
    return fig
