"""CLI commands: the lab's end-to-end job (``odolab demo``) and its steps."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from odolab.cli._apps import app

__all__: list[str] = []


@app.command("demo")
def demo_cmd(
    out: Annotated[Path, typer.Option("--out", help="Folder for the results.")] = Path(
        "odolab-out"
    ),
) -> None:
    """Run the lab end to end on the virtual Jaguar (for now: odometry of a hand-made square)."""
    import math

    import numpy as np

    from odolab.io import write_trajectory_csv
    from odolab.odometry import integrate
    from odolab.params import PRESETS

    p = PRESETS["jaguar-lite"]
    # A 1 m square driven at 20 Hz: straight legs and in-place quarter turns, counters wrapping.
    per_m = p.ticks_per_rev / (2 * math.pi * p.left_wheel_radius)
    turn = (math.pi / 2) * (p.track_width / 2) * per_m
    steps: list[tuple[float, float]] = []
    for _ in range(4):
        steps += [(per_m / 20, per_m / 20)] * 20
        steps += [(-turn / 10, turn / 10)] * 10
    d = np.array([(0.0, 0.0), *steps])
    left = (np.round(np.cumsum(d[:, 0])).astype(np.int64) + 32000) % 32768
    right = (np.round(np.cumsum(d[:, 1])).astype(np.int64) + 32000) % 32768
    t = np.arange(len(d)) * 0.05
    traj = integrate(t, left, right, p)
    path = write_trajectory_csv(traj, out / "square.csv")
    end = traj.final
    typer.echo(
        f"square of 1 m by odometry: closes at x={end.x:+.4f} m y={end.y:+.4f} m, "
        f"heading {end.heading:.4f} rad (2 pi = {2 * math.pi:.4f}); trajectory in {path}"
    )
