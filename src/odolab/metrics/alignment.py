"""Planar alignment of an estimated trajectory onto a reference: none, origin, or rigid SE(2)."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from odolab.core.defaults import Alignment  # its home is odolab.core.defaults; re-exported here
from odolab.core.errors import InsufficientDataError
from odolab.core.trajectory import Trajectory

__all__ = [
    "SPREAD_ROUNDING_UNITS",
    "Alignment",
    "Rigid2D",
    "align",
    "rigid_from_moments",
    "rigid_from_points",
    "transform_trajectory",
]


class Rigid2D(NamedTuple):
    """A planar rigid transform: rotate by ``angle`` (rad), then translate by (tx, ty) (m)."""

    angle: float
    tx: float
    ty: float


def transform_trajectory(traj: Trajectory, tf: Rigid2D) -> Trajectory:
    """Apply ``tf`` to every pose (positions rotated and shifted, heading + angle)."""
    c, s = np.cos(tf.angle), np.sin(tf.angle)
    x = c * traj.x - s * traj.y + tf.tx
    y = s * traj.x + c * traj.y + tf.ty
    return Trajectory.from_xyh(traj.t, x, y, traj.heading + tf.angle)


#: A point set whose root summed squared distance from its mean is at most this many
#: rounding units of its largest coordinate (times sqrt(n)) counts as one point: its mean's
#: rounding alone makes such a spread, and the angle fitted to it would be noise.
SPREAD_ROUNDING_UNITS = 64.0


def rigid_from_points(est_xy: np.ndarray, ref_xy: np.ndarray) -> Rigid2D:
    """Least-squares rigid transform taking points ``est_xy`` onto ``ref_xy`` (shapes (n, 2)).

    Closed form (Umeyama/Kabsch in 2-D, no scale): the angle is ``atan2`` of the cross and dot
    sums of the centred point sets.

    Raises:
        InsufficientDataError: fewer than two associated poses are given.
    """
    n = int(est_xy.shape[0])
    if n < 2:
        raise InsufficientDataError("SE(2) alignment needs at least two associated poses")
    me = est_xy.mean(axis=0)
    mr = ref_xy.mean(axis=0)
    a = est_xy - me
    b = ref_xy - mr
    moments = np.array([[np.sum(a[:, i] * b[:, j]) for j in (0, 1)] for i in (0, 1)])
    scale = float(max(np.abs(est_xy).max(), np.abs(ref_xy).max()))
    return rigid_from_moments(n, me, mr, moments, float(np.sum(a * a)), float(np.sum(b * b)), scale)


def rigid_from_moments(
    n: int,
    mean_est: np.ndarray,
    mean_ref: np.ndarray,
    cross_moments: np.ndarray,
    sq_est: float,
    sq_ref: float,
    scale: float,
) -> Rigid2D:
    """:func:`rigid_from_points` from the point sets' moments: their count, means (2,), cross
    moments ``s[a, b] = sum (est_a - mean_est_a) (ref_b - mean_ref_b)`` (2, 2), summed squared
    distances from the means, and largest absolute coordinate (``scale``).

    Raises :class:`InsufficientDataError` when either set does not spread out (see
    :data:`SPREAD_ROUNDING_UNITS`) or the angle is undefined."""
    if n < 2:
        raise InsufficientDataError("SE(2) alignment needs at least two associated poses")
    tiny = SPREAD_ROUNDING_UNITS * float(np.finfo(float).eps) * math.sqrt(n) * scale
    dot = float(cross_moments[0, 0] + cross_moments[1, 1])
    cross = float(cross_moments[0, 1] - cross_moments[1, 0])
    if math.sqrt(sq_est) <= tiny or math.sqrt(sq_ref) <= tiny or (dot == 0.0 and cross == 0.0):
        raise InsufficientDataError(
            "SE(2) alignment is undefined: the associated positions do not spread out"
        )
    ang = float(np.arctan2(cross, dot))
    c, s = np.cos(ang), np.sin(ang)
    me, mr = mean_est, mean_ref
    tx = float(mr[0] - (c * me[0] - s * me[1]))
    ty = float(mr[1] - (s * me[0] + c * me[1]))
    return Rigid2D(ang, tx, ty)


def align(
    reference: Trajectory, estimate: Trajectory, method: Alignment | str = Alignment.NONE
) -> tuple[Trajectory, Rigid2D]:
    """The estimate moved onto the reference (associated, equal length), and the transform used.

    ``origin`` puts the estimate's first pose on the reference's first pose (evo ``align_origin``);
    ``se2`` is the rigid transform minimising the summed squared position differences.
    """
    m = Alignment(method)
    if m is Alignment.NONE:
        return estimate, Rigid2D(0.0, 0.0, 0.0)
    if m is Alignment.ORIGIN:
        ang = float(reference.heading[0] - estimate.heading[0])
        c, s = np.cos(ang), np.sin(ang)
        tx = float(reference.x[0] - (c * estimate.x[0] - s * estimate.y[0]))
        ty = float(reference.y[0] - (s * estimate.x[0] + c * estimate.y[0]))
        tf = Rigid2D(ang, tx, ty)
    else:
        tf = rigid_from_points(estimate.xy, reference.xy)
    return transform_trajectory(estimate, tf), tf
