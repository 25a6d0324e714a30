"""The ground truth's own noise (issue 37): estimated from its updates, and carried by the slip
fit's row covariance (odolab.metrics.truthnoise, slipfit.truth_covariances)."""

from __future__ import annotations

import numpy as np
import pytest

from odolab.calibration.lsq import PreparedRun
from odolab.calibration.slipfit import slip_design, truth_covariances
from odolab.core.errors import CalibrationError
from odolab.core.params import PRESETS
from odolab.metrics.truthnoise import (
    TruthNoise,
    estimate_truth_noise,
    parse_truth_sigma,
    truth_residuals,
)


def _path(n: int) -> tuple[np.ndarray, ...]:
    """A smooth curve at 10 Hz: 0.5 m/s, turning at 0.4 rad/s with a slow wobble."""
    t = np.arange(n) * 0.1
    h = 0.4 * t + 0.3 * np.sin(0.5 * t)
    dt = np.diff(t, prepend=0.0)
    x = np.cumsum(0.5 * np.cos(h) * dt)
    y = np.cumsum(0.5 * np.sin(h) * dt)
    return t, x, y, h


def test_estimate_recovers_the_noise_and_skips_resampled_and_held_rows() -> None:
    rng = np.random.default_rng(3)
    t, x, y, h = _path(600)
    nx, ny, nh = x + 0.03 * rng.standard_normal(600), y + 0.03 * rng.standard_normal(600), h
    nh = h + 0.05 * rng.standard_normal(600)
    est = estimate_truth_noise([truth_residuals(t, nx, ny, nh)])
    assert est is not None
    # measured: 0.0310 m and 0.0497 rad (seed 3)
    assert est.xy == pytest.approx(0.03, rel=0.1)
    assert est.yaw == pytest.approx(0.05, rel=0.1)
    assert est.spacing == pytest.approx(0.1)
    # the same truth resampled at 40 Hz (three rows of four on their neighbours' line) and
    # rounded to 9 digits, as a CSV keeps it: the resampled rows are not measurements
    fine = np.arange(0, t[-1] + 1e-9, 0.025)
    parts = [float(f"{v:.9g}") for v in np.interp(fine, t, nx)]
    rs = truth_residuals(fine, np.array(parts), np.interp(fine, t, ny), np.interp(fine, t, nh))
    again = estimate_truth_noise([rs])
    assert again is not None
    assert again.xy == pytest.approx(est.xy, rel=0.02)  # measured: equal to 5e-9 (rounding)
    assert again.updates == est.updates
    # held values (each update repeated on the next row) are the same measurement
    held = np.repeat(np.arange(600), 2)
    twice = estimate_truth_noise(
        [truth_residuals(np.arange(1200) * 0.05, nx[held], ny[held], nh[held])]
    )
    assert twice is not None and twice.updates == est.updates
    # a noise-free truth: only the curve's own bend, measured 0.75 mm and 0.3 mrad
    clean = estimate_truth_noise([truth_residuals(t, x, y, h)])
    assert clean is not None and clean.xy < 1e-3 and clean.yaw < 1e-3


def test_too_few_updates_give_no_estimate() -> None:
    t, x, y, h = _path(8)
    assert estimate_truth_noise([truth_residuals(t, x, y, h)]) is None
    assert estimate_truth_noise([]) is None


@pytest.mark.parametrize("text", ["0.05", "a,b", "0.05,-1", "nan,0.1", "0.1,0.1,0.1"])
def test_truth_sigma_bad_input_is_one_sentence(text: str) -> None:
    with pytest.raises(CalibrationError, match=r"the ground truth's noise is .*; expected two"):
        parse_truth_sigma(text)


def test_given_truth_sigma() -> None:
    n = parse_truth_sigma("0.05,0.1")
    assert (n.xy, n.yaw, n.given) == (0.05, 0.1, True)
    assert "as given" in n.describe()


