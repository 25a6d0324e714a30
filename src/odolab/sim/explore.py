"""Exploration drives: commands sampled over the robot's input space, inside a geofence.

After DRIVE (Baril et al., ICRA 2024): to learn how a robot slips, drive it with commands sampled
over its whole input space (forward speed ``v`` and turn rate ``w`` within the limits), each held
a few seconds, and record the motion with ground truth. :func:`explore` does this with the
virtual robot:

- every ``hold`` seconds (uniform between its two values) a new command ``(v, w)`` is drawn,
  uniformly over ``|v| <= max_speed``, ``|w| <= max_turn_rate`` and both wheel speeds
  ``v -+ w b / 2`` within ``max_speed`` (rejection sampling: uniform over what the robot can do);
  ``distribution = "edges"`` draws three in four commands from the outer half of each range
  (more data where the slip is largest);
- the geofence is a circle of ``fence_radius`` metres about the start, watched by the robot's own
  odometry (the nominal differential drive: what a real robot knows). When the odometry is
  beyond ``return_fraction`` of the radius and moving outward, the command ends and the robot
  turns toward the centre (in place, at ``max_turn_rate``), then drives a drawn command whose
  speed is forward (toward the centre);
- the run is the recorded :class:`~odolab.sim.drives.Drive`: report stamps, tick increments and
  the true poses (the truth the slip model is fitted to).

``odolab sim explore --seconds 60 -o run/`` writes one such run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from odolab.core.defaults import DEFAULT_TERRAIN
from odolab.core.errors import SimError
from odolab.core.kinematics import wrap_angle
from odolab.core.models import DIFF_DRIVE
from odolab.core.odometry import Odometry
from odolab.core.params import RobotParams
from odolab.core.trials import EXPLORE_DISTRIBUTIONS, draw_exploration_value
from odolab.sim.drives import Drive
from odolab.sim.physics import TrueParams, VirtualRobot

__all__ = [
    "DISTRIBUTIONS",
    "ExploreSettings",
    "explore",
    "sample_command",
    "write_exploration",
]

DISTRIBUTIONS = EXPLORE_DISTRIBUTIONS


@dataclass(frozen=True)
class ExploreSettings:
    """How to explore (see the module). Speeds in m/s, turn rates in rad/s, times in s."""

    seconds: float = 60.0
    max_speed: float = 1.0
    max_turn_rate: float = 2.0
    hold: tuple[float, float] = (1.0, 3.0)
    fence_radius: float = 4.0
    return_fraction: float = 0.7
    distribution: str = "uniform"
    report_rate: float = 20.0

    def __post_init__(self) -> None:
        for key in ("seconds", "max_speed", "max_turn_rate", "fence_radius", "report_rate"):
            value = getattr(self, key)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise SimError(f"exploration {key} is {value!r}; expected a positive number")
        lo, hi = self.hold
        if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
            raise SimError(
                f"exploration hold is {self.hold!r} s; expected two times 0 < low <= high"
            )
        if not 0 < self.return_fraction < 1:
            raise SimError(
                f"exploration return_fraction is {self.return_fraction!r}; expected 0 to 1"
            )
        if self.distribution not in DISTRIBUTIONS:
            raise SimError(
                f"exploration distribution {self.distribution!r} is unknown; expected one of "
                f"{', '.join(DISTRIBUTIONS)}"
            )


def sample_command(
    rng: np.random.Generator, s: ExploreSettings, track_width: float, *, forward: bool = False
) -> tuple[float, float]:
    """One command ``(v, w)`` within the limits (see the module); ``forward``: ``v >= 0``."""
    half = 0.5 * track_width
    for _ in range(1000):
        v = draw_exploration_value(rng, s.max_speed, s.distribution)
        w = draw_exploration_value(rng, s.max_turn_rate, s.distribution)
        if forward:
            v = abs(v)
        if abs(v) + abs(w) * half <= s.max_speed:
            return v, w
    raise SimError("no command within the wheel speed limit; expected a larger max_speed")


def explore(
    truth: TrueParams,
    nominal: RobotParams,
    settings: ExploreSettings | None = None,
    *,
    terrain: str = DEFAULT_TERRAIN,
    seed: int = 0,
    dt: float = 0.005,
) -> Drive:
    """Drive an exploration run with the virtual robot and record it (see the module)."""
    s = settings or ExploreSettings()
    rng = np.random.default_rng(seed)
    robot = VirtualRobot(truth, nominal, terrain, seed=seed, dt=dt)
    robot.reset(misalign=False)
    odo = Odometry(nominal.with_(model=DIFF_DRIVE))
    period = 1.0 / s.report_rate
    half = 0.5 * nominal.track_width
    rows: list[tuple[float, float, float, float, float, float]] = []
    stalled = False

    def record() -> None:
        p = robot.true_pose
        wl, wr = robot.wheel_ticks()
        rows.append((robot.time, wl, wr, p.x, p.y, p.heading))

    record()
    last = robot.wheel_ticks()
    odo.update_increments(robot.time, 0.0, 0.0)
    steps = round(s.seconds * s.report_rate)
    k = 0
    v, w, left_s = 0.0, 0.0, 0.0
    returning = False
    while k < steps:
        pose = odo.pose
        r = math.hypot(pose.x, pose.y)
        outward = pose.x * math.cos(pose.heading) * v + pose.y * math.sin(pose.heading) * v > 0
        edge = r > s.return_fraction * s.fence_radius
        if returning:
            err = math.atan2(-pose.y, -pose.x) - pose.heading
            err = wrap_angle(err)
            if abs(err) < 0.2:
                returning = False
                v, w = sample_command(rng, s, nominal.track_width, forward=True)
                left_s = float(rng.uniform(*s.hold))
            else:
                wr_ = min(s.max_turn_rate, s.max_speed / half)
                v, w = 0.0, math.copysign(wr_, err)
        elif edge and (outward or left_s <= 0):
            returning = True
            continue
        elif left_s <= 0:
            v, w = sample_command(rng, s, nominal.track_width)
            left_s = float(rng.uniform(*s.hold))
        robot.set_wheel_speeds(v - w * half, v + w * half)
        robot.advance(period)
        stalled = stalled or robot.stalled
        record()
        now = robot.wheel_ticks()
        odo.update_increments(robot.time, now[0] - last[0], now[1] - last[1])
        last = now
        left_s -= period
        k += 1
    robot.set_wheel_speeds(0.0, 0.0)
    robot.advance(period)
    record()
    a = np.array(rows)
    ticks_l = np.floor(a[:, 1] + 0.5)
    ticks_r = np.floor(a[:, 2] + 0.5)
    dl = np.diff(ticks_l, prepend=ticks_l[0])
    dr = np.diff(ticks_r, prepend=ticks_r[0])
    return Drive(a[:, 0], dl, dr, a[:, 3], a[:, 4], a[:, 5], stalled)


def write_exploration(folder: str | Path, run: Drive, name: str = "explore") -> tuple[Path, Path]:
    """Write a recorded run as ``<folder>/<name>.csv`` (``t,dticks_left,dticks_right``) and
    its ground truth as ``<folder>/<name>_gt.csv`` (read back by ``--format csv``)."""
    from odolab.core.trajectory import Trajectory
    from odolab.core.writing import given_folder, replacing_path
    from odolab.io.tabular import write_columns
    from odolab.io.trajectory_csv import write_trajectory_csv

    out = given_folder(
        folder, expected="a folder for the exploration run", cannot="the folder", error=SimError
    )
    log, gt = out / f"{name}.csv", out / f"{name}_gt.csv"
    # both through temporary files, renamed only when both are written: a failure leaves an
    # earlier run's pair as it was, never a new log beside an old truth
    with (
        replacing_path(log, what="exploration's encoder log", error=SimError) as log_tmp,
        replacing_path(gt, what="exploration's ground truth", error=SimError) as gt_tmp,
    ):
        write_columns(
            log_tmp,
            {"t": run.t, "dticks_left": run.dticks_left, "dticks_right": run.dticks_right},
            "encoder log",
        )
        write_trajectory_csv(gt_tmp, Trajectory.from_xyh(run.t, run.x, run.y, run.heading))
    return log, gt
