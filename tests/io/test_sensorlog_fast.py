"""SensorLog CSVs are read by polars' parser: no pandas, no warning for the short rows
SensorLog writes, and the values of the careful reader."""

from __future__ import annotations

import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np

from odolab.io.sensorlog import read_sensorlog, write_sensorlog


def test_short_rows_read_without_a_warning(tmp_path: Path) -> None:
    p = tmp_path / "imu.csv"
    p.write_text(
        "motionTimestamp_sinceReboot(s),motionYaw(rad),gyroRotationZ(rad/s)\n"
        "1.0,0.1,0.5\n2.0,0.2\n\n3.0,0.3,0.5\n"  # a short row, a blank line
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        log = read_sensorlog(p)
    assert [str(w.message) for w in caught] == []  # pandas warned "Length of header ..."
    np.testing.assert_array_equal(log.t, [1.0, 2.0, 3.0])
    np.testing.assert_allclose(log.yaw, [0.1, 0.2, 0.3])


def test_a_sensorlog_is_read_without_pandas(tmp_path: Path) -> None:
    t = 100.0 + 0.02 * np.arange(40)
    p = write_sensorlog(tmp_path / "imu.csv", t, 0.3 * t, np.full(40, 0.3), compass_every=4)
    code = (
        "import sys\nfrom odolab.io.sensorlog import read_sensorlog\n"
        f"log = read_sensorlog({str(p)!r})\n"
        "print(len(log), log.wallclock_offset, 'pandas' in sys.modules)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    ).stdout.split()
    assert out[0] == "40"
    assert abs(float(out[1]) - (1380834311.532 - 100.0 + 0.004)) < 1e-3  # loggingTime - t
    assert out[2] == "False"
