"""Monte Carlo of the documented noise model on a given wheel path, for the first-order limit."""

from __future__ import annotations

import math

import numpy as np

from odolab.core.odometry import integrate_increments
from odolab.core.params import PRESETS, NoiseParams
from odolab.core.uncertainty import covariance_matrix, propagate_covariance, second_order_index

P = PRESETS["jaguar-lite"]
B = P.track_width
PER_M = P.ticks_per_rev / (2 * math.pi * P.left_wheel_radius)


def along_ratio(
    dl_m: np.ndarray, dr_m: np.ndarray, k: float, k_scrub: float, runs: int = 4000, seed: int = 0
) -> tuple[float, float, float]:
    """(second-order index at the end, heading variance at the end, Monte Carlo variance of the
    error along the final heading over the first-order one) for wheel steps ``dl_m, dr_m`` (m)."""
    rng = np.random.default_rng(seed)
    p = P.with_(noise=NoiseParams(k, k, k_scrub))
    n = dl_m.size
    dl, dr = np.r_[0.0, dl_m] * PER_M, np.r_[0.0, dr_m] * PER_M
    covs = propagate_covariance(dl, dr, p)
    odo = integrate_increments(np.arange(n + 1) * 0.05, dl, dr, p)
    cov = covariance_matrix(covs[-1])
    el = rng.normal(0, 1, (runs, n)) * np.sqrt(k * np.abs(dl_m))
    er = rng.normal(0, 1, (runs, n)) * np.sqrt(k * np.abs(dr_m))
    scrub = rng.normal(0, 1, (runs, n)) * np.sqrt(k_scrub * np.abs(dr_m - dl_m) / B)
    tl, tr = dl_m - el, dr_m - er
    dh = (tr - tl) / B + scrub
    h = np.cumsum(dh, axis=1)
    mid = h - dh / 2
    s = (tr + tl) / 2
    x, y = np.sum(s * np.cos(mid), axis=1), np.sum(s * np.sin(mid), axis=1)
    u = np.array([math.cos(odo.heading[-1]), math.sin(odo.heading[-1])])
    along = (odo.x[-1] - x) * u[0] + (odo.y[-1] - y) * u[1]
    first = float(u @ cov[:2, :2] @ u)
    rho = float(second_order_index(odo, covs)[-1])
    return rho, float(cov[2, 2]), float(np.mean(along**2)) / first


def straight(d: float, steps: int = 200) -> tuple[np.ndarray, np.ndarray]:
    return np.full(steps, d / steps), np.full(steps, d / steps)


def turn_then_straight(d: float) -> tuple[np.ndarray, np.ndarray]:
    turn = np.full(100, math.pi * B / 100)  # a full turn in place, then d m straight
    leg = np.full(150, d / 150)
    return np.r_[-turn, leg], np.r_[turn, leg]


def arc(k_steps: int = 300) -> tuple[np.ndarray, np.ndarray]:
    return np.full(k_steps, 0.015), np.full(k_steps, 0.025)