def _run(start: float) -> PreparedRun:
    """12 s of driving at 20 Hz (speed and turn rate changing), counts of jaguar-lite."""
    p = PRESETS["jaguar-lite"]
    t = np.arange(240) * 0.05 + start
    v = 0.6 + 0.3 * np.sin(0.7 * t)
    w = 0.8 * np.sin(0.4 * t + 1.0)
    b = p.track_width
    left = np.cumsum(np.concatenate(([0.0], (v - 0.5 * b * w)[1:] * 0.05)))
    right = np.cumsum(np.concatenate(([0.0], (v + 0.5 * b * w)[1:] * 0.05)))
    dl = np.diff(np.round(left / p.left_metres_per_tick), prepend=0.0)
    dr = np.diff(np.round(right / p.right_metres_per_tick), prepend=0.0)
    h = np.cumsum(np.concatenate(([0.0], 0.9 * w[1:] * 0.05)))
    x = np.cumsum(np.concatenate(([0.0], v[1:] * np.cos(h[1:]) * 0.05)))
    y = np.cumsum(np.concatenate(([0.0], v[1:] * np.sin(h[1:]) * 0.05)))
    idx = np.arange(239)
    return PreparedRun("r", t, dl, dr, x, y, h, idx, idx + 1)


def test_truth_covariances_match_the_rows_spread_under_truth_noise() -> None:
    """Perturb only the truth, many times: the rows' covariance is the one the fit assumes
    (each window has its two ends' noise, neighbours share one end with opposite sign)."""
    p = PRESETS["jaguar-lite"]
    base = _run(0.0)
    d0 = slip_design([base], p)
    noise = TruthNoise(0.02, 0.04, spacing=0.05)
    k_xy, k_yaw = truth_covariances(d0, noise)
    rng = np.random.default_rng(11)
    rows_xy, rows_yaw = [], []
    for _ in range(300):
        n = base.t.size
        r = PreparedRun(
            "r", base.t, base.dticks_left, base.dticks_right,
            base.gt_x + 0.02 * rng.standard_normal(n), base.gt_y + 0.02 * rng.standard_normal(n),
            base.gt_heading + 0.04 * rng.standard_normal(n), base.starts, base.ends,
        )  # fmt: skip
        d = slip_design([r], p)
        rows_xy.append(d.y_xy)
        rows_yaw.append(d.y_yaw)
    c_xy = np.cov(np.array(rows_xy).T)
    c_yaw = np.cov(np.array(rows_yaw).T)
    ky, kx = k_yaw.toarray(), k_xy.toarray()  # type: ignore[attr-defined]
    m = d0.y_yaw.size
    assert m >= 20 and np.all(d0.previous[1:] == np.arange(m - 1))
    # heading rows: 2 sigma^2 on the diagonal, -sigma^2 beside it; measured 1.02x and 1.01x the
    # assumed, two apart 0.18 sigma^2 (none assumed)
    assert np.mean(np.diag(c_yaw)) == pytest.approx(np.mean(np.diag(ky)), rel=0.15)
    assert np.mean(np.diag(c_yaw, 1)) == pytest.approx(np.mean(np.diag(ky, 1)), rel=0.2)
    assert np.max(np.abs(np.diag(c_yaw, 2))) < 0.45 * 0.04**2
    # position rows: the diagonal and the neighbours' shared end, x and y together; measured
    # 0.98x and 0.98x the assumed (the truth's heading noise across each window's motion in)
    assert np.mean(np.diag(c_xy)) == pytest.approx(np.mean(np.diag(kx)), rel=0.15)
    nb = [(d0.row_x[w - 1], d0.row_x[w]) for w in range(1, m)]
    emp = np.mean([c_xy[a, b] for a, b in nb])
    # measured: 0.98x the assumed, -0.94 sigma^2
    assert emp == pytest.approx(np.mean([kx[a, b] for a, b in nb]), rel=0.25)
    assert emp < -0.5 * 0.02**2  # measured -0.94 sigma^2
