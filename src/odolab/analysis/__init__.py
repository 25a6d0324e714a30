"""Systematic and random error of odometry from lab trials (issue 6).

``analyze_trials(trials) -> LabAnalysis`` does all the work; ``table1(analysis)`` gives the lab's
Table I rows. The pieces (line fits, random error, growth of sigma, wheel noise, terrain
comparison, outliers) are public for direct use on arrays.
"""

from __future__ import annotations

from odolab.analysis.core import MOTIONS, LabAnalysis, MotionAnalysis, analyze_trials
from odolab.analysis.growth import GrowthFit, fit_growth
from odolab.analysis.noise import WheelNoise, fit_wheel_noise
from odolab.analysis.outliers import Outlier, miscounted_turns
from odolab.analysis.random import (
    GroupSpread,
    RandomError,
    group_spreads,
    random_error,
    sd_confidence_interval,
)
from odolab.analysis.systematic import MIN_FIT_POINTS, LinearFit, fit_line
from odolab.analysis.table1 import table1
from odolab.analysis.terrain import TerrainComparison, compare_terrains

__all__ = [
    "MIN_FIT_POINTS",
    "MOTIONS",
    "GroupSpread",
    "GrowthFit",
    "LabAnalysis",
    "LinearFit",
    "MotionAnalysis",
    "Outlier",
    "RandomError",
    "TerrainComparison",
    "WheelNoise",
    "analyze_trials",
    "compare_terrains",
    "fit_growth",
    "fit_line",
    "fit_wheel_noise",
    "group_spreads",
    "miscounted_turns",
    "random_error",
    "sd_confidence_interval",
    "table1",
]
