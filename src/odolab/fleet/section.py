"""The fleet report section: which robot needs recalibration, with the evidence.

A robot is flagged when its drift (RPE translation per metre, in % of distance) *grows* over the
days - the least-squares slope of its runs' drift against the day is positive by more than
``GROWTH_SIGMAS`` standard errors - or when its drift on its last day is above
``HIGH_FACTOR`` times the fleet's median. The evidence is the slope with its standard error, the
first and last day's mean drift, and the runs behind them.

:func:`fleet_section` returns figures (matplotlib), the table and an HTML fragment (every text
from the data escaped); :meth:`FleetSection.save` writes them into a folder.
"""

from __future__ import annotations

import datetime as dt
import html
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from odolab.core.text import figure_text

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from odolab.fleet.table import Cell

__all__ = ["GROWTH_SIGMAS", "HIGH_FACTOR", "FleetSection", "RobotVerdict", "fleet_section"]

GROWTH_SIGMAS = 4.0
HIGH_FACTOR = 2.0


@dataclass(frozen=True)
class RobotVerdict:
    """One robot's evidence: drift slope per day (%/day) with its standard error, day means."""

    robot: str
    runs: int
    days: int
    slope_pct_per_day: float
    slope_stderr: float
    first_day_pct: float
    last_day_pct: float
    growing: bool
    high: bool

    @property
    def recalibrate(self) -> bool:
        """True when this robot needs recalibration."""
        return self.growing or self.high

    def reason(self) -> str:
        """Plain text of why (or 'ok')."""
        why = []
        if self.growing:
            why.append(
                f"drift grows {self.slope_pct_per_day:+.3f} %/day "
                f"(+/- {self.slope_stderr:.3f}, over {self.days} days)"
            )
        if self.high:
            why.append(f"last day's drift {self.last_day_pct:.2f} % is high for this fleet")
        return "; ".join(why) or "ok"


@dataclass
class FleetSection:
    """Figures (name -> matplotlib Figure), verdicts, and the HTML fragment that shows them."""

    verdicts: list[RobotVerdict]
    figures: dict[str, Figure] = field(default_factory=dict)
    html: str = ""

    @property
    def flagged(self) -> list[str]:
        """Robots that need recalibration."""
        return [v.robot for v in self.verdicts if v.recalibrate]

    def save(self, folder: str | Path) -> Path:
        """Write ``fleet.html`` and the figures as PNG into ``folder``; returns the HTML path."""
        from odolab.core.writing import replacing_path, write_png, write_text_file

        out = Path(folder)
        for name, fig in self.figures.items():
            with replacing_path(out / f"{name}.png", what="fleet figure") as tmp:
                write_png(fig, tmp, dpi=110)
        page = out / "fleet.html"
        html = "<!doctype html><meta charset='utf-8'><title>fleet</title>\n" + self.html
        return write_text_file(page, html, what="fleet page")


def _day_numbers(dates: list[str]) -> np.ndarray:
    days = []
    for d in dates:
        try:
            days.append(dt.date.fromisoformat(d).toordinal())
        except ValueError:
            days.append(-1)
    return np.asarray(days, dtype=np.float64)


def _verdicts(columns: dict[str, list[Cell]]) -> list[RobotVerdict]:
    robot = np.asarray(columns["robot"], dtype=object)
    drift = np.asarray(columns["drift_pct"], dtype=np.float64)
    days = _day_numbers([str(d or "") for d in columns["date"]])
    ok = np.isfinite(drift) & (days >= 0)
    last_means = {}
    for r in sorted({str(x) for x in robot[ok]}):
        sel = ok & (robot == r)
        last_means[r] = float(np.mean(drift[sel & (days == days[sel].max())]))
    median = float(np.median(list(last_means.values()))) if last_means else math.nan
    out = []
    for r, last in last_means.items():
        sel = ok & (robot == r)
        x, y = days[sel] - days[sel].min(), drift[sel]
        n_days = len(np.unique(x))
        slope = se = math.nan
        if n_days >= 2 and x.size >= 3:
            a = np.column_stack((np.ones_like(x), x))
            coef, *_ = np.linalg.lstsq(a, y, rcond=None)
            resid = y - a @ coef
            s2 = float(resid @ resid) / (x.size - 2)
            cov = s2 * np.linalg.inv(a.T @ a)
            slope, se = float(coef[1]), math.sqrt(max(float(cov[1, 1]), 0.0))
        first = float(np.mean(y[x == x.min()]))
        growing = bool(math.isfinite(slope) and slope > GROWTH_SIGMAS * se and slope > 0)
        high = bool(len(last_means) >= 3 and last > HIGH_FACTOR * median)
        out.append(RobotVerdict(r, int(sel.sum()), n_days, slope, se, first, last, growing, high))
    return out


