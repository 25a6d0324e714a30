"""One call from two trajectories to every number: association, alignment, APE, RPE, drift.

Planar: every number is of (x, y, heading); z, roll and pitch are not read (:data:`PLANAR_NOTE`).
A number that is undefined for the data (RPE when the step gives no pose pairs, drift per metre
of a run that turns in place) is NaN in the result and ``null`` in :meth:`Evaluation.to_dict`,
with the reason in ``notes``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from odolab.core.errors import LogFormatError, opt
from odolab.core.trajectory import Trajectory
from odolab.metrics.alignment import Alignment, Rigid2D, align
from odolab.metrics.association import SyncMethod, associate
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

__all__ = [
    "PLANAR_NOTE",
    "Drift",
    "Evaluation",
    "EvaluationOptions",
    "drift_per_distance",
    "evaluate",
    "rpe_undefined_note",
]

#: What every evaluation says about its dimensions (the CLI prints it, the JSON carries it).
PLANAR_NOTE = (
    "planar: x, y and heading only; z, roll and pitch are not read, so where a trajectory "
    "leaves the plane (a hand-held camera) APE and RPE differ from evo's 3-D ones"
)


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
    drift_turn_rad: float = math.pi / 2

    def to_dict(self) -> dict[str, object]:
        """Plain dict for JSON."""
        return {k: (str(v) if isinstance(v, str) else v) for k, v in self.__dict__.items()}


@dataclass(frozen=True)
class Drift:
    """Error growth per distance travelled and per angle turned by the reference.

    ``translation_pct``: mean over path segments of (RPE translation / reference path length) in %;
    ``rotation_deg_per_m``: mean of (RPE rotation in degrees / reference path length); segments
    are consecutive pieces of ``segment_m`` metres of reference path. ``endpoint_error`` (m) is the
    final position error and ``endpoint_pct`` that error over the whole reference path length.

    Per angle turned (defined for a run that turns in place, where per metre is not):
    ``rotation_pct_of_turn`` is the mean over consecutive pieces of ``turn_segment`` rad of
    reference turning (the sum of its steps' ``|wrap(dh)|``) of (RPE rotation / angle turned)
    in %; ``turn`` is the reference's whole turning (rad). A value with no segment is NaN and
    :attr:`notes` says why.
    """

    translation_pct: float
    rotation_deg_per_m: float
    segment_m: float
    segments: int
    endpoint_error: float
    endpoint_heading_error: float
    path_length: float
    endpoint_pct: float
    turn: float = math.nan
    turn_segment: float = math.pi / 2
    turn_segments: int = 0
    rotation_pct_of_turn: float = math.nan

    @property
    def notes(self) -> tuple[str, ...]:
        """Why a drift value is undefined (NaN), one sentence each."""
        out: list[str] = []
        if self.segments == 0:
            why = (
                f"the reference travels {self.path_length:.3g} m, less than one "
                f"{self.segment_m:g} m segment"
            )
            if self.turn_segments > 0:
                why += f" (it turns in place: {math.degrees(self.turn):.0f} deg)"
            out.append(f"drift per metre is undefined: {why}")
        if self.turn_segments == 0:
            out.append(
                f"drift per angle turned is undefined: the reference turns "
                f"{math.degrees(self.turn):.3g} deg, less than one "
                f"{math.degrees(self.turn_segment):.3g} deg piece"
            )
        return tuple(out)

    def to_dict(self) -> dict[str, float | int | None]:
        """Plain dict for JSON: an undefined value (NaN) is ``None``."""
        return {k: _none_if_nan(v) for k, v in self.__dict__.items()}


def _none_if_nan(value: float | int) -> float | int | None:
    return None if isinstance(value, float) and math.isnan(value) else value


def _turn_drift(
    reference: Trajectory, estimate: Trajectory, segment_rad: float
) -> tuple[float, int, float]:
    """Whole turning of ``reference`` (rad), pieces of ``segment_rad`` turned, and the mean RPE
    rotation over angle turned of those pieces (%; NaN with no piece)."""
    turned = turn_distances(reference)
    total = float(turned[-1]) if turned.size else 0.0
    i, j = pair_indices(reference, segment_rad, DeltaUnit.RADIANS, allow_empty=True)
    seg = turned[j] - turned[i]
    ok = seg > 0
    if not ok.any():
        return total, 0, math.nan
    _, er = rpe_errors(reference, estimate, i[ok], j[ok])
    return total, int(ok.sum()), float(np.mean(100.0 * er / seg[ok]))


def _check_turn_segment(segment_rad: float) -> None:
    if not (segment_rad > 0 and math.isfinite(segment_rad)):
        raise LogFormatError(
            f"drift turn segment must be a positive angle ({opt('drift_turn')}, degrees), got "
            f"{math.degrees(segment_rad):g} deg"
        )


def drift_per_distance(
    reference: Trajectory,
    estimate: Trajectory,
    segment_m: float = 1.0,
    turn_segment_rad: float = math.pi / 2,
) -> Drift:
    """Drift of associated, aligned trajectories (equal length) per metre of reference path,
    and per angle turned.

    Raises:
        LogFormatError: the drift segment is not a positive length.
    """
    if not (segment_m > 0 and math.isfinite(segment_m)):
        raise LogFormatError(
            f"drift segment must be a positive length in m ({opt('drift_segment')}), got {segment_m}"
        )
    _check_turn_segment(turn_segment_rad)
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
    turn, tseg, rpct = _turn_drift(reference, estimate, turn_segment_rad)
    return Drift(
        translation_pct=tpct,
        rotation_deg_per_m=rdeg,
        segment_m=float(segment_m),
        segments=nseg,
        endpoint_error=end_err,
        endpoint_heading_error=end_rot,
        path_length=length,
        endpoint_pct=100.0 * end_err / length if length > 0 else math.nan,
        turn=turn,
        turn_segment=float(turn_segment_rad),
        turn_segments=tseg,
        rotation_pct_of_turn=rpct,
    )


def rpe_undefined_note(options: EvaluationOptions, poses: int, chooser: str, measure: float) -> str:
    """Why RPE is undefined: ``options``' step gives no pose pairs on ``poses`` poses of the
    trajectory that chooses them (``chooser``), which travels or turns ``measure``."""
    unit = DeltaUnit(options.delta_unit)
    how, hint = "", ""
    if unit is DeltaUnit.METRES:
        how = f" ({chooser} travels {measure:.3g} m)"
        hint = " (or, for a run that turns in place, {{delta_unit}} deg)"
    elif unit in ANGLE_UNITS:
        how = f" ({chooser} turns {math.degrees(measure):.3g} deg)"
    return (
        f"RPE is undefined: delta = {options.delta:g} {unit.value} gives no pose pairs on "
        f"{poses} poses{how}; a smaller {opt('delta')} gives some{hint}"
    )


@dataclass(frozen=True)
class Evaluation:
    """APE and RPE statistics (translation in m, rotation in rad) and drift of one estimate.

    Planar (:data:`PLANAR_NOTE`). ``rpe`` and ``rpe_rot`` are :meth:`Stats.undefined` when the
    step gives no pose pairs; :attr:`notes` says so."""

    ape: Stats
    ape_rot: Stats
    rpe: Stats
    rpe_rot: Stats
    drift: Drift
    pairs: int
    transform: Rigid2D
    options: EvaluationOptions = field(default_factory=EvaluationOptions)
    rpe_note: str = ""  #: why RPE is undefined (empty when it is defined)

    #: Every number is of (x, y, heading).
    planar: ClassVar[bool] = True

    @property
    def notes(self) -> tuple[str, ...]:
        """Why a number is undefined (NaN), one sentence each."""
        return ((self.rpe_note,) if self.rpe_note else ()) + self.drift.notes

    def to_dict(self) -> dict[str, object]:
        """JSON-ready dict: ``ape``, ``ape_rot``, ``rpe``, ``rpe_rot``, ``drift``, ``options``,
        ``planar`` (true) with its ``planar_note``, and ``notes`` (why a value is ``null``)."""
        return {
            "planar": self.planar,
            "planar_note": PLANAR_NOTE,
            "ape": self.ape.to_dict(),
            "ape_rot": self.ape_rot.to_dict(),
            "rpe": {k: _none_if_nan(v) for k, v in self.rpe.to_dict().items()},
            "rpe_rot": {k: _none_if_nan(v) for k, v in self.rpe_rot.to_dict().items()},
            "drift": self.drift.to_dict(),
            "notes": list(self.notes),
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
    chooser = ref if o.pairs_from_reference else est
    i, j = pair_indices(
        chooser, o.delta, o.delta_unit, all_pairs=o.all_pairs, rel_tol=o.rel_tol, allow_empty=True
    )
    drift = drift_per_distance(ref, est, o.drift_delta_m, o.drift_turn_rad)
    note = ""
    if i.size:
        rt, rr = rpe_errors(ref, est, i, j)
        rpe, rpe_rot = stats_from_errors(rt, "RPE"), stats_from_errors(rr, "RPE")
    else:
        rpe = rpe_rot = Stats.undefined()
        unit = DeltaUnit(o.delta_unit)
        measure = turn_distances(chooser) if unit in ANGLE_UNITS else path_distances(chooser)
        which = "the reference" if o.pairs_from_reference else "the estimate"
        note = rpe_undefined_note(o, len(chooser), which, float(measure[-1]))
    return Evaluation(
        ape=stats_from_errors(ape_translation(ref, est), "APE"),
        ape_rot=stats_from_errors(ape_rotation(ref, est), "APE"),
        rpe=rpe,
        rpe_rot=rpe_rot,
        drift=drift,
        pairs=len(ref),
        transform=tf,
        options=o,
        rpe_note=note,
    )
