"""The virtual robot's physics step written once (odolab.sim._physics_kernels) and run two ways:
numba's twins for batches and schedules, the source itself for the real-time sim-server board."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from odolab.core.params import PRESETS
from odolab.sim.plants import make_plant
from odolab.sim.presets import TRUTH_PRESETS

ROOT = Path(__file__).resolve().parents[2]
NOMINAL = PRESETS["jaguar-lite"]


def _drive(compiled: bool, truth: str, terrain: str, seed: int) -> np.ndarray:
    """Random wheel speeds for 60 cycles of 50 ms (stops, reversals, turns in place), then the
    state after each: time, counters, continuous ticks and the true pose."""
    rng = np.random.default_rng(seed)
    robot = make_plant(truth, NOMINAL, terrain, seed=seed, compiled=compiled)
    rows = []
    for k in range(60):
        if k % 7 == 6:
            left, right = 0.0, 0.0  # an abrupt stop: the slide
        else:
            left, right = rng.uniform(-0.8, 0.8, 2)
        robot.set_wheel_speeds(left, right)
        robot.advance(0.05 if k % 5 else 0.0505)  # and a step shorter than dt
        p = robot.true_pose
        rows.append([p.t, *robot.encoder_counts(), *robot.wheel_ticks(), p.x, p.y, p.heading])
    return np.array(rows)


@pytest.mark.parametrize("truth", ["jaguar-lab", "jaguar-lab-tracked", "ideal"])
@pytest.mark.parametrize("terrain", ["tile", "grass"])
def test_the_plain_step_gives_the_compiled_numbers(truth: str, terrain: str) -> None:
    """The same operations in the same order: equal to the last bit (measured: every value
    equal, 3 truths x 2 terrains x 3 seeds x 60 cycles x 8 values)."""
    assert truth in TRUTH_PRESETS
    for seed in (1, 2, 3):
        np.testing.assert_array_equal(
            _drive(False, truth, terrain, seed), _drive(True, truth, terrain, seed)
        )


def test_a_real_time_board_process_loads_no_numba() -> None:
    """`odolab robot sim-server`'s board (its plant stepped as Python) and a drive of it: no
    numba in the process (its import and the kernels' load were about half a second of CPU)."""
    code = (
        "import sys\n"
        "from odolab.app.robot import BoardRequest, virtual_board\n"
        "board = virtual_board(BoardRequest(port=0), lambda *a: None)\n"
        "try:\n"
        "    board.plant.set_wheel_speeds(0.3, -0.3)\n"
        "    board.plant.advance(0.5)\n"
        "    board.plant.set_wheel_speeds(0.0, 0.0)\n"
        "    assert not board.plant.compiled\n"
        "finally:\n"
        "    board.server.close()\n"
        "print('numba' in sys.modules)\n"
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stdout.strip() == "False"
