"""Compatibility: the compass and meterstick measurement model moved to :mod:`odolab.measurement`.

It is core (the CLI, the CSV import and the notebook all build measurements from readings); import
it from there. This module only re-exports it.
"""

from odolab.measurement import (
    COMPASS_SIGMA_RAD,
    MAX_POSITION_M,
    METERSTICK_SIGMA_M,
    check_compass_reading,
    check_reading,
    rotation_from_compass,
    rotation_measurement_from_compass,
    translation_measurement,
)

__all__ = [
    "COMPASS_SIGMA_RAD",
    "MAX_POSITION_M",
    "METERSTICK_SIGMA_M",
    "check_compass_reading",
    "check_reading",
    "rotation_from_compass",
    "rotation_measurement_from_compass",
    "translation_measurement",
]
