"""Exploration drives (issue 29): commands over the input space, held a few seconds, inside a
geofence watched by odometry."""

from __future__ import annotations

import numpy as np
import pytest

from odolab.core.errors import SimError
from odolab.core.odometry import integrate_increments
from odolab.core.params import PRESETS
from odolab.sim.explore import ExploreSettings, explore, sample_command
from odolab.sim.presets import TRUTH_PRESETS

NOMINAL = PRESETS["jaguar-lite"]
TRUTH = TRUTH_PRESETS["jaguar-lab-tracked"]


def test_commands_cover_the_input_space_within_the_wheel_limit() -> None:
    s = ExploreSettings(max_speed=1.0, max_turn_rate=2.0)
    rng = np.random.default_rng(0)
    cmds = np.array([sample_command(rng, s, 0.56) for _ in range(4000)])
    v, w = cmds[:, 0], cmds[:, 1]
    # measured: the limit holds by construction (a clip) at every seed shift 0-3
    assert np.all(np.abs(v) + 0.28 * np.abs(w) <= 1.0 + 1e-12)
    # measured |v| extremes 0.975-0.997 and |w| 1.997-2.000 over seed shifts 0-3 (4000 draws);
    # bounds 0.9, 1.9
    assert v.min() < -0.9 and v.max() > 0.9 and w.min() < -1.9 and w.max() > 1.9
    # measured |mean v| 0.0003-0.0036, |mean w| 0.004-0.040 over seed shifts 0-3; bounds 0.03, 0.06
    assert abs(v.mean()) < 0.03 and abs(w.mean()) < 0.06  # no side preferred


def test_exploration_stays_inside_the_fence() -> None:
    s = ExploreSettings(seconds=60.0, fence_radius=2.0)
    d = explore(TRUTH, NOMINAL, s, seed=3)
    # measured 60.05 to 1e-12 at every seed (the clock); tolerance 0.01
    assert d.t[-1] == pytest.approx(60.05, abs=0.01)
    # the fence watches the odometry (the nominal parameters' pose): that is what it bounds
    odo = integrate_increments(d.t, d.dticks_left, d.dticks_right, NOMINAL)
    # measured 1.418-1.426 m over seeds 3-6 (0.7 R plus a turn); bound R = 2.0, 29 % above
    assert float(np.max(np.hypot(odo.x, odo.y))) < 2.0
    r = np.hypot(d.x, d.y)
    # measured 1.87 m at the test's seed; over seed shifts 1-3 1.77-4.36 m: the true pose can
    # leave the fence (shift 1: 4.36 m), which `sim explore` says when it happens; this seed's
    # true path stays inside, 6 % under the bound
    assert r.max() < 2.0
    assert r.max() > 1.0  # it did explore
    speeds = np.abs(np.diff(d.dticks_left + d.dticks_right))
    assert speeds.max() > 0


def test_bad_settings_are_one_sentence() -> None:
    with pytest.raises(SimError, match="exploration distribution 'gauss' is unknown"):
        ExploreSettings(distribution="gauss")
    with pytest.raises(SimError, match="exploration hold"):
        ExploreSettings(hold=(3.0, 1.0))


def _drive_motion(motion, truth, seconds: float, rate: float = 20.0):  # type: ignore[no-untyped-def]
    from odolab.core.odometry import Odometry
    from odolab.sim.physics import VirtualRobot

    robot = VirtualRobot(truth, NOMINAL, "tile", seed=1, dt=0.005)
    robot.reset(misalign=False)
    odo = Odometry(NOMINAL)
    pose = odo.update(0.0, *robot.encoder_counts())
    motion.start(pose, NOMINAL)
    poses = [pose]
    for k in range(1, round(seconds * rate) + 1):
        speeds = motion.step(pose)
        if speeds is None:
            break
        robot.set_wheel_speeds(*speeds)
        robot.advance(1.0 / rate)
        pose = odo.update(k / rate, *robot.encoder_counts())
        poses.append(pose)
    robot.set_wheel_speeds(0.0, 0.0)
    return poses


def test_live_exploration_motion_stays_inside_and_stops_at_the_fence() -> None:
    from odolab.robot.explore_motion import Explore

    motion = Explore(seconds=30.0, max_speed=0.5, fence_radius=2.0, seed=4)
    poses = _drive_motion(motion, TRUTH, 40.0)
    r = np.array([np.hypot(p.x, p.y) for p in poses])
    # measured |value - expected| 0 over seed shifts 0-3; tolerance 0.06; the same at every seed
    assert poses[-1].t == pytest.approx(30.0, abs=0.06)  # ran its time, then stopped
    assert not motion.fence_crossed and r.max() < 2.0 and r.max() > 0.8
    # the fence is a hard limit: the cycle that finds the robot outside it stops it
    from odolab.core.trajectory import Pose

    fenced = Explore(seconds=30.0, fence_radius=1.0, seed=4)
    fenced.start(Pose(0.0, 1.0, 2.0, 0.0, 0.0), NOMINAL)
    assert fenced.step(Pose(0.05, 1.2, 2.3, 0.0, 0.0)) is not None
    assert fenced.step(Pose(0.10, 1.6, 2.9, 0.0, 0.0)) is None  # 1.06 m from the start
    assert fenced.fence_crossed
    with pytest.raises(SimError, match="exploration fence_radius is 0"):
        Explore(fence_radius=0)
