"""The virtual Jaguar: robot physics, terrains, instruments and the lab's experiment protocols.

- :mod:`odolab.sim.truth`: :class:`TrueParams` (the robot's true behaviour).
- :mod:`odolab.sim.physics`: :class:`VirtualRobot`, the batch kernel (numba: loaded on first use
  of ``VirtualRobot`` here, so that naming a truth or a terrain does not load it).
- :mod:`odolab.sim.terrains`: ``tile``, ``concrete``, ``grass``.
- :mod:`odolab.sim.presets`: ``TRUTH_PRESETS`` (``ideal``, ``jaguar-lab``, ``jaguar-lab-track``,
  ``jaguar-lab-tracked``: an ICR vehicle, docs/models.md), ``derive_jaguar_lab``,
  ``LAB_REPORT_SEED``.
- :mod:`odolab.sim.instruments`: compass with counted turns, meterstick / tape.
- :mod:`odolab.sim.protocols`: protocol TOML files, ``run_protocol`` (vectorized Monte Carlo).
- :mod:`odolab.sim.export`: ``write_encoder_logs`` (trials: :func:`odolab.store.csvio.write_trials_csv`).
- :mod:`odolab.sim.drives`: free drives (wheel-speed legs) recorded with the true pose.

See docs/sim.md.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from odolab.sim.terrains import TERRAINS, Terrain, get_terrain
from odolab.sim.truth import TrueParams

if TYPE_CHECKING:
    from odolab.sim.physics import VirtualRobot

__all__ = ["TERRAINS", "Terrain", "TrueParams", "VirtualRobot", "get_terrain"]


def __getattr__(name: str) -> object:
    """:class:`VirtualRobot`, loaded on first use (the compiled physics imports numba)."""
    if name == "VirtualRobot":
        from odolab.sim.physics import VirtualRobot

        return VirtualRobot
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
