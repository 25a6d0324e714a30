"""Pose covariance of odometry with the slip model: moved to :mod:`odolab.core.models.slip_covariance`
(the slip model's own covariance lives with the model). The names stay importable from here.
"""

from odolab.core.models.slip_covariance import *  # noqa: F403
from odolab.core.models.slip_covariance import __all__ as __all__
