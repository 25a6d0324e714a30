"""Planar test trajectories (helpers shared by the metrics tests)."""

from __future__ import annotations

import numpy as np

from odolab.core.trajectory import Trajectory


def random_drive(n: int, seed: int, *, t0: float = 0.0, dt: float = 0.05) -> Trajectory:
    """A random planar drive with stops, turns in place and reversing (shape (n,))."""
    rng = np.random.default_rng(seed)
    v = rng.normal(0.3, 0.25, n)
    v[rng.random(n) < 0.1] = 0.0  # stops: repeated positions
    w = rng.normal(0.0, 0.8, n)
    h = np.cumsum(w * dt)
    x = np.cumsum(v * dt * np.cos(h))
    y = np.cumsum(v * dt * np.sin(h))
    t = t0 + dt * np.arange(n)
    return Trajectory.from_xyh(t, x, y, h)


def noisy_copy(traj: Trajectory, seed: int, drift: float = 0.02) -> Trajectory:
    """The same drive with heading drift and a scale error (an odometry-like estimate)."""
    rng = np.random.default_rng(seed)
    n = len(traj)
    dh = np.diff(traj.heading, prepend=traj.heading[0]) * (1.0 + drift) + rng.normal(0, 1e-3, n)
    h = traj.heading[0] + np.cumsum(dh) - dh[0]
    dx = np.diff(traj.x, prepend=traj.x[0])
    dy = np.diff(traj.y, prepend=traj.y[0])
    ds = np.hypot(dx, dy) * (1.0 + drift)
    x = traj.x[0] + np.cumsum(ds * np.cos(h))
    y = traj.y[0] + np.cumsum(ds * np.sin(h))
    return Trajectory.from_xyh(traj.t, x, y, h)
