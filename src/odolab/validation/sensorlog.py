"""Compatibility: the SensorLog (phone IMU) reader moved to :mod:`odolab.io.sensorlog`.

A reader of a log format belongs with the other readers in :mod:`odolab.io`; import it from there.
"""

from odolab.io.sensorlog import (
    DEFAULT_START,
    WRITTEN_COLUMNS,
    ImuLog,
    check_imu_log,
    rate_aided_unwrap,
    read_sensorlog,
    write_sensorlog,
)

__all__ = [
    "DEFAULT_START",
    "WRITTEN_COLUMNS",
    "ImuLog",
    "check_imu_log",
    "rate_aided_unwrap",
    "read_sensorlog",
    "write_sensorlog",
]
