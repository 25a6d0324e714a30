"""Runs made exactly by the documented noise model (docs/ros2.md), for NEES tests.

The measured wheel distance of each cycle is the true one plus a draw of variance
``k |ds|``; the true heading change carries scrub of variance ``k_scrub |ds_r - ds_l| / b``.
The ground truth integrates the true motion with the same pose step (midpoint) that the
odometry uses on the measured ticks, from the same start, in the same frame."""

from __future__ import annotations

import math

import numpy as np

from odolab.core.params import PRESETS, NoiseParams
from odolab.core.trajectory import Trajectory
from odolab.io.run import OdometryRun

NOMINAL = PRESETS["jaguar-lite"]
MODEL_NOISE = NoiseParams(k_left=2e-4, k_right=1e-4, k_scrub=0.004)
RATE = 20.0  #: Hz
PIECE_S = 2.0  #: seconds a piece


def model_run(seed: int, pieces: int = 20, *, turning: bool = True) -> OdometryRun:
    """``pieces`` pieces of :data:`PIECE_S` s of smooth, mostly forward driving with turns
    (straight driving only when not ``turning``)."""
    rng = np.random.default_rng(seed)
    n = round(pieces * PIECE_S * RATE) + 1
    t = np.arange(n) / RATE
    phase = rng.uniform(0, 2 * math.pi, 2)
    v = 0.4 + 0.2 * np.sin(0.7 * t + phase[0])  # m/s
    w = 0.6 * np.sin(0.45 * t + phase[1]) * turning  # rad/s
    b = NOMINAL.track_width
    dt = 1.0 / RATE
    ds_l = (v - w * b / 2) * dt
    ds_r = (v + w * b / 2) * dt
    ds_l[0] = ds_r[0] = 0.0
    k = MODEL_NOISE
    meas_l = ds_l + rng.normal(0, 1, n) * np.sqrt(k.k_left * np.abs(ds_l))
    meas_r = ds_r + rng.normal(0, 1, n) * np.sqrt(k.k_right * np.abs(ds_r))
    scrub = rng.normal(0, 1, n) * np.sqrt(k.k_scrub * np.abs(ds_r - ds_l) / b)
    # the truth: midpoint steps of the true wheel motion, heading with scrub
    dh = (ds_r - ds_l) / b + scrub
    ds = (ds_r + ds_l) / 2
    heading = np.cumsum(dh)
    mid = heading - dh / 2
    x = np.cumsum(ds * np.cos(mid))
    y = np.cumsum(ds * np.sin(mid))
    gt = Trajectory.from_xyh(t, x, y, heading)
    per_m = NOMINAL.ticks_per_rev / (2 * math.pi * NOMINAL.left_wheel_radius)
    return OdometryRun(
        f"model-{seed}", "documented noise model", t, meas_l * per_m, meas_r * per_m,
        ground_truth=gt,
    )  # fmt: skip
