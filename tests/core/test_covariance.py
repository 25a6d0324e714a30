"""Propagated pose covariance: against an independent implementation, closed forms, Monte Carlo."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from tests.core.test_models import SideSlip

from odolab.core.errors import LogFormatError, OdolabError, ParamsError
from odolab.core.odometry import (
    Odometry,
    integrate,
    integrate_increments,
    integrate_with_covariance,
)
from odolab.core.params import PRESETS, NoiseParams, load_params, save_params
from odolab.core.uncertainty import (
    covariance_along,
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


def _pose_after(pose: np.ndarray, params, dsl: float, dsr: float, scrub: float, arc: bool):  # type: ignore[no-untyped-def]
    """The pose after one cycle through the library's own body_motion and step_pose; ``scrub``
    is added to the heading change (and, through the model, to the sideways motion)."""
    from odolab.core.kinematics import body_motion, step_pose

    c = params.coefficients
    fwd, _, dth = body_motion(*c, dsl, dsr)
    dth += scrub
    return np.array(step_pose(*pose, fwd, c.lateral * dth, dth, arc))


@pytest.mark.parametrize("method", ["midpoint", "arc"])
@pytest.mark.parametrize(
    "ticks", [(300.0, 900.0), (-500.0, 700.0), (400.0, 400.001), (20.0, -600.0), (-350.0, -80.0)]
)
def test_jacobians_equal_finite_differences_of_the_pose_step(
    method: str, ticks: tuple[float, float]
) -> None:
    # P' = F P F^T + G Q G^T, with F and G from central differences of step_pose(body_motion(...))
    # of a model with a sideways term (the ICR 0.12 m ahead of the axle)
    params = NOMINAL.with_(model=SideSlip(0.12))
    arc = method == "arc"
    pose = np.array([0.3, -0.2, 0.7])
    dsl, dsr = ticks[0] * params.left_metres_per_tick, ticks[1] * params.right_metres_per_tick
    h = 1e-6
    eye = np.eye(3)

    def f(p: np.ndarray, a: float = 0.0, b: float = 0.0, n: float = 0.0) -> np.ndarray:
        return _pose_after(p, params, dsl + a, dsr + b, n, arc)  # type: ignore[no-any-return]

    jac_f = np.column_stack([(f(pose + h * e) - f(pose - h * e)) / (2 * h) for e in eye])
    jac_g = np.column_stack(
        [(f(pose, *(h * e)) - f(pose, *(-h * e))) / (2 * h) for e in eye]  # d/d(dsl, dsr, scrub)
    )
    p0 = np.array([[2e-4, 5e-5, 1e-5], [5e-5, 3e-4, -2e-5], [1e-5, -2e-5, 1e-3]])
    k = NoiseParams(1e-4, 3e-4, k_scrub=0.02)
    q = np.diag([k.k_left * abs(dsl), k.k_right * abs(dsr), k.k_scrub * abs(dsr - dsl) / 0.56])
    expected = jac_f @ p0 @ jac_f.T + jac_g @ q @ jac_g.T
    got = propagate_covariance(
        [0.0, ticks[0]], [0.0, ticks[1]], params, method, noise=k, heading0=0.7, cov0=p0
    )[-1]
    np.testing.assert_allclose(covariance_matrix(got), expected, rtol=1e-8, atol=1e-14)


def _ticks(seed: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    left = np.cumsum(rng.integers(-40, 60, n)) % 32768  # rolls over several times
    right = np.cumsum(rng.integers(-30, 70, n)) % 32768
    return left, right


def _scaled_error(got: np.ndarray, ref: np.ndarray) -> float:
    """Largest difference of each term over the scale sqrt(P_aa P_bb) of its row and column."""
    diag = ref[:, [0, 3, 5]]
    scale = np.sqrt(diag[:, [0, 0, 0, 1, 1, 2]] * diag[:, [0, 1, 2, 1, 2, 2]]) + 1e-300
    return float((np.abs(got - ref) / scale)[1:].max())


@pytest.mark.parametrize("method", ["midpoint", "arc"])
@pytest.mark.parametrize("model", [None, SideSlip(0.12)])
def test_integrate_with_covariance_equals_the_separate_calls(
    method: str, model: SideSlip | None
) -> None:
    params = NOMINAL.with_(noise=NoiseParams(1e-4, 3e-4, k_scrub=0.02))
    if model is not None:
        params = params.with_(model=model)
    left, right = _ticks(11, 3000)  # several blocks of the kernel, the last one partial
    t = 0.05 * np.arange(left.size)
    cov0 = np.diag([1e-4, 2e-4, 3e-5])
    traj, cov = integrate_with_covariance(
        t, left, right, params, method, start=(1.0, -2.0, 0.4), cov0=cov0
    )
    ref_traj = integrate(t, left, right, params, method, start=(1.0, -2.0, 0.4))
    ref = covariance_from_ticks(left, right, params, method, heading0=0.4, cov0=cov0)
    for name in ("t", "x", "y", "theta", "heading"):  # below PARALLEL_MIN_SAMPLES: the same ops
        np.testing.assert_array_equal(getattr(traj, name), getattr(ref_traj, name))
    assert _scaled_error(cov, ref) < 1e-9  # the shear from the pose step: equal to rounding


@pytest.mark.parametrize("threads", [2, 3, 7])
def test_segments_on_threads_equal_one_pass(threads: int, monkeypatch: pytest.MonkeyPatch) -> None:
    # each segment starts from zero; the true start is carried in afterwards through the
    # position change (the F's compose to one shear): equal to the one-pass recursion
    import odolab.core.uncertainty as unc

    monkeypatch.setattr(unc, "PARALLEL_MIN_SAMPLES", 100)
    params = NOMINAL.with_(noise=NoiseParams(1e-4, 3e-4, k_scrub=0.02))
    left, right = _ticks(12, 5000)
    t = 0.05 * np.arange(left.size)
    cov0 = np.diag([1e-4, 2e-4, 3e-5])
    start = (3.0, -1.0, 0.2)
    traj1, one = integrate_with_covariance(
        t, left, right, params, start=start, cov0=cov0, parallel=1
    )
    trajn, many = integrate_with_covariance(
        t, left, right, params, start=start, cov0=cov0, parallel=threads
    )
    assert _scaled_error(many, one) < 1e-9
    np.testing.assert_allclose(trajn.x, traj1.x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(trajn.y, traj1.y, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(trajn.theta, traj1.theta)
    assert not np.array_equal(many, one)  # the segments did run (rounding differs)


def test_headings_beyond_the_fast_sine_take_libm() -> None:
    # a heading past the polynomial sine's range (1e7 rad): the kernel falls back to libm and
    # still equals the streaming odometry
    params = NOMINAL.with_(noise=NOISE)
    left, right = _ticks(13, 1200)
    big = 0.9e7
    batch = covariance_from_ticks(left, right, params, heading0=big)
    odo = Odometry(params, covariance=True, start=(0.0, 0.0, big))
    for i in range(left.size):
        odo.update(0.05 * i, int(left[i]), int(right[i]))
    np.testing.assert_allclose(odo.covariance, batch[-1], rtol=1e-9)
    traj, fused = integrate_with_covariance(0.05 * np.arange(left.size), left, right, params,
                                            start=(0.0, 0.0, big))  # fmt: skip
    np.testing.assert_allclose(fused[-1], batch[-1], rtol=1e-9)
    np.testing.assert_allclose([traj.x[-1], traj.y[-1]], odo.pose[1:3], rtol=1e-9)
    # and the same as starting at the same direction with a small heading (the fast sine)
    near = covariance_from_ticks(left, right, params, heading0=math.remainder(big, 2 * math.pi))
    assert _scaled_error(near, batch) < 1e-6  # 1e7 rad carries ~1e-9 rad of rounding


def test_covariance_along_refuses_other_counters_and_a_missing_noise_table() -> None:
    left, right = _ticks(14, 50)
    t = 0.05 * np.arange(left.size)
    params = NOMINAL.with_(noise=NOISE)
    traj = integrate(t, left, right, params)
    with pytest.raises(LogFormatError, match="trajectory has 50 poses but the counters have 49"):
        covariance_along(traj, left[:-1], right[:-1], params)
    with pytest.raises(ParamsError, match=r"no \[noise\] table"):
        integrate_with_covariance(t, left, right, NOMINAL.with_(noise=None))


# --- where first order stops holding: measured by Monte Carlo (issue 26.5) --------------------

_PATHS = [  # (name, wheel path, k_left = k_right, k_scrub)
    ("straight 1 m", "straight", 1.0, 1e-4, 0.0),
    ("straight 5 m", "straight", 5.0, 1e-4, 0.0),
    ("straight 5 m, the issue's", "straight", 5.0, 1.87e-4, 0.0),
    ("straight 5 m, quiet", "straight", 5.0, 5e-5, 0.0),
    ("straight 5 m, noisy", "straight", 5.0, 5e-4, 0.0),
    ("turn, then 3 m", "turn", 3.0, 1e-4, 0.0),
    ("turn with scrub, then 3 m", "turn", 3.0, 1e-4, 5e-4),
    ("turn with scrub, then 1 m", "turn", 1.0, 2e-5, 2e-4),
    ("arc", "arc", 0.0, 5e-4, 0.0),
    ("arc, noisy", "arc", 0.0, 2e-3, 0.0),
]


@pytest.mark.parametrize(("name", "kind", "d", "k", "k_scrub"), _PATHS, ids=[p[0] for p in _PATHS])
def test_the_second_order_limit_is_where_first_order_stops_holding(
    name: str, kind: str, d: float, k: float, k_scrub: float
) -> None:
    """Below the limit the Monte Carlo spread along the heading is within 15 % of first order;
    at twice the limit it is 30 % or more above it. Heading variance alone does not say it (an
    arc with 0.077 rad^2 is fine, a straight 5 m with 0.006 rad^2 is not)."""
    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    from second_order_mc import along_ratio, arc, straight, turn_then_straight

    from odolab.core.uncertainty import SECOND_ORDER_LIMIT

    path = {"straight": straight, "turn": turn_then_straight}.get(kind)
    wheels = path(d) if path is not None else arc()
    rho, var_h, ratio = along_ratio(*wheels, k, k_scrub)
    if rho <= SECOND_ORDER_LIMIT:
        assert ratio <= 1.15, (name, rho, ratio)
    elif rho >= 2 * SECOND_ORDER_LIMIT:
        assert ratio >= 1.3, (name, rho, ratio)
    # the index predicts the understatement: about 1 + 2 rho^2 on every kind of path
    if kind != "arc":
        assert ratio == pytest.approx(1 + 2.2 * rho**2, rel=0.15), (name, rho, ratio)
    if name.endswith("the issue's"):
        assert var_h == pytest.approx(0.006, rel=0.01) and rho > SECOND_ORDER_LIMIT


def test_the_note_says_from_when_first_order_stops_holding() -> None:
    from odolab.core.params import NoiseParams
    from odolab.core.uncertainty import first_order_note

    p = NOMINAL.with_(noise=NoiseParams(1.87e-4, 1.87e-4))
    per_m = p.ticks_per_rev / (2 * math.pi * p.left_wheel_radius)
    dl = np.r_[0.0, np.full(200, 5.0 / 200 * per_m)]
    t = np.arange(201) * 0.05
    traj = integrate_increments(t, dl, dl, p)
    cov = propagate_covariance(dl, dl, p)
    note = first_order_note(traj, cov)
    assert note is not None and "understates the spread from t = " in note
    when = float(note.split("from t = ")[1].split(" s")[0])
    assert 3.0 < when < 10.0  # a straight 5 m of 10 s: past about 3.5 m
    from odolab.core.trajectory import Trajectory

    first = Trajectory.from_xyh(traj.t[:40], traj.x[:40], traj.y[:40], traj.heading[:40])
    assert first_order_note(first, cov[:40]) is None  # the first metre holds
