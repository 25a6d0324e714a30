"""Wheel noise constants by maximum likelihood: the likelihood against scipy, recovery."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from odolab.analysis import fit_wheel_noise
from odolab.analysis.noise import _loglik, record_pivot, record_rotation, record_translation

B = 0.56


def _translations(seed: int, k_r: float, k_l: float, n: int = 40) -> list:
    rng = np.random.default_rng(seed)
    recs = []
    for i in range(n):
        d = [1.1, 2.5, -1.1, -2.5][i % 4]
        proto = record_translation(d, B, residual_x=0.0, residual_y=0.0)
        cov = k_r * proto.a_right + k_l * proto.a_left
        rx, ry = rng.multivariate_normal([0, 0], cov)
        recs.append(record_translation(d, B, residual_x=rx, residual_y=ry))
    return recs


def test_loglik_equals_scipy_multivariate_normal() -> None:
    recs = [
        *_translations(0, 0.0002, 0.0001, n=8),
        record_rotation(0.3, 20.0, B, sigma=0.05),
        record_pivot(-0.2, 6.0, B, "right"),
    ]
    k_r, k_l = 3e-4, 1.5e-4
    ref = 0.0
    for rec in recs:
        cov = k_r * rec.a_right + k_l * rec.a_left + rec.m
        ref += stats.multivariate_normal(np.zeros(rec.r.size), cov).logpdf(rec.r)
    assert _loglik(k_r, k_l, recs) == pytest.approx(ref, rel=1e-10)


def test_translation_covariance_is_the_random_walk_model() -> None:
    rec = record_translation(2.0, B, residual_x=0.0, residual_y=0.0)
    # var x = d/4, var y = d^3/(3 b^2), cov = d^2/(4 b) for the right wheel, forward
    assert rec.a_right[0, 0] == pytest.approx(0.5)
    assert rec.a_right[1, 1] == pytest.approx(8 / (3 * B**2))
    assert rec.a_right[0, 1] == pytest.approx(4 / (4 * B))
    assert rec.a_left[0, 1] == pytest.approx(-4 / (4 * B))
    rev = record_translation(-2.0, B, residual_x=0.0, residual_y=0.0)
    assert rev.a_right[0, 1] == pytest.approx(-4 / (4 * B))


def test_recovers_per_wheel_constants_from_translations() -> None:
    k_r, k_l = 4e-4, 1e-4
    res = fit_wheel_noise(_translations(11, k_r, k_l, n=400))
    assert res.identifiable
    assert res.k_right_ci95[0] <= k_r <= res.k_right_ci95[1]
    assert res.k_left_ci95[0] <= k_l <= res.k_left_ci95[1]
    assert res.k_right == pytest.approx(k_r, rel=0.3)
    assert res.k_left == pytest.approx(k_l, rel=0.5)


def test_intervals_cover_truth_in_most_seeds() -> None:
    k_r, k_l, hits, n_seeds = 3e-4, 2e-4, 0, 40
    for seed in range(n_seeds):
        res = fit_wheel_noise(_translations(100 + seed, k_r, k_l, n=60))
        hits += res.k_right_ci95[0] <= k_r <= res.k_right_ci95[1]
    assert hits / n_seeds >= 0.85


def test_rotations_alone_give_only_the_sum() -> None:
    rng = np.random.default_rng(4)
    k = 0.1
    recs = []
    for h in np.repeat([10.0, 30.0, 60.0], 10):
        recs.append(record_rotation(rng.normal(0, np.sqrt(k * h / (2 * B))), h, B))
    res = fit_wheel_noise(recs)
    assert not res.identifiable
    assert res.k_right == res.k_left == pytest.approx(res.k_sum / 2)
    assert res.k_sum_ci95[0] <= k <= res.k_sum_ci95[1]
