"""The exploration's geofence is a hard limit, by odometry: the cycle that finds the robot outside
it commands stop and no motion follows; the stop is confirmed by the robot's data; the run ends
early, is kept (with its truth) and the CLI exits 1 saying so. A normal exploration stays inside
the fence by odometry, every command within the speed limits."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from odolab.cli import main
from odolab.core.params import PRESETS
from odolab.core.trajectory import Pose
from odolab.core.trials import Command, Exploration, TrialStatus
from odolab.io import read_trajectory
from odolab.robot.config import RunConfig
from odolab.robot.explore import ExplorePlan, plan_exploration
from odolab.robot.explore_motion import Explore
from odolab.robot.loop import CycleInfo
from odolab.robot.plant import IdealPlant
from odolab.sim.plants import make_plant

NOMINAL = PRESETS["jaguar-lite"]


class RecordingPlant(IdealPlant):
    """An ideal plant that keeps every wheel-speed change the board makes: (time, left, right)."""

    def __init__(self) -> None:
        self.speeds: list[tuple[float, float, float]] = []
        super().__init__(NOMINAL)

    def set_wheel_speeds(self, left_mps: float, right_mps: float) -> None:
        self.speeds.append((self.time, left_mps, right_mps))
        super().set_wheel_speeds(left_mps, right_mps)


def _plan(spec: Exploration) -> ExplorePlan:
    return plan_exploration(Command.exploration(spec), RunConfig(), NOMINAL, "sim://")


def test_crossing_the_fence_stops_the_robot_and_the_stop_is_confirmed(tmp_path: Path) -> None:
    """Fence 2 cm, 0.83 m/s first command (seed 3): the first report beyond it stops the run."""
    plan = _plan(Exploration(seconds=5.0, fence=0.02, max_speed=1.0, seed=3))
    plant = RecordingPlant()
    cycles: list[CycleInfo] = []
    run = plan.simulate(plant, params=NOMINAL, save_to=tmp_path / "run", on_cycle=cycles.append)
    record = run.extra["exploration"]
    assert record["fence_crossed"] is True
    t_cross, r_cross = record["crossed_at"]
    assert r_cross > 0.02 and t_cross < 0.5
    # from the crossing cycle on: no motion command, the loop settles and stops
    after = [c for c in cycles if c.t >= t_cross]
    assert after and all(c.command == (0.0, 0.0) and c.phase == "settling" for c in after)
    assert all(c.command != (0.0, 0.0) for c in cycles if c.t < t_cross)
    # the board's wheels: stopped once, never driven again; the robot's data confirmed it
    first_stop = next(i for i, s in enumerate(plant.speeds) if s[0] > 0 and s[1:] == (0.0, 0.0))
    assert all(s[1:] == (0.0, 0.0) for s in plant.speeds[first_stop:])
    assert run.stop_confirmed is True
    # ended early, kept with its truth, left out of the analysis with the reason
    assert run.loop.completed is False and run.loop.aborted.startswith("fence crossed: ")
    assert run.trial.status is TrialStatus.EXCLUDED
    doc = json.loads((tmp_path / "run" / "run.json").read_text())
    assert doc["completed"] is False and doc["stop_confirmed"] is True
    assert doc["exploration"]["fence_crossed"] is True and "fence 0.02 m" in doc["aborted"]
    truth = read_trajectory(tmp_path / "run" / "encoders_gt.csv")
    assert len(truth) == len(run.loop.log)


def test_cli_fence_crossing_exits_1_with_a_sentence_and_keeps_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    run = tmp_path / "run"
    code = main(
        [
            "robot", "explore", "--seconds", "5", "--fence", "0.02", "--max-speed", "1",
            "--explore-seed", "3", "--quiet", "--no-realtime", "--out", str(run),
        ]
    )  # fmt: skip
    out, err = capsys.readouterr()
    assert code == 1
    assert "robot stopped (its sensor data confirms it)" in err
    last = err.splitlines()[-1]
    assert last.startswith("odolab: error: the exploration left its 0.02 m fence (fence crossed: ")
    assert f"it ended early and is kept in {run}" in last
    assert f"ground truth: {run / 'encoders_gt.csv'}" in out
    doc = json.loads((run / "run.json").read_text())
    assert doc["exploration"]["fence_crossed"] is True and doc["stop_confirmed"] is True
    assert doc["status"] == "excluded" and doc["exclusion_reason"].startswith("fence crossed")


@pytest.mark.parametrize("distribution", ["uniform", "edges"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_normal_exploration_stays_inside_the_fence_by_odometry(
    seed: int, distribution: str
) -> None:
    """40 s on the slipping tracked virtual Jaguar, fence 1.5 m, 0.8 m/s."""
    spec = Exploration(seconds=40.0, fence=1.5, max_speed=0.8, seed=seed, distribution=distribution)
    plan = _plan(spec)
    plant = make_plant("jaguar-lab-tracked", NOMINAL, "tile", seed=seed)
    cycles: list[CycleInfo] = []
    run = plan.simulate(plant, params=NOMINAL, on_cycle=cycles.append)
    record = run.extra["exploration"]
    assert record["fence_crossed"] is False and run.loop.completed is True
    odometry = run.loop.log.trajectory()
    radius = np.hypot(odometry.x - odometry.x[0], odometry.y - odometry.y[0])
    assert radius.max() <= 1.5
    # it does go out to the edge, and turns back: the return radius shrunk by the odometry's
    # uncertainty (issue 39), the margin only growing
    assert radius.max() + record["largest_margin"] > 0.6 * 1.5
    half = 0.5 * NOMINAL.track_width
    for c in cycles:  # no track ever commanded beyond the exploration's speed limit
        assert max(abs(c.command[0]), abs(c.command[1])) <= 0.8 + 1e-12
    for _, v, w in record["commands"]:
        assert abs(v) + abs(w) * half <= 0.8 + 1e-12 and abs(w) <= record["max_turn_rate"]
    assert run.truth is not None and len(run.truth) == len(run.loop.log)


def test_the_motion_turns_back_near_the_edge_and_stops_beyond_it_or_after_its_time() -> None:
    motion = Explore(seconds=10.0, max_speed=0.5, max_turn_rate=1.0, fence_radius=2.0, seed=1)
    motion.start(Pose(0.0, 0.0, 0.0, 0.0, 0.0), NOMINAL)
    assert motion.step(Pose(0.0, 0.0, 0.0, 0.0, 0.0)) is not None
    # beyond 60 % of the radius, facing outward: it turns in place toward the centre
    # at the end of its hold (<= 3 s), beyond 60 % of the radius: it turns in place toward the
    # centre (behind it: the left track forward or backward, the right one the other way)
    left, right = motion.step(Pose(3.5, 1.5, 0.0, 0.0, 0.0)) or (math.nan, math.nan)
    assert left == pytest.approx(-right) and abs(left) > 0
    # beyond the fence: None (stop), and it says so
    assert motion.step(Pose(3.6, 2.01, 0.0, 0.0, 0.0)) is None
    assert motion.fence_crossed and motion.crossed_at == pytest.approx((3.6, 2.01))
    # a fresh start, then past its time: None without a crossing
    motion.start(Pose(0.0, 0.0, 0.0, 0.0, 0.0), NOMINAL)
    assert motion.step(Pose(10.0, 0.0, 0.0, 0.0, 0.0)) is None and not motion.fence_crossed
