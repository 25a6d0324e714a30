"""Table I as rich tables for the terminal (the library returns them; the CLI prints them).

Numbers follow :mod:`odolab.core.numfmt`: a value carries the decimals its 95 % interval supports.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from odolab.analysis.table1 import growth_text
from odolab.core import numfmt
from odolab.core.text import safe_terminal

if TYPE_CHECKING:
    from rich.table import Table

__all__ = ["sigma_text", "table1_compare_rich", "table1_rich"]


def sigma_text(s: dict[str, Any], unit: str = "") -> str:
    """``2.96 rad @ 62.83 [2.2, 4.4]``: a repeated group's sigma with its 95 % interval."""
    lo, hi = s["sigma_ci95"]
    at = numfmt.plain(float(s["commanded"]), strip=True)
    u = f" {unit}" if unit else ""
    return f"{numfmt.with_ci(s['sigma'], lo, hi).replace(' [', f'{u} @ {at} [', 1)}"


def table1_rich(rows: Sequence[dict[str, Any]], *, title: str = "Table I") -> Table:
    """Rows of :func:`odolab.analysis.table1` as a :class:`rich.table.Table`."""
    from rich.table import Table
    from rich.text import Text

    t = Table(title=title)
    for name, justify in (
        ("motion", "left"),
        ("terrain", "left"),
        ("n", "right"),
        ("ratio [95% CI]", "right"),
        ("unit", "left"),
        ("error/pred.", "right"),
        ("R²", "right"),
        ("σ @ repeat [95% CI]", "left"),
        ("growth p [95% CI]", "right"),
    ):
        t.add_column(name, justify=justify)  # type: ignore[arg-type]
    for r in rows:
        lo, hi = r["ratio_ci95"]
        elo, ehi = r.get("error_per_predicted_ci95", (lo, hi))
        sig = "\n".join(sigma_text(s, r["unit"]) for s in r.get("sigmas", []))
        growth = growth_text(r)
        t.add_row(
            Text(safe_terminal(r["motion"])),  # user text: no markup, no escape sequences
            Text(safe_terminal(r["terrain"])),
            str(r["n"]),
            numfmt.with_ci(r["ratio"], lo, hi),
            r["ratio_unit"],
            numfmt.with_ci(r["error_per_predicted"], elo, ehi).split(" [")[0],
            f"{r['r2']:.3f}" if math.isfinite(r["r2"]) else "-",  # no spread in y: undefined
            sig or "-",
            Text(growth),  # "[unbounded, 0.1]" is no markup
        )
    return t


def table1_compare_rich(
    rows: Sequence[dict[str, Any]], *, title: str = "Table I: this campaign vs the lab report"
) -> Table:
    """Table I beside the Jaguar lab report's own numbers (and the pooled y sigma row)."""
    from rich.table import Table
    from rich.text import Text

    from odolab.analysis.reference import LAB_REPORT_TABLE1, LAB_REPORT_Y_SIGMA
    from odolab.analysis.table1 import pooled_y_sigmas

    table = Table(title=title)
    for name in ("motion", "terrain", "n", "ratio [95% CI]", "lab", "σ @ repeat", "lab σ"):
        table.add_column(name, justify="left" if name in ("motion", "terrain") else "right")
    for r in rows:
        ref = LAB_REPORT_TABLE1.get((r["motion"], r["terrain"]))
        lo, hi = r["ratio_ci95"]
        sig = "\n".join(
            f"{numfmt.with_ci(s['sigma'], *s['sigma_ci95']).split(' [')[0]} @ "
            f"{numfmt.plain(float(s['commanded']), strip=True)}"
            for s in r.get("sigmas", [])
        )
        table.add_row(
            Text(safe_terminal(r["motion"])),  # user text: no markup, no escape sequences
            Text(safe_terminal(r["terrain"])),
            str(r["n"]),
            numfmt.with_ci(r["ratio"], lo, hi),
            f"{numfmt.shortest(ref[0])} ± {numfmt.shortest(ref[1])}" if ref else "-",
            sig or "-",
            "\n".join(
                f"{numfmt.shortest(s)} ± {numfmt.shortest(u)} @ {numfmt.plain(at, strip=True)}"
                for s, at, u in ref[2]
            )
            if ref and ref[2]
            else "-",
        )
    pooled = pooled_y_sigmas(rows)
    if pooled:
        table.add_row(
            "y (fwd + rev)",
            "tile",
            "",
            "",
            "",
            "\n".join(
                f"{numfmt.plain(s, 3)} @ {numfmt.plain(d, strip=True)}" for d, s in pooled.items()
            ),
            "\n".join(
                f"{numfmt.shortest(s)} ± {numfmt.shortest(u)} @ {numfmt.plain(at, strip=True)}"
                for s, at, u in LAB_REPORT_Y_SIGMA
            ),
        )
    return table