def _figures(columns: dict[str, list[Cell]], verdicts: list[RobotVerdict]) -> dict[str, Figure]:
    from matplotlib.figure import Figure

    robot = np.asarray(columns["robot"], dtype=object)
    drift = np.asarray(columns["drift_pct"], dtype=np.float64)
    dates = np.asarray([str(d or "") for d in columns["date"]], dtype=object)
    flagged = {v.robot for v in verdicts if v.recalibrate}
    fig = Figure(figsize=(7.5, 4.0))
    ax = fig.add_subplot()
    all_days = sorted({d for d in dates if d})
    pos = {d: k for k, d in enumerate(all_days)}
    for v in verdicts:
        sel = (robot == v.robot) & np.isfinite(drift) & (dates != "")
        days = sorted({str(d) for d in dates[sel]})
        means = [float(np.mean(drift[sel & (dates == d)])) for d in days]
        bold = v.robot in flagged
        name = figure_text(v.robot)
        label = f"{name} (recalibrate)" if bold else name
        ax.plot(
            [pos[d] for d in days],
            means,
            marker="o",
            label=label,
            linewidth=2.5 if bold else 1.0,
            alpha=1.0 if bold else 0.6,
        )
    days_shown = [figure_text(d) for d in all_days]  # a table read back: any text
    ax.set_xticks(range(len(all_days)), days_shown, rotation=30, ha="right", fontsize=8)
    ax.set_ylabel("drift, mean per day (% of distance)")
    ax.set_title("odometry drift per robot and day")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, ncols=2)
    fig.tight_layout()
    return {"fleet_drift_per_day": fig}


def _fmt(v: float, digits: int = 3) -> str:
    return "-" if not math.isfinite(v) else f"{v:.{digits}f}"


def fleet_section(columns: dict[str, list[Cell]], *, figures: bool = True) -> FleetSection:
    """The section from a fleet table (:func:`odolab.fleet.fleet_rows` or a table read back)."""
    verdicts = _verdicts(columns)
    figs = _figures(columns, verdicts) if figures and verdicts else {}
    e = html.escape
    runs = len(columns["run"])
    failed = sum(1 for x in columns["error"] if x)
    flagged = [v for v in verdicts if v.recalibrate]
    head = (
        f"<p>{len(flagged)} of {len(verdicts)} robots need recalibration: "
        f"{e(', '.join(v.robot for v in flagged)) or 'none'}. {runs} runs, {failed} failed.</p>"
    )
    rows = "".join(
        "<tr>"
        f"<td>{e(v.robot)}</td><td>{v.runs}</td><td>{v.days}</td>"
        f"<td>{_fmt(v.slope_pct_per_day)} &plusmn; {_fmt(v.slope_stderr)}</td>"
        f"<td>{_fmt(v.first_day_pct, 2)}</td><td>{_fmt(v.last_day_pct, 2)}</td>"
        f"<td>{'<strong>recalibrate</strong>' if v.recalibrate else 'ok'}</td>"
        f"<td>{e(v.reason())}</td></tr>\n"
        for v in verdicts
    )
    images = "".join(
        f'<figure><img src="{e(name)}.png" alt="{e(name)}"></figure>\n' for name in figs
    )
    fragment = (
        '<section class="fleet">\n<h2>Fleet: which robot needs recalibration</h2>\n'
        f"{head}\n"
        "<table>\n<thead><tr><th>robot</th><th>runs</th><th>days</th>"
        "<th>drift slope (%/day)</th><th>first day drift %</th><th>last day drift %</th>"
        "<th>verdict</th><th>evidence</th></tr></thead>\n<tbody>\n"
        f"{rows}</tbody>\n</table>\n{images}"
        f"<p>Flagged when the drift grows by more than {GROWTH_SIGMAS:g} standard errors of "
        f"its slope per day, or the last day's drift exceeds {HIGH_FACTOR:g}x the fleet "
        "median.</p>\n</section>\n"
    )
    return FleetSection(verdicts, figs, fragment)
