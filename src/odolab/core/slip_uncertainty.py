"""Pose covariance of odometry with the slip model: moved to :mod:`odolab.core.models.slip_covariance`
(the slip model's own covariance lives with the model). The names stay importable from here.
"""

from __future__ import annotations

from odolab.core.models.slip_covariance import (
    HEADING_DRIFT,
    HEADING_TERMS,
    TERMS,
    EndPairs,
    SlipCovarianceStepper,
    SlipPropagation,
    describe_covariance,
    end_second_order,
    heading_moments,
    propagate_covariance,
    propagate_terms,
    terms_of,
)

__all__ = [
    "HEADING_DRIFT",
    "HEADING_TERMS",
    "TERMS",
    "EndPairs",
    "SlipCovarianceStepper",
    "SlipPropagation",
    "describe_covariance",
    "end_second_order",
    "heading_moments",
    "propagate_covariance",
    "propagate_terms",
    "terms_of",
]
