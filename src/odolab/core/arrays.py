"""The numpy array types of odolab's annotations: one name for the arrays of each dtype.

``FloatArray`` is ``NDArray[np.float64]`` (any shape), ``IntArray`` ``NDArray[np.int64]`` and
``BoolArray`` ``NDArray[np.bool_]``. Modules import them from here rather than each spelling its
own alias (some under a short local name: ``from odolab.core.arrays import FloatArray as F64``).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["BoolArray", "FloatArray", "IntArray"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]
