"""Propagated pose covariance: against an independent implementation, closed forms, Monte Carlo."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from tests.core.test_models import SideSlip

from odolab.errors import OdolabError, ParamsError
from odolab.odometry import Odometry, integrate_increments
from odolab.params import PRESETS, NoiseParams, load_params, save_params
from odolab.uncertainty import (
    covariance_from_ticks,
    covariance_matrix,
    pose_covariance,
    propagate_covariance,
    straight_line_covariance,
)

NOMINAL = PRESETS["jaguar-lite"]
NOISE = NoiseParams(k_left=2e-4, k_right=5e-4)


def _path(seed: int, n: int = 200) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    dl = rng.normal(25.0, 20.0, n)
    dr = rng.normal(25.0, 20.0, n)
    dl[0] = dr[0] = 0.0
    return dl, dr


def test_midpoint_diff_drive_equals_the_independent_numpy_version() -> None:
    dl, dr = _path(1)
    kl, kr = NOMINAL.left_metres_per_tick, NOMINAL.right_metres_per_tick
    ref = pose_covariance(dl[1:] * kl, dr[1:] * kr, NOMINAL.track_width, 2e-4, 5e-4, heading0=0.3)
    got = covariance_matrix(propagate_covariance(dl, dr, NOMINAL, noise=NOISE, heading0=0.3))
    np.testing.assert_allclose(got, ref, rtol=1e-10, atol=1e-18)


def test_straight_run_matches_the_closed_form() -> None:
    n = 4000
    per_step = 2.0 / n / NOMINAL.left_metres_per_tick  # 2 m in n steps
    d = np.full(n + 1, per_step)
    cov = covariance_matrix(propagate_covariance(d, d, NOMINAL, "arc", noise=NOISE)[-1])
    ref = straight_line_covariance(2.0, NOMINAL.track_width, 2e-4, 5e-4)
    np.testing.assert_allclose(cov, ref, rtol=2e-3)


@pytest.mark.parametrize("method", ["midpoint", "arc"])
@pytest.mark.parametrize("model", [None, SideSlip(0.12)])
def test_streaming_equals_batch(method: str, model: SideSlip | None) -> None:
    params = NOMINAL.with_(noise=NoiseParams(1e-4, 3e-4, k_scrub=0.02))
    if model is not None:
        params = params.with_(model=model)
    rng = np.random.default_rng(5)
    left = np.cumsum(rng.integers(-40, 60, 300)) % 32768
    right = np.cumsum(rng.integers(-40, 60, 300)) % 32768
    batch = covariance_from_ticks(left, right, params, method, heading0=0.4)
    odo = Odometry(params, method, covariance=True, start=(0.0, 0.0, 0.4))
    for i in range(left.size):
        odo.update(0.05 * i, int(left[i]), int(right[i]))
        np.testing.assert_allclose(odo.covariance, batch[i], rtol=1e-9, atol=1e-15)


def test_monte_carlo_agrees_within_ten_percent() -> None:
    # 2,000 runs of a mixed path (straight, turn in place, curve) with wheel slip and scrub
    params = NOMINAL.with_(noise=NoiseParams(6e-5, 2e-5, k_scrub=0.002))
    seg = [(40.0, 40.0, 60), (-30.0, 30.0, 40), (50.0, 20.0, 80)]
    dl = np.concatenate([[0.0]] + [np.full(k, a) for a, _, k in seg])
    dr = np.concatenate([[0.0]] + [np.full(k, b) for _, b, k in seg])
    cov = covariance_matrix(propagate_covariance(dl, dr, params, "arc")[-1])
    rng = np.random.default_rng(2024)
    runs = 2000
    kl, kr, b = params.left_metres_per_tick, params.right_metres_per_tick, params.track_width
    x = np.zeros(runs)
    y = np.zeros(runs)
    h = np.zeros(runs)
    for i in range(1, dl.size):
        sl = dl[i] * kl
        sr = dr[i] * kr
        nl = sl + np.sqrt(6e-5 * abs(sl)) * rng.standard_normal(runs)
        nr = sr + np.sqrt(2e-5 * abs(sr)) * rng.standard_normal(runs)
        dth = (nr - nl) / b + np.sqrt(0.002 * abs(sr - sl) / b) * rng.standard_normal(runs)
        u = 0.5 * dth
        c = np.where(np.abs(u) < 1e-8, 1.0, np.sin(u) / np.where(u == 0, 1.0, u))
        ds = 0.5 * (nl + nr) * c
        x += ds * np.cos(h + u)
        y += ds * np.sin(h + u)
        h += dth
    sample = np.cov(np.stack([x, y, h]))
    np.testing.assert_allclose(np.diag(sample), np.diag(cov), rtol=0.10)
    # 95 % ellipses (of x, y) hold 95 +- 2 % of the runs
    nominal = integrate_increments(np.arange(dl.size), dl, dr, params, "arc")
    end = np.array([nominal.x[-1], nominal.y[-1]])
    d = np.stack([x, y], axis=1) - end
    m2 = np.einsum("ij,jk,ik->i", d, np.linalg.inv(cov[:2, :2]), d)
    inside = float(np.mean(m2 <= -2.0 * math.log(0.05)))
    assert 0.93 <= inside <= 0.97


def test_noise_table_round_trip_and_errors(tmp_path: Path) -> None:
    params = NOMINAL.with_(noise=NoiseParams(1e-4, 2e-4, k_scrub=0.05))
    path = save_params(tmp_path / "p.toml", params)
    assert "[noise]" in path.read_text()
    assert load_params(path) == params
    path.write_text(path.read_text().replace("k_right", "k_rigth"))
    with pytest.raises(ParamsError, match=r"unknown key 'k_rigth' in \[noise\]"):
        load_params(path)
    with pytest.raises(ParamsError, match=r"\[noise\] k_left must be a number from 0 to 1"):
        NoiseParams(-1.0, 0.0)
    with pytest.raises(ParamsError, match=r"no \[noise\] table"):
        propagate_covariance([0.0, 1.0], [0.0, 1.0], NOMINAL)
    with pytest.raises(OdolabError, match="without covariance=True"):
        _ = Odometry(NOMINAL).covariance
