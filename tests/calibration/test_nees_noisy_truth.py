"""NEES against a noisy ground truth (issue 37: a covariance whose growth with the horizon is
right): the truth's variance at each stamp (odolab.metrics.truthnoise.variance_factors), what its
noise adds to a piece's error (piece_covariance), that term known in the slip fit's noise terms
and added in `evaluate --nees`."""

from __future__ import annotations

import numpy as np
import pytest

from noisy_truth import at_half_rate
from odolab.metrics.truthnoise import TruthNoise, material, piece_covariance, variance_factors


def test_variance_factors_follow_the_truths_own_updates() -> None:
    # real updates every 0.1 s on a curve; rows between them resampled (their line) or held
    tu = 0.1 * np.arange(6)
    xu, yu, hu = np.sin(tu), tu**2, 0.3 * tu + np.array([0, 0.01, -0.01, 0.02, 0, 0.01])
    mid = 0.5 * (tu[:-1] + tu[1:])
    t = np.sort(np.concatenate((tu, mid)))
    x, y, h = (np.interp(t, tu, v) for v in (xu, yu, hu))
    # at the real updates 1, halfway 0.5, a quarter of the way 0.625 ((3/4)^2 + (1/4)^2)
    q = np.array([0.0, 0.05, 0.025, 0.1, 0.175, 0.5])
    assert np.allclose(variance_factors(t, x, y, h, q), [1.0, 0.5, 0.625, 1.0, 0.625, 1.0])
    # the same updates held between (a staircase): every stamp is one update, 1
    x2, y2, h2 = (v[np.searchsorted(tu, t, side="right") - 1] for v in (xu, yu, hu))
    held = variance_factors(t, x2, y2, h2, t)
    assert np.allclose(held, 1.0)
    # (halfway between a real update and its held copy: still that one update)
    assert np.allclose(variance_factors(t, x2, y2, h2, np.array([0.025, 0.125])), 1.0)


def test_piece_covariance_is_what_the_truths_noise_does_to_a_piece() -> None:
    """Monte Carlo: a piece started at a noisy truth pose and ended against a noisy one."""
    rng = np.random.default_rng(5)
    noise = TruthNoise(0.03, 0.05)
    d = np.array([0.8, 0.3])  # the odometry's displacement over the piece
    n = 200_000
    start_xy = noise.xy * rng.standard_normal((n, 2))
    start_h = noise.yaw * rng.standard_normal(n)
    end_xy = noise.xy * rng.standard_normal((n, 2))
    end_h = noise.yaw * rng.standard_normal(n)
    # the odometry from the noisy start: turned by the start's heading error
    c, s = np.cos(start_h), np.sin(start_h)
    odo = start_xy + np.column_stack((c * d[0] - s * d[1], s * d[0] + c * d[1]))
    e = np.column_stack((d + end_xy - odo, end_h - start_h))  # truth - odometry
    got = np.cov(e.T)
    want = piece_covariance(noise, np.array([1.0]), np.array([1.0]), d[None, :])[0]
    # measured (seed 5): every entry within 0.30 % of the largest; seeds 1-7 0.16-0.51 %; bound 3 %
    assert np.max(np.abs(got - want)) < 0.03 * np.max(np.abs(want))
    # halfway rows weigh half
    half = piece_covariance(noise, np.array([0.5]), np.array([0.5]), d[None, :])[0]
    assert np.allclose(half, 0.5 * want)
    # a start on a real update and an end halfway between two: the start's heading alone turns
    # the piece, so the two ends are not interchangeable
    e2 = np.column_stack((d + np.sqrt(0.5) * end_xy - odo, np.sqrt(0.5) * end_h - start_h))
    got2 = np.cov(e2.T)
    want2 = piece_covariance(noise, np.array([1.0]), np.array([0.5]), d[None, :])[0]
    swapped = piece_covariance(noise, np.array([0.5]), np.array([1.0]), d[None, :])[0]
    # measured (seed 5): within 0.19 % of the largest entry; swapped ends 27 % off; bounds 3 %,
    # 10 %
    assert np.max(np.abs(got2 - want2)) < 0.03 * np.max(np.abs(want2))
    assert np.max(np.abs(got2 - swapped)) > 0.1 * np.max(np.abs(want2))


def test_material_is_the_one_rule() -> None:
    assert not material(None)
    assert not material(TruthNoise(0.0, 0.0, given=True))  # --truth-sigma 0,0
    assert not material(TruthNoise(1.08e-4, 7e-4))  # a perfect simulator's own bend
    assert material(TruthNoise(0.0133, 0.00363))  # the DRIVE Husky's lidar
    assert material(TruthNoise(0.0, 0.002))


def _fit_and_nees(seed: int) -> dict[float, np.ndarray]:
    """icr-speed's exploration and held-out runs, their truth at 10 Hz with 5 cm / 0.1 rad of
    white noise (resampled to 20 Hz), the slip model fitted on the exploration: NEES of the
    held-out runs' 1 s and 3 s pieces as `evaluate --nees` gives them."""
    import tempfile
    from pathlib import Path

    from tests.models.independent_sims import IcrSpeedSim, exploration, held_out_runs, write_run

    from odolab.calibration.lsq import LsqOptions, calibrate_lsq
    from odolab.calibration.slipfit import nees_pieces
    from odolab.core.params import PRESETS
    from odolab.io.registry import read_run

    rng = np.random.default_rng(104729 * seed)
    runs = [exploration(IcrSpeedSim(), seed), *held_out_runs(IcrSpeedSim(), seed)]
    noisy = [at_half_rate(r, 0.05, 0.1, rng) for r in runs]
    with tempfile.TemporaryDirectory() as d:
        read = [read_run(write_run(Path(d), r), "csv") for r in noisy]
        fit = calibrate_lsq(read[:1], PRESETS["jaguar-lite"], LsqOptions(model="slip"))
        return {s: nees_pieces(read[1:], fit.params, s) for s in (1.0, 3.0)}


@pytest.mark.slow
def test_nees_shape_with_centimetre_truth_noise() -> None:
    """Issue 37's goal: with 5 cm / 0.1 rad of truth noise the slip model's NEES is near 3 at
    both 1 s and 3 s. Before the truth's noise was a known term (fitted into the model's own
    terms, which grow with the horizon), it was 3.96 at 1 s (overconfident) and 1.58 at 3 s
    (too cautious), pooled over five seeds."""
    got = [_fit_and_nees(seed) for seed in (1, 2)]
    one = float(np.mean(np.concatenate([g[1.0] for g in got])))
    three = float(np.mean(np.concatenate([g[3.0] for g in got])))
    # measured (seeds 1, 2): 1 s 2.77, 3 s 2.84; per seed over 1-6: 1 s 2.50-3.16, 3 s
    # 1.70-3.18; pairs (1, 2) to (5, 6): 1 s 2.60-2.93, 3 s 2.29-2.84. Before: 3.96 and 1.58
    # (the benchmark's five seeds). Bounds: 1 s below 3.5, 3 s above 2.0 (13 % from the pairs);
    # the other sides 2.0 and 4.0, far from both
    assert 2.0 < one < 3.5, (one, three)
    # measured 3 s 2.84 (seeds 1, 2; pairs 2.29-2.84, before 1.58); bounds 2.0 and 4.0
    assert 2.0 < three < 4.0, (one, three)
