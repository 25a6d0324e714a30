"""A simulated fleet: many robots, each with its own true parameters, wearing over days.

Every run is written as an encoder CSV run (:mod:`odolab.io.csv_run`): ``<root>/<robot>/<date>/
run-NNN.csv`` (``t,left_ticks,right_ticks``, raw 15-bit counters) with ``run-NNN_gt.csv`` beside
it (the true trajectory, ``t,x,y,theta,heading``), so ``odolab evaluate --format csv`` reads it.
``fleet.json`` at the root keeps each robot's truth per day (what a fleet report should find).

Each robot's effective wheel radii and track width differ from the nominal model by its own
factors; some robots *wear*: their left radius shrinks a little every day, so their odometry
drifts more and more (the ones a fleet report must flag for recalibration).
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from odolab.core.errors import OdolabError
from odolab.core.params import PRESETS, RobotParams
from odolab.core.trajectory import Trajectory
from odolab.core.trials import EncoderLog
from odolab.core.writing import strict_json, write_text_file
from odolab.io.encoder_csv import write_encoder_csv
from odolab.io.trajectory_csv import write_trajectory_csv
from odolab.sim import TrueParams, VirtualRobot

__all__ = ["FleetSpec", "RobotTruth", "simulate_fleet", "truth_on_day"]


@dataclass(frozen=True)
class FleetSpec:
    """What to simulate: ``robots`` x ``days`` x ``runs_per_day`` runs of ``run_seconds`` each.

    ``wearing``: how many of the robots wear (their left radius shrinks ``wear_per_day``, a
    fraction per day). ``rate``: encoder samples per second. ``seed`` makes it all repeatable.
    """

    robots: int = 4
    days: int = 5
    runs_per_day: int = 3
    run_seconds: float = 40.0
    wearing: int = 1
    wear_per_day: float = 0.003
    rate: float = 20.0
    start_date: str = "2026-03-02"
    seed: int = 0
    nominal: str = "jaguar-lite"

    def __post_init__(self) -> None:
        for name in ("robots", "days", "runs_per_day"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise OdolabError(f"fleet {name} is {value!r}; expected a whole number >= 1")
        if not 0 <= self.wearing <= self.robots:
            raise OdolabError(
                f"fleet wearing is {self.wearing!r}; expected 0..{self.robots} robots"
            )
        for name in ("run_seconds", "rate"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise OdolabError(f"fleet {name} is {value!r}; expected a positive number")
        if not (math.isfinite(self.wear_per_day) and 0 <= self.wear_per_day < 0.05):
            raise OdolabError(
                f"fleet wear_per_day is {self.wear_per_day!r}; expected 0 <= fraction < 0.05"
            )
        try:
            dt.date.fromisoformat(self.start_date)
        except ValueError as err:
            raise OdolabError(
                f"fleet start date is {self.start_date!r}; expected YYYY-MM-DD"
            ) from err

    @property
    def runs(self) -> int:
        """Total number of runs."""
        return self.robots * self.days * self.runs_per_day


@dataclass(frozen=True)
class RobotTruth:
    """One robot's true geometry on day 0 and its wear (fraction of left radius per day)."""

    robot: str
    left_radius: float
    right_radius: float
    track_width: float
    wear_per_day: float

    def on_day(self, day: int) -> TrueParams:
        """The robot's true parameters on ``day`` (0-based)."""
        left = self.left_radius * (1.0 - self.wear_per_day * day)
        return TrueParams(
            left_radius_forward=left,
            left_radius_reverse=left,
            right_radius_forward=self.right_radius,
            right_radius_reverse=self.right_radius,
            track_width=self.track_width,
            k_left=1e-5,
            k_right=1e-5,
            k_scrub=1e-5,
            name=self.robot,
        )


def truth_on_day(truth: RobotTruth, day: int) -> TrueParams:
    """Shortcut for :meth:`RobotTruth.on_day`."""
    return truth.on_day(day)


