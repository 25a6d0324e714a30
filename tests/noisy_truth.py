"""Ground truth with white noise added, for the tests of fits that allow for a noisy truth
(issue 37): at every stamp (:func:`white`), or on every second row, resampled to the odometry's
rate as a CSV writer does (:func:`at_half_rate`). Draws x, then y, then heading."""

from __future__ import annotations

from dataclasses import replace
from typing import TypeVar

import numpy as np

from odolab.core.trajectory import Trajectory

R = TypeVar("R")


def white(
    traj: Trajectory, sigma_xy: float, sigma_h: float, rng: np.random.Generator
) -> Trajectory:
    """``traj`` with independent white noise on every stamp's x, y (m) and heading (rad)."""
    n = traj.t.size
    return Trajectory.from_xyh(
        traj.t,
        traj.x + sigma_xy * rng.standard_normal(n),
        traj.y + sigma_xy * rng.standard_normal(n),
        traj.heading + sigma_h * rng.standard_normal(n),
    )


def at_half_rate(run: R, sigma_xy: float, sigma_h: float, rng: np.random.Generator) -> R:
    """A simulated run (fields ``t``, ``x``, ``y``, ``heading``: tests/models/independent_sims'
    SimRun) whose truth is measured on every second row with white noise and resampled onto
    every row (a 10 Hz truth on a 20 Hz log)."""
    t = run.t  # type: ignore[attr-defined]
    keep = np.arange(0, t.size, 2)

    def add(v: np.ndarray, sigma: float) -> np.ndarray:
        return np.interp(t, t[keep], v[keep] + sigma * rng.standard_normal(keep.size))

    return replace(  # type: ignore[type-var]
        run,
        x=add(run.x, sigma_xy),  # type: ignore[attr-defined]
        y=add(run.y, sigma_xy),  # type: ignore[attr-defined]
        heading=add(run.heading, sigma_h),  # type: ignore[attr-defined]
    )
