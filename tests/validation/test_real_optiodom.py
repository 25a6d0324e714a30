"""Real robot runs (OptiOdom): motion-capture heading stands in for the phone's.

The runs' ground truth is already on the odometry's clock, so a clock shift we add must come back
(within the real logs' own sync and 20 Hz sampling), and with the offset fixed the comparison must
equal the error computed directly from the file.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from odolab.core.odometry import integrate
from odolab.core.params import RobotParams
from odolab.core.trials import EncoderLog
from odolab.validation import ImuLog, read_sensorlog, validate, write_sensorlog

NOMINAL = RobotParams(
    left_wheel_radius=0.042,
    right_wheel_radius=0.042,
    track_width=0.2,
    ticks_per_rev=43.7 * 64,
    name="optiodom-nominal",
)


def _run(path: Path) -> tuple[EncoderLog, np.ndarray, np.ndarray]:
    d = np.loadtxt(path, delimiter=",")  # t, x_gt, y_gt, theta_gt, dticks_right, dticks_left
    t = d[:, 0]
    left = np.cumsum(d[:, 5]).astype(np.int64)
    right = np.cumsum(d[:, 4]).astype(np.int64)
    return EncoderLog(t, left, right, None), t, np.unwrap(d[:, 3])


@pytest.mark.parametrize(
    "run", ["circular/231220200121/231220200121_run-01.csv", "square/*/*_run-01.csv"]
)
def test_clock_shift_comes_back_on_real_runs(optiodom_dir: Path, run: str, tmp_path: Path) -> None:
    path = sorted(optiodom_dir.glob(run))[0]
    enc, t, gt = _run(path)
    # through a real file: the motion-capture heading written as a SensorLog, 1 h 3.3 s ahead
    csv = write_sensorlog(tmp_path / "gt.csv", t + 3603.3, gt + 2.0, np.gradient(gt, t))
    imu = read_sensorlog(csv)
    r = validate(enc, imu, NOMINAL, NOMINAL.with_(track_width=0.205), offset=3600.0)
    assert r.clock_offset == pytest.approx(3603.3, abs=0.1)  # two 20 Hz samples
    assert r.alignment.correlation > 0.95
    assert r.warnings == ()


def test_fixed_offset_error_equals_the_direct_computation(optiodom_dir: Path) -> None:
    path = optiodom_dir / "circular/231220200121/231220200121_run-01.csv"
    enc, t, gt = _run(path)
    imu = ImuLog(t + 10.0, gt - 5.0, None, "gt")
    r = validate(enc, imu, NOMINAL, NOMINAL.with_(track_width=0.21), offset=10.0, max_offset=0.0)
    odo = integrate(t, enc.left_ticks, enc.right_ticks, NOMINAL).heading
    direct = (odo - odo[0]) - (gt - gt[0])
    np.testing.assert_allclose(r.old.error, direct, atol=1e-9)
    assert r.old.rms == pytest.approx(float(np.sqrt(np.mean(direct**2))))
    # this circle turned about -12.45 rad; a wider track turns less in the model
    assert r.imu_heading[-1] == pytest.approx(-12.45, abs=0.01)
    assert abs(r.new.heading[-1]) < abs(r.old.heading[-1])
