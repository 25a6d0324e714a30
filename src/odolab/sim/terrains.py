"""Ground presets: how a surface changes what the tracks do.

A :class:`Terrain` scales the robot's true behaviour (:class:`~odolab.sim.physics.TrueParams`,
which describes the robot on the indoor lab tile):

- ``radius_scale`` multiplies every effective wheel radius for any robot (1 for the built-ins:
  how much a given robot's tracks bite into a surface is a property of that robot, kept in
  ``TrueParams.terrain_radius_scale``; ``jaguar-lab`` has concrete ``0.920 / 0.905`` and grass
  ``0.904 / 0.905`` from the lab's x ratios).
- ``slip_scale`` multiplies the per-wheel slip noise constants ``k_left`` and ``k_right``;
  ``scrub_scale`` multiplies the turn-scrub noise ``k_scrub``.
- ``can_turn_in_place``: on concrete and grass a tracked robot's static friction is larger than
  the motors can overcome when the tracks turn in opposite directions; it stalls (the tracks do
  not move, and the encoders show it). It can still pivot on one track.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from odolab.core.errors import SimError
from odolab.core.text import quote_input

__all__ = ["TERRAINS", "Terrain", "get_terrain"]


@dataclass(frozen=True)
class Terrain:
    """How a surface changes the robot's true behaviour (multipliers on the tile values)."""

    name: str
    radius_scale: float = 1.0
    slip_scale: float = 1.0
    scrub_scale: float = 1.0
    can_turn_in_place: bool = True
    outdoor: bool = False
    description: str = ""

    def __post_init__(self) -> None:
        for key in ("radius_scale", "slip_scale", "scrub_scale"):
            value = getattr(self, key)
            if not isinstance(value, int | float) or not math.isfinite(value) or value < 0:
                raise SimError(f"terrain {self.name!r}: {key} must be a finite number >= 0")
        if self.radius_scale <= 0:
            raise SimError(f"terrain {self.name!r}: radius_scale must be > 0")


#: Built-in terrains. Tile is the reference (the lab floor the true parameters describe).
TERRAINS: dict[str, Terrain] = {
    "tile": Terrain("tile", description="indoor lab floor (the reference surface)"),
    "concrete": Terrain(
        "concrete",
        slip_scale=2.0,
        can_turn_in_place=False,
        outdoor=True,
        description="sidewalk concrete: grips, cannot turn in place",
    ),
    "grass": Terrain(
        "grass",
        slip_scale=4.0,
        scrub_scale=2.0,
        can_turn_in_place=False,
        outdoor=True,
        description="lawn: more slip, cannot turn in place",
    ),
}


def get_terrain(terrain: str | Terrain, *, where: str = "terrain") -> Terrain:
    """A :class:`Terrain` by name (or the object itself); ``where`` names the source in errors."""
    if isinstance(terrain, Terrain):
        return terrain
    try:
        return TERRAINS[str(terrain)]
    except KeyError:
        raise SimError(
            f"{where}: unknown terrain {quote_input(str(terrain))}; expected one of "
            f"{', '.join(TERRAINS)}"
        ) from None
