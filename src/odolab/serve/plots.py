"""PNG figures for the pages: a trial's run and the fits of Table I (matplotlib, no pyplot)."""

from __future__ import annotations

import io
import math
from typing import TYPE_CHECKING

from matplotlib.figure import Figure

if TYPE_CHECKING:
    from odolab.analysis import MotionAnalysis
    from odolab.trials import Trial

__all__ = ["fit_png", "run_png"]


def _png(fig: Figure) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    return buf.getvalue()


def run_png(trial: Trial) -> bytes | None:
    """The run of ``trial`` from its encoder log: path (x, y) and heading over time.

    None when the trial has no encoder log (typed in by hand).
    """
    from odolab.odometry import integrate

    log = trial.encoder_log
    if log is None or len(log) < 2:
        return None
    traj = integrate(
        log.t, log.left_ticks, log.right_ticks, trial.params, source=f"trial {trial.trial_id}"
    )
    fig = Figure(figsize=(6.0, 3.0), layout="constrained")
    ax_xy, ax_h = fig.subplots(1, 2)
    ax_xy.plot(traj.x, traj.y, color="tab:blue", lw=1.2)
    ax_xy.plot([traj.x[0]], [traj.y[0]], "o", color="tab:green", label="start")
    ax_xy.plot([traj.x[-1]], [traj.y[-1]], "s", color="tab:red", label="end (predicted)")
    ax_xy.set_aspect("equal", adjustable="datalim")
    ax_xy.set_xlabel("x (m)")
    ax_xy.set_ylabel("y (m)")
    ax_xy.set_title("path by odometry", fontsize=10)
    ax_xy.legend(fontsize=7, loc="best")
    ax_xy.grid(alpha=0.3)
    ax_h.plot(traj.t - traj.t[0], traj.heading / math.pi, color="tab:purple", lw=1.2)
    ax_h.set_xlabel("t (s)")
    ax_h.set_ylabel("heading (π rad)")
    ax_h.set_title("heading, unwrapped", fontsize=10)
    ax_h.grid(alpha=0.3)
    return _png(fig)


def fit_png(m: MotionAnalysis) -> bytes:
    """The fit figure of one Table I row (the report's :func:`~odolab.report.figures.plot_fit`)."""
    from odolab.report.figures import plot_fit

    fig = Figure(figsize=(6.0, 4.2), layout="constrained")
    plot_fit(m, fig.subplots())
    return _png(fig)
