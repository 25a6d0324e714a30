"""One call from two trajectories to every number: association, alignment, APE, RPE, drift."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from odolab.errors import LogFormatError
from odolab.metrics.alignment import Alignment, Rigid2D, align
from odolab.metrics.association import SyncMethod, associate
from odolab.metrics.pose_error import (
    DeltaUnit,
    Stats,
    ape_rotation,
    ape_translation,
    pair_indices,
    path_distances,
    rpe_errors,
    stats_from_errors,
)
from odolab.trajectory import Trajectory

__all__ = ["Drift", "Evaluation", "EvaluationOptions", "drift_per_distance", "evaluate"]


@dataclass(frozen=True)
class EvaluationOptions:
    """Settings of :func:`evaluate` (defaults: evo's, except the delta)."""

    delta: float = 1.0
    delta_unit: DeltaUnit = DeltaUnit.FRAMES
    all_pairs: bool = False
    rel_tol: float = 0.1
    pairs_from_reference: bool = False
    sync: SyncMethod = SyncMethod.NEAREST
    max_diff: float = 0.01
    offset: float = 0.0
    alignment: Alignment = Alignment.NONE
    drift_delta_m: float = 1.0

    def to_dict(self) -> dict[str, Any]:
        """Plain dict for JSON."""
        return {k: (str(v) if isinstance(v, str) else v) for k, v in self.__dict__.items()}


@dataclass(frozen=True)
class Drift:
    """Error growth per distance travelled by the reference.

    ``translation_pct``: mean over path segments of (RPE translation / reference path length) in %;
    ``rotation_deg_per_m``: mean of (RPE rotation in degrees / reference path length); segments
    are consecutive pieces of ``segment_m`` metres of reference path. ``endpoint_error`` (m) is the
    final position error and ``endpoint_pct`` that error over the whole reference path length.
    """

    translation_pct: float
    rotation_deg_per_m: float
    segment_m: float
    segments: int
    endpoint_error: float
    endpoint_heading_error: float
    path_length: float
    endpoint_pct: float

    def to_dict(self) -> dict[str, float | int]:
        """Plain dict for JSON."""
        return dict(self.__dict__)


def drift_per_distance(
    reference: Trajectory, estimate: Trajectory, segment_m: float = 1.0
) -> Drift:
    """Drift of associated, aligned trajectories (equal length) per metre of reference path."""
    if not (segment_m > 0 and math.isfinite(segment_m)):
        raise LogFormatError(
            f"drift segment must be a positive length in m (--drift-segment), got {segment_m}"
        )
    dist = path_distances(reference)
    length = float(dist[-1]) if dist.size else 0.0
    end_err = float(ape_translation(reference[-1:], estimate[-1:])[0])
    end_rot = float(ape_rotation(reference[-1:], estimate[-1:])[0])
    if length > segment_m:
        i, j = pair_indices(reference, segment_m, DeltaUnit.METRES)
        et, er = rpe_errors(reference, estimate, i, j)
        seg = dist[j] - dist[i]
        ok = seg > 0
        tpct = float(np.mean(100.0 * et[ok] / seg[ok]))
        rdeg = float(np.mean(np.degrees(er[ok]) / seg[ok]))
        nseg = int(ok.sum())
    else:
        tpct = rdeg = math.nan
        nseg = 0
    return Drift(
        translation_pct=tpct,
        rotation_deg_per_m=rdeg,
        segment_m=float(segment_m),
        segments=nseg,
        endpoint_error=end_err,
        endpoint_heading_error=end_rot,
        path_length=length,
        endpoint_pct=100.0 * end_err / length if length > 0 else math.nan,
    )


@dataclass(frozen=True)
class Evaluation:
    """APE and RPE statistics (translation in m, rotation in rad) and drift of one estimate."""

    ape: Stats
    ape_rot: Stats
    rpe: Stats
    rpe_rot: Stats
    drift: Drift
    pairs: int
    transform: Rigid2D
    options: EvaluationOptions = field(default_factory=EvaluationOptions)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict: ``ape``, ``ape_rot``, ``rpe``, ``rpe_rot``, ``drift``, ``options``."""
        return {
            "ape": self.ape.to_dict(),
            "ape_rot": self.ape_rot.to_dict(),
            "rpe": self.rpe.to_dict(),
            "rpe_rot": self.rpe_rot.to_dict(),
            "drift": self.drift.to_dict(),
            "associated_poses": self.pairs,
            "alignment": self.transform._asdict(),
            "options": self.options.to_dict(),
        }


def evaluate(
    reference: Trajectory,
    estimate: Trajectory,
    options: EvaluationOptions | None = None,
    *,
    names: tuple[str, str] = ("reference", "estimate"),
) -> Evaluation:
    """Associate, align, then APE, RPE (evo's definitions) and drift per distance."""
    o = options or EvaluationOptions()
    ref, est = associate(
        reference, estimate, method=o.sync, max_diff=o.max_diff, offset=o.offset, names=names
    )
    est, tf = align(ref, est, o.alignment)
    i, j = pair_indices(
        ref if o.pairs_from_reference else est,
        o.delta,
        o.delta_unit,
        all_pairs=o.all_pairs,
        rel_tol=o.rel_tol,
    )
    rt, rr = rpe_errors(ref, est, i, j)
    return Evaluation(
        ape=stats_from_errors(ape_translation(ref, est), "APE"),
        ape_rot=stats_from_errors(ape_rotation(ref, est), "APE"),
        rpe=stats_from_errors(rt, "RPE"),
        rpe_rot=stats_from_errors(rr, "RPE"),
        drift=drift_per_distance(ref, est, o.drift_delta_m),
        pairs=len(ref),
        transform=tf,
        options=o,
    )
