"""Trajectory metrics with evo's definitions: association, alignment, APE, RPE, drift.

Planar (x, y, heading) only (:data:`PLANAR_NOTE`); every number agrees with ``evo`` on the same
planar trajectories, and differs from evo's 3-D numbers where a trajectory leaves the plane.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from odolab.metrics.alignment import (
    Alignment,
    Rigid2D,
    align,
    rigid_from_points,
    transform_trajectory,
)
from odolab.metrics.association import (
    SyncMethod,
    associate,
    interpolate_trajectory,
    matching_time_indices,
)
from odolab.metrics.evaluate import (
    PLANAR_NOTE,
    Drift,
    Evaluation,
    EvaluationOptions,
    drift_per_distance,
    evaluate,
)
from odolab.metrics.pose_error import (
    ANGLE_UNITS,
    DeltaUnit,
    Stats,
    ape_rotation,
    ape_translation,
    pair_indices,
    path_distances,
    rpe_errors,
    stats_from_errors,
    turn_distances,
)

if TYPE_CHECKING:
    from odolab.metrics.chunked import ErrorStats, evaluate_files, exact_median_from_file
    from odolab.metrics.runs import (
        RUN_OPTIONS,
        Progress,
        RunEvaluation,
        evaluate_run,
        evaluate_run_files,
        parallel_map,
    )

__all__ = [
    "ANGLE_UNITS",
    "PLANAR_NOTE",
    "RUN_OPTIONS",
    "Alignment",
    "DeltaUnit",
    "Drift",
    "ErrorStats",
    "Evaluation",
    "EvaluationOptions",
    "Progress",
    "Rigid2D",
    "RunEvaluation",
    "Stats",
    "SyncMethod",
    "align",
    "ape_rotation",
    "ape_translation",
    "associate",
    "drift_per_distance",
    "evaluate",
    "evaluate_files",
    "evaluate_run",
    "evaluate_run_files",
    "exact_median_from_file",
    "interpolate_trajectory",
    "matching_time_indices",
    "pair_indices",
    "parallel_map",
    "path_distances",
    "rigid_from_points",
    "rpe_errors",
    "stats_from_errors",
    "transform_trajectory",
    "turn_distances",
]

# loaded when first used (PEP 562): a whole-file evaluation needs neither the chunked reader nor
# the many-runs machinery (their imports: 11 ms of every ``odolab evaluate GT EST``)
_WHERE = {
    **dict.fromkeys(
        ("ErrorStats", "evaluate_files", "exact_median_from_file"), "odolab.metrics.chunked"
    ),
    **dict.fromkeys(
        (
            "RUN_OPTIONS",
            "Progress",
            "RunEvaluation",
            "evaluate_run",
            "evaluate_run_files",
            "parallel_map",
        ),
        "odolab.metrics.runs",
    ),
}


def __getattr__(name: str) -> object:
    import importlib

    if name not in _WHERE:
        raise AttributeError(f"module 'odolab.metrics' has no attribute {name!r}")
    return getattr(importlib.import_module(_WHERE[name]), name)
