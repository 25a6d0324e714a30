"""Planar alignment of an estimated trajectory onto a reference: none, origin, or rigid SE(2)."""

from __future__ import annotations

from enum import StrEnum
from typing import NamedTuple

import numpy as np

from odolab.errors import InsufficientDataError
from odolab.trajectory import Trajectory

__all__ = ["Alignment", "Rigid2D", "align", "rigid_from_points", "transform_trajectory"]


class Alignment(StrEnum):
    """How the estimate is moved onto the reference before APE."""

    NONE = "none"
    ORIGIN = "origin"
    SE2 = "se2"


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


def rigid_from_points(est_xy: np.ndarray, ref_xy: np.ndarray) -> Rigid2D:
    """Least-squares rigid transform taking points ``est_xy`` onto ``ref_xy`` (shapes (n, 2)).

    Closed form (Umeyama/Kabsch in 2-D, no scale): the angle is ``atan2`` of the cross and dot
    sums of the centred point sets.
    """
    if est_xy.shape[0] < 2:
        raise InsufficientDataError("SE(2) alignment needs at least two associated poses")
    me = est_xy.mean(axis=0)
    mr = ref_xy.mean(axis=0)
    a = est_xy - me
    b = ref_xy - mr
    dot = float(np.sum(a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1]))
    cross = float(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]))
    if dot == 0.0 and cross == 0.0:
        raise InsufficientDataError(
            "SE(2) alignment is undefined: the associated positions do not spread out"
        )
    ang = float(np.arctan2(cross, dot))
    c, s = np.cos(ang), np.sin(ang)
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
