"""The constants of the pose step that the plain kinematics and its compiled twin share.

A module of its own so that :mod:`odolab.core._kinematics_jit` (which imports numba) and
:mod:`odolab.core.kinematics` (which must not, until a compiled function is used) read the same
numbers without importing each other.
"""

from __future__ import annotations

import math

#: Below this |dtheta/2| the arc's chord factor uses its series ``1 - u^2/6`` (error < 1e-17).
SMALL_ANGLE = 1e-4
TWO_PI = 2.0 * math.pi
