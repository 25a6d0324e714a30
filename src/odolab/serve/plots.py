"""PNG figures for the pages: a trial's run and the fits of Table I (matplotlib, no pyplot).

Each figure is drawn for the width it is shown at (:data:`LAYOUTS`): ``wide`` for a computer's
page (at most 48 rem, 768 CSS px), ``phone`` for a page under 600 px (the page's width less
its margins: 336 px on a 360 px phone, 376 px on a 400 px one). Sizes are chosen so that the smallest text (tick labels, legend) stays at least 11 CSS
px at that width: a point of a figure ``w`` inches wide shown ``s`` px wide is ``s / (72 w)``
px. Legends sit under the axes, never on the data. No rcParams are changed (the server draws
in several threads at once): every size is given to the artist.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from matplotlib.figure import Figure

from odolab.core.writing import write_png

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from odolab.analysis import MotionAnalysis
    from odolab.core.trials import Trial

__all__ = ["LAYOUTS", "Layout", "fit_png", "layout", "run_png"]


@dataclass(frozen=True)
class Layout:
    """How a figure is drawn for one display width."""

    width_in: float  #: figure width (inches)
    shown_px: float  #: the CSS width it is shown at (for the text-size rule)
    dpi: int  #: pixels per inch of the PNG (about twice the CSS px: sharp on a phone's screen)
    text_pt: float  #: tick labels and legend
    label_pt: float  #: axis labels and titles
    wrap: int | None  #: legend labels wrapped at this many characters

    def px(self, pt: float) -> float:
        """CSS pixels of ``pt`` points of text at the width the figure is shown."""
        return pt * self.shown_px / (72.0 * self.width_in)


LAYOUTS = {
    "wide": Layout(width_in=7.2, shown_px=768, dpi=130, text_pt=9.0, label_pt=10.0, wrap=None),
    "phone": Layout(width_in=3.3, shown_px=336, dpi=220, text_pt=8.0, label_pt=8.5, wrap=40),
}


def layout(name: str | None) -> Layout:
    """The layout called ``name`` (``phone``; anything else is ``wide``)."""
    return LAYOUTS["phone" if name == "phone" else "wide"]


def _png(fig: Figure, lay: Layout) -> bytes:
    buf = io.BytesIO()
    write_png(fig, buf, dpi=lay.dpi)
    return buf.getvalue()


def _sizes(ax: Axes, lay: Layout) -> None:
    ax.tick_params(labelsize=lay.text_pt)
    ax.xaxis.label.set_fontsize(lay.label_pt)
    ax.yaxis.label.set_fontsize(lay.label_pt)
    ax.title.set_fontsize(lay.label_pt)
    ax.xaxis.get_offset_text().set_fontsize(lay.text_pt)
    ax.yaxis.get_offset_text().set_fontsize(lay.text_pt)


def run_png(trial: Trial, size: str | None = None) -> bytes | None:
    """The run of ``trial`` from its encoder log: path (x, y) and heading over time; side by
    side (``wide``) or one above the other (``phone``).

    None when the trial has no encoder log (typed in by hand).
    """
    from odolab.core.odometry import integrate
    from odolab.report.figures import legend_outside

    log = trial.encoder_log
    if log is None or len(log) < 2:
        return None
    lay = layout(size)
    traj = integrate(
        log.t, log.left_ticks, log.right_ticks, trial.params, source=f"trial {trial.trial_id}"
    )
    phone = lay is LAYOUTS["phone"]
    fig = Figure(figsize=(lay.width_in, 5.8 if phone else 3.4), layout="constrained")
    ax_xy, ax_h = fig.subplots(2, 1) if phone else fig.subplots(1, 2)
    ax_xy.plot(traj.x, traj.y, color="tab:blue", lw=1.2, label="path")
    ax_xy.plot([traj.x[0]], [traj.y[0]], "o", color="tab:green", label="start")
    ax_xy.plot([traj.x[-1]], [traj.y[-1]], "s", color="tab:red", label="end (predicted)")
    ax_xy.set_aspect("equal", adjustable="datalim")
    ax_xy.set_xlabel("x (m)")
    ax_xy.set_ylabel("y (m)")
    ax_xy.set_title("path by odometry")
    ax_xy.grid(alpha=0.3)
    ax_h.plot(traj.t - traj.t[0], traj.heading / math.pi, color="tab:purple", lw=1.2)
    ax_h.set_xlabel("t (s)")
    ax_h.set_ylabel("heading (π rad)")
    ax_h.set_title("heading, unwrapped")
    ax_h.grid(alpha=0.3)
    for ax in (ax_xy, ax_h):
        _sizes(ax, lay)
    legend_outside(ax_xy, fontsize=lay.text_pt, ncol=3)
    return _png(fig, lay)


def fit_png(m: MotionAnalysis, size: str | None = None) -> bytes:
    """The fit figure of one Table I row (the report's :func:`~odolab.report.figures.plot_fit`),
    its legend under the axes."""
    from odolab.report.figures import legend_outside, plot_fit

    lay = layout(size)
    fig = Figure(figsize=(lay.width_in, 4.6), layout="constrained")
    ax = fig.subplots()
    plot_fit(m, ax)
    _sizes(ax, lay)
    legend_outside(ax, fontsize=lay.text_pt, ncol=1, wrap=lay.wrap)
    return _png(fig, lay)
