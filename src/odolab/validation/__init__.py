"""odolab.validation: old vs new parameters vs a phone IMU (the lab's Fig. 21).

- :func:`read_sensorlog` / :func:`write_sensorlog`: the SensorLog app's CSV (:class:`ImuLog`).
- :func:`find_clock_offset`: the phone-minus-robot clock offset from cross-correlated yaw rates.
- :func:`validate`: heading error over time of two parameter sets against the IMU, RMS before and
  after (:class:`ValidationResult`); :func:`plot_validation`, :func:`validation_figure`.
- :func:`simulate_phone_log`, :func:`rotation_scenario`, :func:`write_demo`: a simulated phone and
  a stand-alone turning-in-place scenario for demos and tests.
"""

from odolab.io.sensorlog import ImuLog, read_sensorlog, write_sensorlog
from odolab.validation.align import ClockAlignment, find_clock_offset
from odolab.validation.compare import (
    HeadingError,
    ValidationResult,
    plot_validation,
    validate,
    validation_figure,
)
from odolab.validation.simulate import (
    RotationScenario,
    rotation_scenario,
    simulate_phone_log,
    write_demo,
)

__all__ = [
    "ClockAlignment",
    "HeadingError",
    "ImuLog",
    "RotationScenario",
    "ValidationResult",
    "find_clock_offset",
    "plot_validation",
    "read_sensorlog",
    "rotation_scenario",
    "simulate_phone_log",
    "validate",
    "validation_figure",
    "write_demo",
    "write_sensorlog",
]
