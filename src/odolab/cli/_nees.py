"""The NEES table and verdict that ``odolab evaluate --nees`` prints (:func:`print_nees`).

It imports the application layer (numpy and the metrics) when it is imported: load it where the
NEES is wanted, not at a command module's import.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import ParamSpec

from odolab.app.evaluate import NeesOutcome, nees_of_paths
from odolab.cli.wording import said

__all__ = ["print_nees", "render_nees"]

P = ParamSpec("P")


def _printed(compute: Callable[P, NeesOutcome]) -> Callable[P, dict[str, object]]:
    """``compute`` with its arguments, its outcome printed (:func:`render_nees`) and returned as
    JSON-ready numbers."""

    def print_nees(*args: P.args, **kwargs: P.kwargs) -> dict[str, object]:
        """NEES of every run against its ground truth (the arguments of
        :func:`odolab.app.evaluate.nees_of_paths`): prints a table and the verdict, returns the
        JSON-ready numbers."""
        outcome = compute(*args, **kwargs)
        render_nees(outcome)
        return outcome.to_dict()

    return print_nees


#: NEES of every run against its ground truth, with the arguments of
#: :func:`odolab.app.evaluate.nees_of_paths`; prints a table and the verdict, returns the
#: JSON-ready numbers
print_nees = _printed(nees_of_paths)


def render_nees(outcome: NeesOutcome) -> None:
    """The table of runs, the mean NEES with its bounds and verdict, and the notes."""
    from rich.table import Table

    from odolab.cli._console import console as make_console
    from odolab.cli._console import print_table
    from odolab.cli._output import markup_text

    results, summary = outcome.results, outcome.summary
    table = Table(
        title=f"NEES of odometry vs ground truth, pieces of {outcome.segment_s:g} s (dof 3)"
    )
    for col in ("run", "pieces", "mean NEES", "gt yaw offset (rad)"):
        table.add_column(col, justify="right")
    for r in results:
        mean = f"{float(r.nees.mean()):.3g}" if r.nees.size else "-"
        offset = (
            f"{r.gt_yaw_offset:.4f} +- {r.gt_yaw_offset_se:.2g} (fitted)"
            if r.dof_removed and r.gt_yaw_offset_se is not None
            else f"{r.gt_yaw_offset:.4f} (not fitted)"
        )
        table.add_row(markup_text(r.name), str(r.nees.size), mean, offset)
    console = make_console()
    print_table(console, table)
    lo, hi = summary.mean_bounds95
    fitted = sum(r.dof_removed for r in results)
    dof = f" (expected {summary.dof / summary.n:.4g}: {fitted} fitted offsets)" if fitted else ""
    console.print(
        f"mean NEES {summary.mean:.3g} over {summary.n} pieces{dof}; 95 % bounds "
        f"[{lo:.3g}, {hi:.3g}]; "
        f"{100 * summary.fraction_inside:.1f} % of pieces inside their own 95 % bounds: "
        f"covariance {summary.verdict}",
        markup=False,
        highlight=False,
    )
    for model in outcome.slip_models:
        console.print(
            "note: covariance: " + model.describe_covariance(), markup=False, highlight=False
        )
    if outcome.truth is not None:
        console.print(
            f"note: {said(outcome.truth.describe())}; its noise at each piece's two ends is "
            "added to the piece's covariance (--truth-sigma 0,0: taken as exact)",
            markup=False,
            highlight=False,
        )
    if outcome.skip_note:
        console.print(f"note: {said(outcome.skip_note)}", markup=False, highlight=False)
    if outcome.first_order_note:
        console.print(f"note: {said(outcome.first_order_note)}", markup=False, highlight=False)