def _truths(spec: FleetSpec, nominal: RobotParams, rng: np.random.Generator) -> list[RobotTruth]:
    out = []
    for k in range(spec.robots):
        wear = spec.wear_per_day if k >= spec.robots - spec.wearing else 0.0
        out.append(
            RobotTruth(
                robot=f"robot-{k + 1:02d}",
                left_radius=nominal.left_wheel_radius * (1.0 + rng.normal(0.0, 0.002)),
                right_radius=nominal.right_wheel_radius * (1.0 + rng.normal(0.0, 0.002)),
                track_width=nominal.track_width * (1.0 + abs(rng.normal(0.005, 0.003))),
                wear_per_day=wear,
            )
        )
    return out


def _drive(
    truth: TrueParams, nominal: RobotParams, spec: FleetSpec, seed: int
) -> tuple[EncoderLog, Trajectory]:
    """One run: a random sequence of straights and turns; counters and truth at ``rate``."""
    rng = np.random.default_rng(seed)
    robot = VirtualRobot(truth, nominal, "tile", seed=seed, dt=0.005)
    robot.reset(misalign=False)
    period = 1.0 / spec.rate
    n = round(spec.run_seconds * spec.rate) + 1
    t: NDArray[np.float64] = np.arange(n, dtype=np.float64) * period
    left = np.empty(n, dtype=np.int64)
    right = np.empty(n, dtype=np.int64)
    x, y, h = np.empty(n), np.empty(n), np.empty(n)
    t0 = robot.time
    seg_end = 0
    for i in range(n):
        if i == seg_end:  # a new segment: straight (always the first) or turn, 1-4 s
            if i == 0 or rng.random() < 0.6:
                v = rng.uniform(0.3, 1.0)
                vl = vr = v
            else:
                w = rng.uniform(0.2, 0.5) * rng.choice((-1.0, 1.0))
                v = rng.uniform(0.0, 0.4)
                vl, vr = v - w, v + w
            robot.set_wheel_speeds(vl, vr)
            seg_end = i + int(rng.integers(round(2 * spec.rate), round(4 * spec.rate)))
        if i > 0:
            robot.advance(period)
        left[i], right[i] = robot.encoder_counts()
        pose = robot.true_pose
        x[i], y[i], h[i] = pose.x, pose.y, pose.heading
    del t0
    log = EncoderLog(t, left, right, nominal.encoder_modulus)
    return log, Trajectory.from_xyh(t, x, y, h)


def simulate_fleet(
    root: str | Path,
    spec: FleetSpec | None = None,
    *,
    progress: Callable[[int, int, str], None] | None = None,
) -> list[Path]:
    """Write the fleet's runs under ``root``; returns the encoder log paths (sorted).

    Raises:
        OdolabError: a robot names a nominal preset odolab does not have.
    """
    s = spec or FleetSpec()
    if s.nominal not in PRESETS:
        raise OdolabError(
            f"unknown nominal preset {s.nominal!r}; expected one of {sorted(PRESETS)}"
        )
    nominal = PRESETS[s.nominal]
    out = Path(root)
    rng = np.random.default_rng(s.seed)
    truths = _truths(s, nominal, rng)
    start = dt.date.fromisoformat(s.start_date)
    paths: list[Path] = []
    done = 0
    for r, truth in enumerate(truths):
        for day in range(s.days):
            date = (start + dt.timedelta(days=day)).isoformat()
            folder = out / truth.robot / date
            true_params = truth.on_day(day)
            for k in range(s.runs_per_day):
                seed = s.seed * 1_000_003 + (r * s.days + day) * s.runs_per_day + k
                log, gt = _drive(true_params, nominal, s, seed)
                path = folder / f"run-{k + 1:03d}.csv"
                write_encoder_csv(path, log)
                write_trajectory_csv(folder / f"run-{k + 1:03d}_gt.csv", gt)
                paths.append(path)
                done += 1
                if progress is not None:
                    progress(done, s.runs, str(path))
    manifest = {
        "spec": asdict(s),
        "nominal": nominal.to_dict(),
        "robots": [asdict(t) for t in truths],
    }
    text = strict_json(manifest) + "\n"
    write_text_file(out / "fleet.json", text, what="fleet manifest")
    return sorted(paths)
