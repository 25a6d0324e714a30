"""Compatibility: the SensorLog (phone IMU) reader moved to :mod:`odolab.io.sensorlog`.

A reader of a log format belongs with the other readers in :mod:`odolab.io`; import it from there.
"""

from odolab.io.sensorlog import *  # noqa: F403
from odolab.io.sensorlog import __all__ as __all__
