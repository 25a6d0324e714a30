"""Correct the kinematic model: ratios (the lab's section VIII, done right) and UMBmark.

Each method returns a :class:`CalibrationResult` (new :class:`~odolab.core.params.RobotParams` plus a
provenance dict) that ``save()`` writes as TOML with a ``[provenance]`` table.
"""

from __future__ import annotations

from odolab.calibration.ratios import CalibrationResult, ratios, ratios_from_analysis
from odolab.calibration.umbmark import (
    UmbmarkResult,
    e_max_syst,
    scale_sd_from,
    umbmark,
    umbmark_errors_from_trials,
    umbmark_iterated,
)

__all__ = [
    "CalibrationResult",
    "UmbmarkResult",
    "e_max_syst",
    "ratios",
    "ratios_from_analysis",
    "scale_sd_from",
    "umbmark",
    "umbmark_errors_from_trials",
    "umbmark_iterated",
]
