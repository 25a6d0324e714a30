"""The DRIVE Husky's nominal parameters (its configuration: wheel radius 0.165 m, track 0.55 m),
as docs/real-logs.md's worked example writes them to husky.toml, for the Husky benchmarks."""

from __future__ import annotations

from odolab.core.params import PRESETS

HUSKY = PRESETS["jaguar-lite"].with_(
    name="husky",
    left_wheel_radius=0.165,
    right_wheel_radius=0.165,
    track_width=0.55,
    encoder_modulus=None,
)
