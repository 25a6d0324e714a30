"""Table I as a rich table for the terminal (the library returns it; the CLI prints it)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from odolab.text import safe_terminal

if TYPE_CHECKING:
    from rich.table import Table

__all__ = ["table1_rich"]


def _g(v: float, d: int = 4) -> str:
    return f"{v:.{d}g}"


def table1_rich(rows: Sequence[dict[str, Any]], *, title: str = "Table I") -> Table:
    """Rows of :func:`odolab.analysis.table1` as a :class:`rich.table.Table`."""
    from rich.table import Table
    from rich.text import Text

    t = Table(title=title)
    for name, justify in (
        ("motion", "left"),
        ("terrain", "left"),
        ("n", "right"),
        ("ratio", "right"),
        ("95% CI", "right"),
        ("error/pred.", "right"),
        ("R²", "right"),
        ("σ @ repeat (95% CI)", "left"),
        ("growth p (95% CI)", "right"),
    ):
        t.add_column(name, justify=justify)  # type: ignore[arg-type]
    for r in rows:
        lo, hi = r["ratio_ci95"]
        sig = "\n".join(
            f"{_g(s['sigma'], 3)} {r['unit']} @ {s['commanded']:+.3g} "
            f"[{_g(s['sigma_ci95'][0], 2)}, {_g(s['sigma_ci95'][1], 2)}]"
            for s in r.get("sigmas", [])
        )
        growth = (
            f"{r['growth_p']:.2f} [{r['growth_p_ci95'][0]:.2f}, {r['growth_p_ci95'][1]:.2f}]"
            if "growth_p" in r
            else "-"
        )
        t.add_row(
            Text(safe_terminal(r["motion"])),  # user text: no markup, no escape sequences
            Text(safe_terminal(r["terrain"])),
            str(r["n"]),
            f"{_g(r['ratio'])} {r['ratio_unit']}",
            f"[{_g(lo)}, {_g(hi)}]",
            _g(r["error_per_predicted"]),
            f"{r['r2']:.3f}",
            sig or "-",
            growth,
        )
    return t
