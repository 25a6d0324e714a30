"""A 2-D laser scanner in a world of walls: ray casting for synthetic ``LaserScan`` data.

A :class:`World` is a set of wall segments (metres, the tape/floor frame); :func:`room_world`
builds a rectangular room with a few boxes in it. :class:`LaserModel` is the scanner
(``beams`` rays evenly from ``angle_min`` to ``angle_max``, ranges beyond ``range_max``
reported as ``inf``, Gaussian range noise ``range_sigma``). :func:`sensor_poses` places the scanner
on the robot (mounted at ``(dx, dy)`` in the robot's frame, x forward, y left, turned by ``dyaw``),
and :func:`cast_scans` returns one row of ranges per sensor pose.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odolab.core.errors import SimError
from odolab.sim.drives import Leg
from odolab.sim.physics import TrueParams

__all__ = [
    "DEFAULT_DRIVE",
    "LaserDrive",
    "LaserModel",
    "World",
    "cast_scans",
    "room_world",
    "sensor_poses",
    "simulate_laser_drive",
]


@dataclass(frozen=True, eq=False)
class World:
    """Wall segments, an (m, 4) array of rows ``x0, y0, x1, y1`` (m)."""

    segments: NDArray[np.float64]

    def __post_init__(self) -> None:
        s = np.asarray(self.segments, dtype=np.float64)
        if s.ndim != 2 or s.shape[1] != 4 or len(s) == 0 or not np.isfinite(s).all():
            raise SimError(f"world segments must be a non-empty (m, 4) finite array, got {s.shape}")
        object.__setattr__(self, "segments", s)


def _box(x0: float, y0: float, x1: float, y1: float) -> list[list[float]]:
    return [[x0, y0, x1, y0], [x1, y0, x1, y1], [x1, y1, x0, y1], [x0, y1, x0, y0]]


def room_world(width: float = 8.0, depth: float = 6.0) -> World:
    """A ``width`` x ``depth`` rectangular room (corner at the origin) with four boxes and a pillar.

    The boxes break the room's symmetry so that a scan matcher cannot confuse two places."""
    if not (width >= 4.0 and depth >= 4.0):
        raise SimError(f"room must be at least 4 m x 4 m, got {width} x {depth}")
    w, d = float(width), float(depth)
    segs = _box(0.0, 0.0, w, d)
    segs += _box(0.6, 0.6, 1.4, 1.1)  # a box in the lower left corner
    segs += _box(w - 1.6, d - 1.3, w - 0.7, d - 0.5)  # upper right
    segs += _box(0.5 * w - 0.2, d - 1.0, 0.5 * w + 0.3, d)  # against the top wall
    segs += _box(w - 0.5, 1.0, w, 2.2)  # a cupboard on the right wall
    # an octagonal pillar off centre
    cx, cy, r = 0.62 * w, 0.3 * d, 0.18
    a = np.linspace(0.0, 2.0 * math.pi, 9)
    for i in range(8):
        segs.append(
            [
                cx + r * math.cos(a[i]),
                cy + r * math.sin(a[i]),
                cx + r * math.cos(a[i + 1]),
                cy + r * math.sin(a[i + 1]),
            ]
        )
    return World(np.array(segs))


@dataclass(frozen=True)
class LaserModel:
    """A planar scanner: ``beams`` rays from ``angle_min`` to ``angle_max`` (rad, counter-clockwise
    from the sensor's x axis), ranges in [``range_min``, ``range_max``] (m), noise ``range_sigma``
    (m, Gaussian). The default is a 270 degree scanner at 0.5 degree steps, 1 cm noise."""

    beams: int = 541
    angle_min: float = -0.75 * math.pi
    angle_max: float = 0.75 * math.pi
    range_min: float = 0.1
    range_max: float = 30.0
    range_sigma: float = 0.01

    def __post_init__(self) -> None:
        if self.beams < 2:
            raise SimError(f"a laser needs at least 2 beams, got {self.beams}")
        if not (self.angle_max > self.angle_min):
            raise SimError(f"angle_max {self.angle_max} must exceed angle_min {self.angle_min}")
        if not (0 <= self.range_min < self.range_max) or self.range_sigma < 0:
            raise SimError(
                f"laser ranges [{self.range_min}, {self.range_max}] and noise {self.range_sigma} "
                "must satisfy 0 <= range_min < range_max and noise >= 0"
            )

    @property
    def angle_increment(self) -> float:
        """Angle between neighbouring beams (rad)."""
        return (self.angle_max - self.angle_min) / (self.beams - 1)

    @property
    def angles(self) -> NDArray[np.float64]:
        """Beam angles in the sensor frame (rad)."""
        return np.linspace(self.angle_min, self.angle_max, self.beams)


