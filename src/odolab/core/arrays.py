"""The array types odolab annotates with, spelled once: every module imports them from here."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["FloatArray", "IntArray"]

#: an array of float64 (any shape)
FloatArray = NDArray[np.float64]
#: an array of int64 (any shape)
IntArray = NDArray[np.int64]
