"""The report's figures, answering the lab's Figs. 12-21.

Each takes an optional ``ax`` and returns it.

Nothing here changes matplotlib's global state; callers choose the backend.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odolab.analysis.core import LabAnalysis, MotionAnalysis
from odolab.analysis.random import GroupSpread
from odolab.core.motion import Motion
from odolab.core.params import RobotParams
from odolab.core.text import figure_text

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = [
    "LEGEND_FONTSIZE",
    "legend_outside",
    "plot_calibration_effect",
    "plot_error_ellipses",
    "plot_fit",
    "plot_growth",
    "plot_histogram",
    "plot_residuals",
    "plot_terrain_slopes",
    "plot_terrains",
    "plot_umbmark",
    "ratio_fit_label",
]

_CHI2_2DOF_95 = 5.991464547107979


def _axes(ax: Axes | None) -> Axes:
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    _, new = plt.subplots(figsize=(6.4, 4.4))
    return new


#: Legend text size (pt): the report draws figures 6 in wide and shows them down to a phone's
#: 368 px, the web notebook draws its own phone-size rendering (:mod:`odolab.serve.plots`).
LEGEND_FONTSIZE = 9


def _finish(ax: Axes, motion: Motion, title: str) -> Axes:
    """A ratio plot's last touches: the motion's axis labels, the title, a grid, the legend."""
    ax.set_xlabel(motion.x_label)
    ax.set_ylabel(motion.y_label)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    legend_outside(ax)
    return ax


def legend_outside(
    ax: Axes,
    *,
    fontsize: float = LEGEND_FONTSIZE,
    ncol: int | None = None,
    title: str | None = None,
    wrap: int | None = None,
) -> int:
    """The legend of ``ax`` under the axes (never on the data), centred, in ``ncol`` columns
    (when None: as many as the figure's width holds, at most 3), each label wrapped at ``wrap`` characters when
    given (a narrow figure). A figure with ``layout="constrained"`` makes room for it; nothing
    is drawn when ``ax`` has no labelled artist. Returns the lines of text the legend takes
    (its title included; 0 without a legend)."""
    import textwrap

    handles, labels = ax.get_legend_handles_labels()
    if not labels:
        return 0
    if wrap is not None:
        # a word longer than a line stays whole: a cut would part an escaped "\$"
        labels = [textwrap.fill(t, wrap, break_long_words=False) for t in labels]
    if ncol is None:  # as many as fit the figure's width (a character is about 0.55 em)
        fig = ax.get_figure(root=True)
        width_pt = 72.0 * (fig.get_figwidth() if fig is not None else 6.0)
        longest = max(len(line) for t in labels for line in t.split("\n"))
        ncol = min(3, int(width_pt / (0.55 * fontsize)) // (longest + 6))
    ncol = max(1, min(ncol, len(labels)))
    lines: list[int] = [str(t).count("\n") + 1 for t in labels]
    per_column = -(-len(labels) // ncol)
    # matplotlib fills the columns one after the other
    columns = [lines[i * per_column : (i + 1) * per_column] or [0] for i in range(ncol)]
    ax.legend(
        handles,
        labels,
        title=title,
        loc="upper center",
        bbox_to_anchor=(0.5, -0.14),
        ncol=ncol,
        frameon=False,
        fontsize=fontsize,
        title_fontsize=fontsize,
    )
    return max(sum(c) for c in columns) + (1 if title else 0)


def _title(m: MotionAnalysis) -> str:
    names = {
        "rotation": "Rotation in place",
        "pivot": "Pivot turn",
        "x": "x translation",
        "y_forward": "y drift, forward",
        "y_reverse": "y drift, reverse",
    }
    return f"{names[m.motion]} ({figure_text(m.terrain)})"


def ratio_fit_label(m: MotionAnalysis) -> str:
    """Legend label of the proportional fit (Table I's ratio), e.g.
    ``"ratio (through origin) 0.875 [0.858, 0.892]"``; empty when ``m`` has none."""
    if m.ratio_fit is None:
        return ""
    lo, hi = m.ratio_fit.slope_ci95
    return f"ratio (through origin) {m.ratio_fit.slope:.3f} [{lo:.3f}, {hi:.3f}]"


def plot_fit(m: MotionAnalysis, ax: Axes | None = None) -> Axes:
    """Data, least-squares line with its slope CI, ideal line, outliers (Figs. 12, 15-17).

    Where ``m.ratio_fit`` exists (rotation, pivot, x) the proportional fit
    ``actual = ratio * predicted`` (Table I's ratio) is drawn too, dashed.
    """
    ax = _axes(ax)
    f = m.fit
    lo_hi = np.array([min(0.0, float(f.x.min())), max(0.0, float(f.x.max()))])
    ideal = lo_hi if m.motion.ideal_line else np.zeros(2)
    ideal_label = "ideal (actual = predicted)" if m.motion.ideal_line else ("ideal (no error)")
    ax.plot(lo_hi, ideal, color="tab:green", lw=1.2, label=ideal_label)
    ax.scatter(f.x, f.y, s=18, color="tab:blue", label=f"trials (n = {f.n})", zorder=3)
    lo, hi = f.slope_ci95
    ax.plot(
        lo_hi,
        f.predict(lo_hi),
        color="tab:red",
        lw=1.5,
        label=(
            f"fit with intercept: slope {f.slope:.4f} [{lo:.4f}, {hi:.4f}], "
            f"intercept {f.intercept:.3g} {m.motion.unit}, R² {f.r2:.3f}"
        ),
    )
    if m.ratio_fit is not None:
        rf = m.ratio_fit
        ax.plot(
            lo_hi,
            rf.slope * lo_hi,
            color="tab:purple",
            lw=1.5,
            ls="--",
            label=ratio_fit_label(m),
        )
    if m.outliers:
        ax.scatter(
            [o.predicted for o in m.outliers],
            [o.actual for o in m.outliers],
            marker="x",
            s=50,
            color="black",
            label="outlier, left out",
            zorder=4,
        )
    return _finish(ax, m.motion, _title(m))


def plot_residuals(m: MotionAnalysis, ax: Axes | None = None) -> Axes:
    """Residuals of the fit against the predicted value, with the fitted +-1.96 sigma(d) band."""
    ax = _axes(ax)
    f = m.fit
    unit = m.motion.unit
    ax.axhline(0.0, color="tab:red", lw=1)
    ax.scatter(f.x, f.residuals, s=18, color="tab:blue", label="residual", zorder=3)
    if m.growth is not None:
        d = np.linspace(max(1e-6, float(np.abs(f.x).min()) * 0.8), float(np.abs(f.x).max()), 100)
        band = 1.96 * m.growth.sigma_at(d)
        signs = [s for s in (1.0, -1.0) if np.any(np.sign(f.x) == s)]
        for i, sgn in enumerate(signs):
            ax.fill_between(
                sgn * d,
                -band,
                band,
                color="tab:orange",
                alpha=0.2,
                label=f"±1.96 σ, σ = {m.growth.a:.3g}·d^{m.growth.p:.2f}" if i == 0 else None,
            )
    else:
        s = m.random.sd
        ax.axhspan(-1.96 * s, 1.96 * s, color="tab:orange", alpha=0.2, label="±1.96 σ")
    ax.set_xlabel(m.motion.x_label)
    ax.set_ylabel(f"residual ({unit})")
    ax.set_title(f"Residuals: {_title(m)}")
    ax.grid(alpha=0.3)
    legend_outside(ax)
    return ax


def plot_histogram(
    group: GroupSpread, unit: str, ax: Axes | None = None, *, label: str = "error"
) -> Axes:
    """Histogram of the errors at one repeated distance/angle with the fitted Gaussian (Fig. 14)."""
    from odolab.core.distributions import norm_pdf

    ax = _axes(ax)
    e = group.errors
    bins = max(4, min(12, int(math.ceil(math.sqrt(e.size)) + 1)))
    ax.hist(
        e, bins=bins, density=True, color="tab:blue", alpha=0.6, label=f"{label} (n = {e.size})"
    )
    xs = np.linspace(e.min() - 2 * group.sd, e.max() + 2 * group.sd, 200)
    ax.plot(
        xs,
        norm_pdf(xs, group.mean_error, group.sd),
        color="tab:red",
        label=f"Gaussian: mean {group.mean_error:.3g}, σ {group.sd:.3g} {unit}",
    )
    lo, hi = group.interval95
    ax.axvline(lo, color="gray", ls="--", lw=1, label=f"95%: [{lo:.3g}, {hi:.3g}]")
    ax.axvline(hi, color="gray", ls="--", lw=1)
    ax.set_xlabel(f"{label}, predicted - actual ({unit})")
    ax.set_ylabel(f"probability density (1/{unit})")
    pv = "" if group.normality is None else f", Shapiro p = {group.normality.pvalue:.2f}"
    ax.set_title(f"Error at {group.at:.3g} {unit}{pv}")
    ax.grid(alpha=0.3)
    ax.set_ylim(0.0, None)
    legend_outside(ax)
    return ax


def plot_growth(m: MotionAnalysis, ax: Axes | None = None) -> Axes:
    """sigma vs distance/angle (log-log): repeated groups with CIs, fitted a·d^p, p = .5, 1, 1.5."""
    ax = _axes(ax)
    unit = m.motion.unit
    f = m.fit
    ax.scatter(
        np.abs(f.x), np.abs(f.residuals), s=10, color="lightgray", label="|residual| per trial"
    )
    if m.groups:
        at = np.array([g.at for g in m.groups])
        sd = np.array([g.sd for g in m.groups])
        err = np.array([[g.sd - g.sd_ci95[0], g.sd_ci95[1] - g.sd] for g in m.groups]).T
        ax.errorbar(at, sd, yerr=err, fmt="o", color="tab:blue", capsize=3, label="σ at repeats")
    if m.growth is not None:
        g = m.growth
        d = np.geomspace(g.d_min, g.d_max, 50)
        ax.plot(d, g.sigma_at(d), color="tab:red", label=g.verdict().split(":")[0])
        ref_d = math.sqrt(g.d_min * g.d_max)
        ref_s = float(g.sigma_at(ref_d)[()])
        for p, ls in ((0.5, ":"), (1.0, "--"), (1.5, "-.")):
            ax.plot(d, ref_s * (d / ref_d) ** p, color="gray", ls=ls, lw=1, label=f"p = {p:g}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

    ticks = sorted({round(float(v), 3) for v in np.abs(f.x)})
    if len(ticks) > 6:  # round numbers (1, 2, 5 per decade) inside the data's range
        lo_t, hi_t = min(ticks), max(ticks)
        ticks = [
            float(m_ * 10.0**e)
            for e in range(math.floor(math.log10(lo_t)), math.ceil(math.log10(hi_t)) + 1)
            for m_ in (1.0, 2.0, 5.0)
            if lo_t * 0.95 <= m_ * 10.0**e <= hi_t * 1.05
        ]
        ticks = sorted({*ticks, lo_t, hi_t}) if len(ticks) < 3 else ticks
    ax.xaxis.set_major_locator(FixedLocator(ticks))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:.3g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel(f"|predicted| ({unit})")
    ax.set_ylabel(f"σ of the error ({unit})")
    ax.set_title(f"Growth of σ: {_title(m)}")
    ax.grid(alpha=0.3, which="both")
    legend_outside(ax)
    return ax


def plot_terrains(analysis: LabAnalysis, motion: str = "x", ax: Axes | None = None) -> Axes:
    """One motion's data and fits on every terrain, side by side in one axes (Fig. 20)."""
    ax = _axes(ax)
    kind = Motion.parse(motion, "plot_terrains")
    ms = [m for m in analysis.motions if m.motion == kind]
    xmax = max((float(np.abs(m.fit.x).max()) for m in ms), default=1.0)
    xs = np.array([0.0, xmax]) if all(np.all(m.fit.x >= 0) for m in ms) else np.array([-xmax, xmax])
    if kind.ideal_line:
        ax.plot(xs, xs, color="black", lw=1, ls=":", label="ideal")
    colors = ["tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown"]
    for i, m in enumerate(ms):
        c = colors[i % len(colors)]
        ax.scatter(m.fit.x, m.fit.y, s=14, color=c, alpha=0.8)
        lo, hi = m.fit.slope_ci95
        ax.plot(
            xs,
            m.fit.predict(xs),
            color=c,
            label=f"{figure_text(m.terrain)}: slope {m.fit.slope:.4f} [{lo:.4f}, {hi:.4f}]",
        )
    return _finish(ax, kind, f"{motion} on each terrain")


def plot_terrain_slopes(analysis: LabAnalysis, motion: str = "x", ax: Axes | None = None) -> Axes:
    """Slope per terrain with 95% CIs: the terrain comparison at a glance.

    The slopes of the lines with an intercept are what the terrain F-test compares; where the
    motion has a proportional fit (rotation, pivot, x) its ratio (Table I's) is drawn beside.
    """
    ax = _axes(ax)
    kind = Motion.parse(motion, "plot_terrain_slopes")
    ms = [m for m in analysis.motions if m.motion == kind]
    y = np.arange(len(ms), dtype=float)
    both = bool(ms) and all(m.ratio_fit is not None for m in ms)
    if both:
        slope = np.array([m.fit.slope for m in ms])
        sci = np.array([m.fit.slope_ci95 for m in ms])
        ax.errorbar(
            slope,
            y - 0.12,
            xerr=np.abs(sci.T - slope),
            fmt="o",
            capsize=4,
            color="tab:red",
            label="slope with intercept (F-test), 95% CI",
        )
    ratio = np.array([m.ratio for m in ms])
    ci = np.array([m.ratio_ci95 for m in ms])
    ax.errorbar(
        ratio,
        y + (0.12 if both else 0.0),
        xerr=np.abs(ci.T - ratio),
        fmt="s" if both else "o",
        capsize=4,
        color="tab:purple" if both else "tab:blue",
        label="ratio (through origin), 95% CI" if both else "slope, 95% CI",
    )
    ax.set_yticks(y, [figure_text(m.terrain) for m in ms])
    ax.set_ylim(-0.6, len(ms) - 0.4)
    test = next((t for t in analysis.terrain_tests if t.motion == motion), None)
    if test is not None:
        ax.set_title(
            f"{motion}: F-test p = {test.pvalue:.3g}, partial η² = {test.partial_eta2:.2f}"
        )
    unit = kind.ratio_unit
    ax.set_xlabel(
        f"actual/predicted ({unit})" if kind.ideal_line else f"y error per metre travelled ({unit})"
    )
    ax.set_ylabel("terrain")
    ax.grid(alpha=0.3)
    legend_outside(ax)
    return ax


def plot_error_ellipses(analysis: LabAnalysis, terrain: str, ax: Axes | None = None) -> Axes:
    """x and y errors (predicted - actual) per repeated distance, 95% ellipses (Figs. 18-19)."""
    from matplotlib.patches import Ellipse

    ax = _axes(ax)
    xm = analysis.get("x", terrain)
    ex: dict[str, tuple[float, float]] = {}
    if xm is not None:
        for tid, px, ax_, c in zip(xm.fit.trial_ids, xm.fit.x, xm.fit.y, xm.commanded, strict=True):
            ex[tid] = (float(px - ax_), float(c))
    colors = ["tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:red", "tab:brown"]
    k = 0
    drawn = 0
    for motion in (fit for fit in Motion if fit.is_y):
        ym = analysis.get(motion, terrain)
        if ym is None:
            continue
        pts: dict[float, list[tuple[float, float]]] = {}
        for tid, err_y in zip(ym.fit.trial_ids, ym.fit.y, strict=True):
            if tid in ex:
                e_x, c = ex[tid]
                pts.setdefault(round(c, 3), []).append((e_x, float(err_y)))
        for c, p in sorted(pts.items()):
            arr = np.array(p)
            color = colors[k % len(colors)]
            k += 1
            ax.scatter(arr[:, 0], arr[:, 1], s=16, color=color, label=f"{c:+g} m (n = {len(p)})")
            if len(p) >= 3:
                drawn += 1
                cov = np.cov(arr.T)
                vals, vecs = np.linalg.eigh(cov)
                angle = math.degrees(math.atan2(vecs[1, 1], vecs[0, 1]))
                w, h = 2 * np.sqrt(np.maximum(vals[::-1], 0) * _CHI2_2DOF_95)
                ax.add_patch(
                    Ellipse(
                        tuple(arr.mean(axis=0)), w, h, angle=angle, fill=False, color=color, lw=1.2
                    )
                )
    ax.set_xlabel("x error, predicted - actual (m)")
    ax.set_ylabel("y error, predicted - actual (m)")
    where = figure_text(terrain)
    ax.set_title(
        f"End-point errors and 95% ellipses ({where})"
        if drawn
        else f"End-point errors, one trial per distance ({where})"
    )
    ax.grid(alpha=0.3)
    ax.axhline(0, color="gray", lw=0.8)
    ax.axvline(0, color="gray", lw=0.8)
    legend_outside(ax, title="commanded distance", ncol=3 if k > 6 else 2)
    return ax


def _scale_prediction(
    motion: Motion, predicted: NDArray[np.float64], old: RobotParams, new: RobotParams
) -> NDArray[np.float64]:
    """Re-predict without logs: exact when both wheels scale alike (the ratios method)."""
    r_old = 0.5 * (old.left_wheel_radius + old.right_wheel_radius)
    r_new = 0.5 * (new.left_wheel_radius + new.right_wheel_radius)
    return motion.rescaled(predicted, (r_old, r_new), (old.track_width, new.track_width))


def plot_calibration_effect(
    analysis: LabAnalysis,
    old: RobotParams,
    new: Mapping[str, RobotParams],
    motion: str,
    ax: Axes | None = None,
    *,
    terrain: str | None = None,
) -> Axes:
    """Actual vs predicted with the old and each new parameter set (Fig. 21 without the IMU).

    New predictions scale the old ones (both wheels alike), which is exact for ratio changes.
    """
    ax = _axes(ax)
    m = analysis.get(motion, terrain)
    if m is None:
        return ax
    f = m.fit
    span = np.array([min(0.0, float(f.x.min())), max(0.0, float(f.x.max()))])
    ax.plot(span, span, color="tab:green", lw=1.2, label="ideal")
    ax.scatter(
        f.x, f.y, s=14, color="tab:red", label=f"old {figure_text(old.name)}: ratio {m.ratio:.3f}"
    )
    markers = ["o", "s", "^", "D"]
    for i, (name, p) in enumerate(new.items()):
        px = _scale_prediction(m.motion, f.x, old, p)
        slope = float(px @ f.y / (px @ px))  # the proportional fit, as Table I's ratio
        ax.scatter(
            px,
            f.y,
            s=14,
            marker=markers[i % len(markers)],
            facecolors="none",
            edgecolors=f"C{i}",
            label=f"new ({figure_text(name)}): ratio {slope:.3f}",
        )
    return _finish(ax, m.motion, f"Old vs new parameters: {_title(m)}")


def plot_umbmark(
    cw_errors: ArrayLike,
    ccw_errors: ArrayLike,
    ax: Axes | None = None,
    *,
    after: tuple[ArrayLike, ArrayLike] | None = None,
    predicted_minus_actual: bool = True,
) -> Axes:
    """UMBmark return-position errors with their centres of gravity.

    The errors come as UMBmark defines them (measured - odometry); they are drawn in the
    report's convention, odometry - measured (predicted - actual), unless
    ``predicted_minus_actual`` is False. Before: filled dots, centre "+"; after correction
    (same runs, new parameters): open circles, centre "x".
    """
    ax = _axes(ax)
    sign = -1.0 if predicted_minus_actual else 1.0
    sets: list[tuple[str, NDArray[np.float64], NDArray[np.float64], bool, str]] = [
        (
            "before",
            sign * np.asarray(cw_errors, dtype=np.float64),
            sign * np.asarray(ccw_errors, dtype=np.float64),
            True,
            "+",
        )
    ]
    if after is not None:
        sets.append(
            (
                "after",
                sign * np.asarray(after[0], dtype=np.float64),
                sign * np.asarray(after[1], dtype=np.float64),
                False,
                "x",
            )
        )
    for name, cw, ccw, filled, centre in sets:
        for arr, color, d in ((cw, "tab:blue", "cw"), (ccw, "tab:red", "ccw")):
            ax.scatter(
                arr[:, 0], arr[:, 1], s=26, label=f"{d} {name}",
                edgecolors=color, facecolors=color if filled else "none",
            )  # fmt: skip
            cg = arr.mean(axis=0)
            ax.scatter(
                [cg[0]],
                [cg[1]],
                marker=centre,
                s=180,
                linewidths=2.2,
                color=color,
                label=f"centre {d} {name}",
                zorder=5,
            )
    ax.axhline(0, color="gray", lw=0.8)
    ax.axvline(0, color="gray", lw=0.8)
    how = "odometry - measured" if predicted_minus_actual else "measured - odometry"
    ax.set_xlabel(f"x error, {how} (m)")
    ax.set_ylabel(f"y error, {how} (m)")
    ax.set_title("UMBmark return-position errors")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    legend_outside(ax, ncol=2)
    return ax