def sensor_poses(
    x: ArrayLike,
    y: ArrayLike,
    heading: ArrayLike,
    mount: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> NDArray[np.float64]:
    """(n, 3) sensor poses ``x, y, yaw`` of a sensor mounted at ``mount = (dx, dy, dyaw)`` on a
    robot at the given poses (robot frame: x forward, y left)."""
    xx, yy, hh = (np.asarray(v, dtype=np.float64) for v in (x, y, heading))
    dx, dy, dyaw = (float(v) for v in mount)
    c, s = np.cos(hh), np.sin(hh)
    return np.column_stack((xx + c * dx - s * dy, yy + s * dx + c * dy, hh + dyaw))


def cast_scans(
    world: World,
    poses: ArrayLike,
    laser: LaserModel | None = None,
    *,
    seed: int = 0,
) -> NDArray[np.float64]:
    """(n, beams) ranges (m) seen from each sensor pose ``x, y, yaw`` (rows of ``poses``).

    A beam that hits nothing within ``range_max`` reads ``inf``; noisy ranges are clipped to
    ``range_min``."""
    lz = laser or LaserModel()
    p = np.atleast_2d(np.asarray(poses, dtype=np.float64))
    if p.ndim != 2 or p.shape[1] != 3 or not np.isfinite(p).all():
        raise SimError(f"sensor poses must be a finite (n, 3) array, got shape {p.shape}")
    rng = np.random.default_rng(seed)
    seg = world.segments
    a = seg[:, 0:2]  # (m, 2)
    e = seg[:, 2:4] - a  # segment direction
    out = np.empty((len(p), lz.beams))
    rel = lz.angles
    for i, (px, py, yaw) in enumerate(p):
        ang = yaw + rel
        dx, dy = np.cos(ang)[:, None], np.sin(ang)[:, None]  # (b, 1)
        # solve (px, py) + t d = a + u e  for t (range) and u (position on the segment)
        wx, wy = a[:, 0] - px, a[:, 1] - py  # (m,)
        den = dx * e[:, 1] - dy * e[:, 0]  # cross(d, e), (b, m)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            t = (wx * e[:, 1] - wy * e[:, 0]) / den
            u = (wx * dy - wy * dx) / den
        ok = (np.abs(den) > 1e-12) & (t > 1e-9) & (u >= 0.0) & (u <= 1.0)
        r = np.where(ok, t, np.inf).min(axis=1)
        if lz.range_sigma > 0:
            r = r + lz.range_sigma * rng.standard_normal(lz.beams)
        r = np.where(r > lz.range_max, np.inf, np.maximum(r, lz.range_min))
        out[i] = r
    return out


#: The default drive: (left, right) wheel surface speeds (m/s) held for a duration (s); starts
#: at (1.5, 2.5, 0) in :func:`room_world`'s default room and stays clear of its walls and boxes.
DEFAULT_DRIVE: tuple[tuple[float, float, float], ...] = (
    (0.4, 0.4, 6.0),  # straight along the room
    (-0.3, 0.3, 2.9),  # turn in place, about 180 degrees
    (0.35, 0.45, 5.0),  # a left-curving arc back
    (0.3, -0.3, 1.5),  # turn right in place
    (0.4, 0.4, 2.0),
    (0.0, 0.0, 0.5),  # stop
)


@dataclass(frozen=True, eq=False)
class LaserDrive:
    """A simulated drive with a laser on the robot.

    ``scan_t``: (n,) scan stamps (s); ``ranges``: (n, beams); ``sensor``: (n, 3) true sensor poses
    ``x, y, yaw`` (yaw unwrapped); ``robot``: (n, 3) true robot poses at the scan stamps;
    ``joint_t``: (k,) and ``wheel_angles``: (k, 2) the wheels' angles (rad, left, right) for
    ``/joint_states``; ``laser`` and ``mount`` as used."""

    scan_t: NDArray[np.float64]
    ranges: NDArray[np.float64]
    sensor: NDArray[np.float64]
    robot: NDArray[np.float64]
    joint_t: NDArray[np.float64]
    wheel_angles: NDArray[np.float64]
    laser: LaserModel
    mount: tuple[float, float, float]


def simulate_laser_drive(
    *,
    world: World | None = None,
    laser: LaserModel | None = None,
    mount: tuple[float, float, float] = (0.15, -0.05, 0.1),
    drive: Sequence[Leg | tuple[float, float, float]] = DEFAULT_DRIVE,
    start: tuple[float, float, float] = (1.5, 2.5, 0.0),
    scan_rate: float = 10.0,
    joint_rate: float = 50.0,
    truth: str | TrueParams = "ideal",
    seed: int = 0,
) -> LaserDrive:
    """Drive the virtual Jaguar (``odolab.sim.VirtualRobot``, jaguar-lite nominal parameters,
    truth preset ``truth`` or given :class:`TrueParams`) through ``drive`` (legs ``(left, right,
    seconds)`` or :class:`~odolab.sim.drives.Leg`, whose ramp is ignored here) and scan ``world``
    at ``scan_rate`` Hz from a laser mounted at ``mount = (dx, dy, dyaw)``; wheel angles are
    sampled at ``joint_rate`` Hz."""
    from odolab.core.params import PRESETS
    from odolab.sim.physics import VirtualRobot
    from odolab.sim.presets import TRUTH_PRESETS

    if isinstance(truth, str) and truth not in TRUTH_PRESETS:
        raise SimError(f"unknown truth preset {truth!r}; expected one of {sorted(TRUTH_PRESETS)}")
    if not (scan_rate > 0 and joint_rate > 0):
        raise SimError(f"scan and joint rates must be > 0 Hz, got {scan_rate}, {joint_rate}")
    if not drive:
        raise SimError("a laser drive needs at least one leg")
    legs = [(g.left, g.right, g.duration) if isinstance(g, Leg) else g for g in drive]
    true = TRUTH_PRESETS[truth] if isinstance(truth, str) else truth
    nominal = PRESETS["jaguar-lite"]
    robot = VirtualRobot(true, nominal, "tile", seed=seed, dt=0.002)
    robot.reset(start, misalign=False)
    rad_per_tick = 2.0 * math.pi / nominal.ticks_per_rev
    total = sum(d for _, _, d in legs)
    step = 1.0 / joint_rate
    every = max(1, round(joint_rate / scan_rate))
    n = math.floor(total / step + 1e-9) + 1
    joint_t, wheels, scan_t, robot_poses = [], [], [], []
    ends = np.cumsum([d for _, _, d in legs])
    for k in range(n):
        if k:
            robot.advance(step)
        seg = min(int(np.searchsorted(ends, robot.time + 1e-9, side="right")), len(legs) - 1)
        robot.set_wheel_speeds(legs[seg][0], legs[seg][1])
        tl, tr = robot.wheel_ticks()
        joint_t.append(robot.time)
        wheels.append((tl * rad_per_tick, tr * rad_per_tick))
        if k % every == 0:
            pose = robot.true_pose
            scan_t.append(robot.time)
            robot_poses.append((pose.x, pose.y, pose.heading))
    rp = np.array(robot_poses)
    sp = sensor_poses(rp[:, 0], rp[:, 1], rp[:, 2], mount)
    lz = laser or LaserModel()
    ranges = cast_scans(world or room_world(), sp, lz, seed=seed)
    return LaserDrive(
        scan_t=np.array(scan_t),
        ranges=ranges,
        sensor=sp,
        robot=rp,
        joint_t=np.array(joint_t),
        wheel_angles=np.array(wheels),
        laser=lz,
        mount=mount,
    )
