"""The drift monitor's goals (docs/imu.md), on the 2014 Jaguar's link in simulated time.

- False alarms: 10 minutes of turning in place (600 rad at 1 rad/s) on the simulator's
  jaguar-lab robot (its turn scrub: a heading sigma of 2.94 rad at 20 pi) with parameters whose
  rotation ratio is the lab's 0.875, for several seeds: the flags raised (expected: none).
- Detection: an ideal robot whose track grows (or shrinks) 5 % at 15 s of a 6-turn rotation:
  the seconds from the change to the flag (goal: within 10 s).

    python benchmarks/bench_drift.py [SEEDS]   # default 3
"""

from __future__ import annotations

import math
import sys

from odolab.core.params import PRESETS, RobotParams
from odolab.core.trials import Command, MotionKind
from odolab.robot.plant import IdealPlant
from odolab.robot.session import run_simulated
from odolab.sim.plants import make_plant

NOMINAL = PRESETS["jaguar-lite"]


class _Changing(IdealPlant):
    def __init__(self, truth: RobotParams, after: RobotParams, at: float) -> None:
        super().__init__(truth)
        self.after, self.at = after, at

    def advance(self, duration: float) -> None:
        if self._t >= self.at:
            self.truth = self.after
        super().advance(duration)


def main(seeds: int) -> None:
    cal = NOMINAL.with_(track_width=NOMINAL.track_width / 0.875)
    for seed in range(seeds):
        run = run_simulated(
            Command(MotionKind.ROTATION, angle=600.0, speed=1.0),
            nominal=cal,
            plant=make_plant("jaguar-lab", cal, seed=seed),
            link="jaguar2014",
            seed=seed,
        )
        flags = run.extra["drift"]["flags"]
        print(f"jaguar-lab, 10 min, seed {seed}: {len(flags)} flag(s) {flags}")
    for factor in (1.05, 1 / 1.05):
        plant = _Changing(NOMINAL, NOMINAL.with_(track_width=NOMINAL.track_width * factor), 15.0)
        run = run_simulated(
            Command(MotionKind.ROTATION, angle=12 * math.pi, speed=1.0),
            nominal=NOMINAL,
            plant=plant,
            link="jaguar2014",
        )
        flags = run.extra["drift"]["flags"]
        after = [f"{t - 15.0:.1f} s" for t, _ in flags]
        print(f"track x {factor:.4f} at 15 s: flagged after {after}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 3)
