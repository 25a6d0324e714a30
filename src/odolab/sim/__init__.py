"""The virtual Jaguar: robot physics, terrains, instruments and the lab's experiment protocols.

- :mod:`odolab.sim.physics`: :class:`TrueParams`, :class:`VirtualRobot`, the batch kernel.
- :mod:`odolab.sim.terrains`: ``tile``, ``concrete``, ``grass``.
- :mod:`odolab.sim.presets`: ``TRUTH_PRESETS`` (``ideal``, ``jaguar-lab``, ``jaguar-lab-track``),
  ``derive_jaguar_lab``, ``LAB_REPORT_SEED``.
- :mod:`odolab.sim.instruments`: compass with counted turns, meterstick / tape.
- :mod:`odolab.sim.protocols`: protocol TOML files, ``run_protocol`` (vectorized Monte Carlo).
- :mod:`odolab.sim.export`: ``write_encoder_logs`` (trials: :func:`odolab.store.csvio.write_trials_csv`).

See docs/sim.md.
"""

from __future__ import annotations

from odolab.sim.physics import TrueParams, VirtualRobot
from odolab.sim.terrains import TERRAINS, Terrain, get_terrain

__all__ = ["TERRAINS", "Terrain", "TrueParams", "VirtualRobot", "get_terrain"]
