"""The compiled pose-step functions of :mod:`odolab.core.kinematics` (numba), in their own module so
that importing :mod:`odolab.core.kinematics` does not import numba: reach them through
``odolab.core.kinematics`` (``from odolab.core.kinematics import step_pose``), which loads this on first use.

Each is numba's compilation of the plain kernel of the same name in
:mod:`odolab.core._step_kernels` (its twin: the same source), which the covariance, the
simulator and the batch passes' general step inline (``inline="always"``; numba's cache keeps
their machine code). The batch's fast path for the linear models fuses the same operations by
hand (:func:`odolab.core._odometry_kernels._model_steps`), tested equal to rounding.
"""

from __future__ import annotations

from odolab.core import _step_kernels as _plain
from odolab.core._jit import twin

__all__ = ["body_motion", "chord", "chord_derivative", "step_pose", "wrap"]

#: The plain module's names, with each kernel replaced by its twin as it is made.
_TWINS: dict[str, object] = dict(vars(_plain))

chord = twin(_plain.chord, _TWINS)
chord_derivative = twin(_plain.chord_derivative, _TWINS)
body_motion = twin(_plain.body_motion, _TWINS)
step_pose = twin(_plain.step_pose, _TWINS)
wrap = twin(_plain.wrap, _TWINS)
