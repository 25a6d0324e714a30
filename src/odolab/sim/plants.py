"""The simulator as the plant of a virtual robot board (``odolab.robot.plant.Plant``).

:func:`make_plant` builds a :class:`~odolab.sim.physics.VirtualRobot` from a truth preset name or
:class:`~odolab.sim.physics.TrueParams`; it satisfies the robot stack's ``Plant`` interface
structurally, so the robot stack never imports the simulator (the CLI and the lab wire them).
"""

from __future__ import annotations

from odolab.core.defaults import DEFAULT_SEED, DEFAULT_TERRAIN
from odolab.core.errors import SimError
from odolab.core.params import RobotParams
from odolab.sim.physics import TrueParams, VirtualRobot
from odolab.sim.presets import TRUTH_PRESETS

__all__ = ["make_plant"]


def make_plant(
    truth: str | TrueParams,
    nominal: RobotParams,
    terrain: str = DEFAULT_TERRAIN,
    *,
    seed: int = DEFAULT_SEED,
    compiled: bool = True,
) -> VirtualRobot:
    """The simulated robot for ``truth`` (a name in ``TRUTH_PRESETS`` or a ``TrueParams``);
    ``compiled=False``: its physics step as plain Python (the same numbers; for a board that
    runs in real time, whose process then loads no numba)."""
    if isinstance(truth, str):
        if truth not in TRUTH_PRESETS:
            raise SimError(
                f"unknown truth preset {truth!r}; expected one of {', '.join(TRUTH_PRESETS)}"
            )
        truth = TRUTH_PRESETS[truth]
    if not isinstance(truth, TrueParams):
        raise SimError(f"truth must be a preset name or TrueParams, got {type(truth).__name__}")
    return VirtualRobot(truth, nominal, terrain, seed=seed, compiled=compiled)
