"""The slip fit's Kalman filter (issue 37: fits that know the ground truth is noisy):
odolab.calibration.slipfilter, its compiled pass, and the rule that chooses it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from odolab.calibration._slipfilter_jit import GATE, POSE, N, filter_pass
from odolab.calibration.lsq import LsqOptions, PreparedRun, calibrate_lsq
from odolab.calibration.slipfit import filtered, slip_design
from odolab.core.models.slip import SlipModel
from odolab.core.params import PRESETS
from odolab.metrics.truthnoise import TruthNoise, real_updates

NOMINAL = PRESETS["jaguar-lite"]
KEYS = SlipModel.COEF_KEYS


def _reference(
    ds: np.ndarray,
    dth: np.ndarray,
    phi: np.ndarray,
    var: np.ndarray,
    start: np.ndarray,
    meas: np.ndarray,
    truth: np.ndarray,
    r: np.ndarray,
    beta0: np.ndarray,
    p0: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, float, list[int]]:
    """The same filter written plainly: the whole 27 x 27 Jacobian, P <- F P F^T + G Q G^T."""
    s = np.concatenate((np.zeros(POSE), beta0))
    p = np.zeros((N, N))
    p[POSE:, POSE:] = p0
    ll = 0.0
    gated: list[int] = []
    for k in range(ds.size):
        if start[k]:
            s[:POSE] = truth[k]
            p[:POSE, :] = 0.0
            p[:, :POSE] = 0.0
            p[:POSE, :POSE] = np.diag(r)
            continue
        bf, bl, by = s[3:11], s[11:19], s[19:27]
        f, lat, rot = ds[k] + phi[k] @ bf, phi[k] @ bl, dth[k] + phi[k] @ by
        m = s[2] + 0.5 * rot
        rm = np.array([[math.cos(m), -math.sin(m)], [math.sin(m), math.cos(m)]])
        d = rm @ np.array([f, lat])
        jac = np.eye(N)
        jac[0, 2], jac[1, 2] = -d[1], d[0]
        jac[0:2, 3:11] = np.outer(rm[:, 0], phi[k])
        jac[0:2, 11:19] = np.outer(rm[:, 1], phi[k])
        jac[0:2, 19:27] = np.outer(np.array([-d[1], d[0]]), 0.5 * phi[k])
        jac[2, 19:27] = phi[k]
        s[0:2] += d
        s[2] += rot
        g = np.zeros((N, 3))
        g[0:2, 0:2] = rm
        g[2, 2] = 1.0
        p = jac @ p @ jac.T + g @ np.diag(var[k]) @ g.T
        if meas[k]:
            h = np.zeros((3, N))
            h[:, :3] = np.eye(3)
            sm = h @ p @ h.T + np.diag(r)
            inn = truth[k] - s[:3]
            quad = float(inn @ np.linalg.solve(sm, inn))
            rho = math.sqrt(GATE * quad) - 0.5 * GATE if quad > GATE else 0.5 * quad
            ll += -(rho + 0.5 * math.log(np.linalg.det(sm)) + 1.5 * math.log(2 * math.pi))
            if quad > GATE:  # a glitch: not taken
                gated.append(k)
                continue
            kg = p @ h.T @ np.linalg.inv(sm)
            s = s + kg @ inn
            p = p - kg @ h @ p
            p = 0.5 * (p + p.T)
    return s[POSE:], p[POSE:, POSE:], ll, gated


def test_the_compiled_pass_is_the_plain_filter() -> None:
    """Two runs of 60 cycles, updates every second cycle: the structured update (only the
    pose's rows of F) gives the whole filter's coefficients, covariance and likelihood."""
    rng = np.random.default_rng(5)
    n = 120
    ds = 0.03 + 0.01 * rng.standard_normal(n)
    dth = 0.05 * rng.standard_normal(n)
    phi = np.ascontiguousarray(0.05 * rng.standard_normal((n, 8)))
    var = np.ascontiguousarray(np.abs(1e-5 * rng.standard_normal((n, 3))) + 1e-7)
    start = np.zeros(n, dtype=bool)
    start[[0, 60]] = True
    meas = (np.arange(n) % 2 == 0) & ~start
    beta0 = 0.02 * rng.standard_normal(24)
    true = beta0 + 0.01 * rng.standard_normal(24)  # the robot's coefficients
    truth = np.empty((n, 3))
    for k in range(n):  # its path, each run from the origin, measured with 5 cm / 0.1 rad
        if start[k]:
            pose = np.zeros(3)
        else:
            f, lat = ds[k] + phi[k] @ true[:8], phi[k] @ true[8:16]
            rot = dth[k] + phi[k] @ true[16:]
            m = pose[2] + 0.5 * rot
            step = (math.cos(m) * f - math.sin(m) * lat, math.sin(m) * f + math.cos(m) * lat, rot)
            pose = pose + np.array(step)
        truth[k] = pose + rng.standard_normal(3) * (0.05, 0.05, 0.1)
    r = np.array([0.05**2, 0.05**2, 0.1**2])
    p0 = np.diag(np.full(24, 0.3**2))
    truth[70] += (0.8, -0.6, 0.5)  # a scan matcher's glitch: the gate leaves it out
    beta, cov, ll, count, glitches = filter_pass(
        ds, dth, phi, var, start, meas, truth, r, beta0.copy(), p0.copy()
    )
    b2, c2, l2, gated = _reference(ds, dth, phi, var, start, meas, truth, r, beta0, p0)
    assert gated == [70]
    assert (count, glitches) == (int(meas.sum()) - 1, 1)
    # equal to rounding (the sums run in another order); bounds far above it
    np.testing.assert_allclose(beta, b2, rtol=0, atol=1e-12)
    np.testing.assert_allclose(cov, c2, rtol=0, atol=1e-12)
    assert ll == pytest.approx(l2, rel=1e-10)


def test_real_updates_leave_out_held_and_resampled_rows() -> None:
    t = np.arange(0, 10.0, 0.1)
    x, y, h = np.sin(t), np.cos(0.7 * t), 0.3 * t**2
    held = np.repeat(np.arange(t.size), 2)  # each update repeated on the next row
    assert np.array_equal(real_updates(np.arange(held.size) * 0.05, x[held], y[held], h[held]),
                          np.arange(0, held.size, 2))  # fmt: skip
    fine = np.arange(0, t[-1] + 1e-9, 0.05)  # the truth resampled onto a 20 Hz clock
    keep = real_updates(fine, np.interp(fine, t, x), np.interp(fine, t, y), np.interp(fine, t, h))
    assert np.array_equal(keep, np.arange(0, fine.size, 2))


def _noisy_exploration(sigma_xy: float, sigma_h: float, seed: int) -> PreparedRun:
    """The independent icr-speed simulator's 60 s exploration (tests/models/independent_sims),
    its truth at 10 Hz with white noise, at the odometry's 20 Hz as a CSV writer resamples it."""
    from tests.models.independent_sims import IcrSpeedSim, exploration

    from odolab.calibration.lsq import prepare_run
    from odolab.core.trajectory import Trajectory
    from odolab.io.run import OdometryRun

    r = exploration(IcrSpeedSim(), seed)
    rng = np.random.default_rng(seed)
    keep = np.arange(0, r.t.size, 2)
    n = keep.size

    def noisy(v: np.ndarray, sigma: float) -> np.ndarray:
        return np.interp(r.t, r.t[keep], v[keep] + sigma * rng.standard_normal(n))

    gt = Trajectory.from_xyh(r.t, noisy(r.x, sigma_xy), noisy(r.y, sigma_xy),
                             noisy(r.heading, sigma_h))  # fmt: skip
    run = OdometryRun("explore", "explore", r.t, r.dticks_left, r.dticks_right, ground_truth=gt)
    return prepare_run(run, 2.0)


def test_the_filter_is_chosen_where_the_truth_is_noisier_than_the_model() -> None:
    run = _noisy_exploration(0.05, 0.1, 1)
    d = slip_design([run], NOMINAL, 0.5)
    c_xy, c_yaw = np.array([0.0, 1.3e-3]), np.array([0.0, 1.5e-3])  # icr-speed's, measured
    assert filtered(TruthNoise(0.05, 0.1, spacing=0.1), d, c_xy, c_yaw)
    # the DRIVE Husky's lidar against its model's noise (measured 0.22 and 0.008 of it)
    husky_xy, husky_yaw = np.array([0.0089, 0.0]), np.array([0.0, 0.0156])
    assert not filtered(TruthNoise(0.0138, 0.0038, spacing=0.1), d, husky_xy, husky_yaw)
    assert not filtered(None, d, c_xy, c_yaw)
    assert not filtered(TruthNoise(0.0, 0.0), d, c_xy, c_yaw)  # --truth-sigma 0,0: off
    # a perfect simulator (no model noise at all) whose truth reads its own bend, 0.1 mm: as good
    # as exact, the regression (the filter's likelihood cannot size a noise that is not there)
    nil = np.array([0.0, 1e-12])
    assert not filtered(TruthNoise(1.08e-4, 0.0, spacing=0.05), d, nil, nil)


@pytest.mark.slow
def test_filter_beats_the_regression_with_centimetre_truth_noise() -> None:
    """Issue 37's goal on its own simulator, two seeds (the benchmark runs five): fitted on the
    exploration with 5 cm / 0.1 rad of truth noise, the held-out runs' end points (against the
    true path) are nearer than with the regression, and than with the best kinematic model."""
    from tests.models.independent_sims import IcrSpeedSim, held_out_runs

    from odolab.calibration import slipfit
    from odolab.calibration.slipfit import endpoint_error

    held_runs = []
    for seed in (2, 3):
        from odolab.core.trajectory import Trajectory
        from odolab.io.run import OdometryRun

        runs = []
        for r in held_out_runs(IcrSpeedSim(), seed):
            gt = Trajectory.from_xyh(r.t, r.x, r.y, r.heading)
            runs.append(OdometryRun(r.name, r.name, r.t, r.dticks_left, r.dticks_right,
                                    ground_truth=gt))  # fmt: skip
        held_runs.append(runs)
    ends: dict[str, list[float]] = {"filter": [], "regression": [], "kinematic": []}
    notes = []
    for seed, held in zip((2, 3), held_runs, strict=True):
        fit_run = _noisy_exploration(0.05, 0.1, seed)
        fit = calibrate_lsq([fit_run], NOMINAL, LsqOptions(model="slip"))
        notes.append(fit.notes[-1])
        ends["filter"].append(float(np.mean([endpoint_error(r, fit.params) for r in held])))
        original = slipfit.filtered
        slipfit.filtered = lambda *a, **k: False  # type: ignore[assignment]
        try:
            reg = calibrate_lsq([fit_run], NOMINAL, LsqOptions(model="slip")).params
        finally:
            slipfit.filtered = original  # type: ignore[assignment]
        ends["regression"].append(float(np.mean([endpoint_error(r, reg) for r in held])))
        kin = [
            calibrate_lsq([fit_run], NOMINAL, LsqOptions(model=m)).params for m in ("diff", "icr")
        ]
        ends["kinematic"].append(
            min(float(np.mean([endpoint_error(r, p) for r in held])) for p in kin)
        )
    assert all("Kalman filter" in n and "left out as glitches" in n for n in notes), notes
    filt, reg, kin = (sum(ends[k]) for k in ("filter", "regression", "kinematic"))
    # measured (seeds 2, 3): filter 0.864 and 0.964 m, the regression 1.633 and 2.663 m, the
    # best kinematic model 2.426 and 1.444 m: filter / kinematic 0.47 pooled. Over the seed
    # pairs (1, 2) to (5, 6): 0.24 to 0.76 (per seed 0.18 to 0.90: never above 1); bound 1.0,
    # better than the kinematic models, 24 % above the largest pair
    assert filt <= 1.0 * kin, ends
    # measured filter / regression 0.43 pooled; over the seed pairs (1, 2) to (5, 6) 0.18 to
    # 0.56; bound 0.75, 25 % above the largest
    assert filt <= 0.75 * reg, ends


def test_steady_rule_is_the_plain_one_window_by_window() -> None:
    """`_steady` (vectorized over windows) and `steady_cycles` give what the rule says of each
    window taken alone: the smoothed speeds' range over the window and the settling seconds."""
    from scipy.ndimage import uniform_filter1d

    from odolab.calibration import slipfit

    rng = np.random.default_rng(11)
    t = np.cumsum(rng.uniform(0.03, 0.07, 400))
    v = np.repeat(rng.uniform(-1, 1, 20), 20) + 0.02 * rng.standard_normal(400)
    w = np.repeat(rng.uniform(-1, 1, 20), 20) + 0.05 * rng.standard_normal(400)
    i = np.sort(rng.integers(0, 390, 60))
    j = i + rng.integers(1, 10, 60)
    vs = uniform_filter1d(v, slipfit.SETTLE_CYCLES, mode="nearest")
    ws = uniform_filter1d(w, slipfit.SETTLE_CYCLES, mode="nearest")

    def plain(a: int, b: int) -> bool:
        seg = slice(int(np.searchsorted(t, t[a] - slipfit.SETTLE_S)), b + 1)
        return bool(np.ptp(vs[seg]) <= slipfit.STEADY_V and np.ptp(ws[seg]) <= slipfit.STEADY_W)

    got = slipfit._steady(t, v, w, i, j)
    assert got.tolist() == [plain(a, b) for a, b in zip(i, j, strict=True)]
    assert 0 < got.sum() < got.size  # both kinds of window are in the example
    cycles = slipfit.steady_cycles(t, v, w)
    assert cycles.tolist() == [plain(max(k - 1, 0), k) for k in range(t.size)]


def test_the_pass_refuses_a_prior_of_another_size() -> None:
    """The prior's 24 coefficients and 24 x 24 covariance are copied element by element (numba
    compiles a slice assignment slowly), so their sizes are checked, not trusted."""
    n = 4
    args = (np.zeros(n), np.zeros(n), np.zeros((n, 8)), np.ones((n, 3)), np.zeros(n, dtype=bool))
    rest = (np.zeros(n, dtype=bool), np.zeros((n, 3)), np.ones(3))
    for beta0, p0 in ((np.zeros(23), np.eye(24)), (np.zeros(24), np.eye(25))):
        with pytest.raises(ValueError, match="24 slip coefficients"):
            filter_pass(*args, *rest, beta0, p0)
