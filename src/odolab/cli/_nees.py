"""The NEES table and verdict that ``odolab evaluate --nees`` prints (:func:`print_nees`)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from odolab.cli.wording import said

if TYPE_CHECKING:
    from odolab.app.evaluate import NeesOutcome
    from odolab.core.params import RobotParams
    from odolab.metrics.truthnoise import TruthNoise

__all__ = ["print_nees", "render_nees"]


def print_nees(
    paths: list[Path],
    fmt: str,
    robot: RobotParams | None,
    method: str,
    segment: float,
    *,
    fit_gt_yaw_offset: bool | None = None,
    truth_sigma: TruthNoise | None = None,
) -> dict[str, object]:
    """NEES of every run (pieces of ``segment`` s) against its ground truth
    (:func:`odolab.app.evaluate.nees_of_paths`); prints a table and the verdict, returns the
    JSON-ready numbers."""
    from odolab.app.evaluate import nees_of_paths

    outcome = nees_of_paths(
        paths, fmt, robot, method, segment, fit_gt_yaw_offset=fit_gt_yaw_offset,
        truth_sigma=truth_sigma,
    )  # fmt: skip
    render_nees(outcome)
    return outcome.to_dict()


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
