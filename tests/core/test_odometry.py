from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from odolab import (
    EncoderJumpError,
    LogFormatError,
    Odometry,
    RobotParams,
    integrate,
    integrate_increments,
)
from odolab.core.odometry import PARALLEL_MIN_SAMPLES

P = RobotParams(0.1, 0.1, 0.5, 800, None, name="test")

dticks = arrays(np.int64, st.integers(2, 60), elements=st.integers(-300, 300))
methods = st.sampled_from(["midpoint", "arc"])
moduli = st.sampled_from([None, 32768, 65536, 2**32])


def _stream(t, left, right, params, method):  # type: ignore[no-untyped-def]
    odo = Odometry(params, method)
    return np.array([odo.update(ti, li, ri) for ti, li, ri in zip(t, left, right, strict=True)])


@given(dticks, dticks, methods, moduli, st.integers(0, 2**40))
def test_streaming_equals_batch(dl, dr, method, modulus, offset) -> None:  # type: ignore[no-untyped-def]
    n = min(dl.size, dr.size)
    params = P.with_(encoder_modulus=modulus)
    left = np.cumsum(dl[:n]) + offset
    right = np.cumsum(dr[:n]) + offset // 3
    if modulus is not None:
        left %= modulus
        right %= modulus
    t = np.arange(n) * 0.05
    batch = integrate(t, left, right, params, method)
    stream = _stream(t, left, right, params, method)
    for j, name in enumerate(("t", "x", "y", "theta", "heading")):
        np.testing.assert_allclose(stream[:, j], getattr(batch, name), rtol=0, atol=1e-9)


@given(dticks, dticks, st.sampled_from([32768, 65536, 2**32]), st.integers(0, 2**33), methods)
def test_rollover_anywhere_equals_no_rollover(dl, dr, modulus, offset, method) -> None:  # type: ignore[no-untyped-def]
    n = min(dl.size, dr.size)
    left = np.cumsum(dl[:n])
    right = np.cumsum(dr[:n])
    t = np.arange(n) * 0.05
    plain = integrate(t, left, right, P, method)
    wrapped = integrate(
        t,
        (left + offset) % modulus,
        (right + offset) % modulus,
        P.with_(encoder_modulus=modulus),
        method,
    )
    np.testing.assert_allclose(wrapped.x, plain.x, atol=1e-12)
    np.testing.assert_allclose(wrapped.y, plain.y, atol=1e-12)
    np.testing.assert_allclose(wrapped.heading, plain.heading, atol=1e-12)


@pytest.mark.parametrize("bits", [15, 16])
@pytest.mark.parametrize("direction", [1, -1])
def test_wrap_between_two_samples_forward_and_backward(bits: int, direction: int) -> None:
    m = 2**bits
    # counters cross the wrap point in one cycle: m-3 -> 2 (forward) or 2 -> m-3 (backward)
    left = np.array([m - 3, 2, 7]) if direction == 1 else np.array([7, 2, m - 3])
    params = P.with_(encoder_modulus=m)
    tr = integrate([0.0, 0.05, 0.1], left, left, params)
    per_tick = params.left_metres_per_tick
    assert tr.x[-1] == pytest.approx(direction * 10 * per_tick)
    assert tr.y[-1] == pytest.approx(0.0, abs=1e-15)


@given(st.integers(1, 40), st.sampled_from([1, -1]), methods)
def test_rotation_in_place_keeps_position(half_turns: int, sign: int, method: str) -> None:
    # wheels in opposite directions; total rotation half_turns * pi, in 200 cycles
    total = sign * half_turns * math.pi
    per_wheel = total * P.track_width / 2 / P.right_metres_per_tick  # ticks, fractional
    d = np.full(201, per_wheel / 200)
    d[0] = 0
    tr = integrate_increments(np.arange(201) * 0.05, -d, d, P, method)
    assert np.all(tr.x == 0.0) and np.all(tr.y == 0.0)
    assert tr.heading[-1] == pytest.approx(total, abs=1e-9)
    assert -math.pi < tr.theta[-1] <= math.pi


def test_twenty_pi_rotation_from_raw_wrapping_counters() -> None:
    params = P.with_(encoder_modulus=32768)
    per_wheel = 20 * math.pi * params.track_width / 2 / params.right_metres_per_tick  # 10000 ticks
    steps = 400
    right = np.rint(np.linspace(0, per_wheel, steps + 1)).astype(np.int64) + 30000
    left = -np.rint(np.linspace(0, per_wheel, steps + 1)).astype(np.int64) + 5
    tr = integrate(np.arange(steps + 1) * 0.05, left % 32768, right % 32768, params)
    assert tr.heading[-1] == pytest.approx(20 * math.pi, abs=1e-9)
    assert abs(tr.x[-1]) < 1e-12 and abs(tr.y[-1]) < 1e-12


def _square_increments(
    side: float, params: RobotParams, ccw: bool
) -> tuple[np.ndarray, np.ndarray]:
    """Hand-computed (fractional) ticks of a square: 4 x (straight leg, quarter turn in place)."""
    leg = side / params.right_metres_per_tick
    quarter = (math.pi / 2) * (params.track_width / 2) / params.right_metres_per_tick
    s = 1 if ccw else -1
    dl, dr = [0.0], [0.0]
    for _ in range(4):
        dl += [leg / 10] * 10
        dr += [leg / 10] * 10
        dl += [-s * quarter / 5] * 5
        dr += [s * quarter / 5] * 5
    return np.array(dl), np.array(dr)


@pytest.mark.parametrize("ccw", [True, False])
@pytest.mark.parametrize("method", ["midpoint", "arc"])
def test_square_closes_where_geometry_says(ccw: bool, method: str) -> None:
    dl, dr = _square_increments(4.0, P, ccw)
    tr = integrate_increments(np.arange(dl.size) * 0.05, dl, dr, P, method)
    # corners at (4,0), (4,±4), (0,±4), back at the origin, heading ±2 pi
    corner = 10 + 5
    sgn = 1 if ccw else -1
    expected = [(4, 0), (4, 4 * sgn), (0, 4 * sgn), (0, 0)]
    for k, (ex, ey) in enumerate(expected, start=1):
        assert tr.x[k * corner] == pytest.approx(ex, abs=1e-9)
        assert tr.y[k * corner] == pytest.approx(ey, abs=1e-9)
    assert tr.heading[-1] == pytest.approx(sgn * 2 * math.pi, abs=1e-12)


def test_square_with_integer_ticks_closes_within_quantization() -> None:
    dl, dr = _square_increments(1.0, P, True)
    left = np.rint(np.cumsum(dl)).astype(np.int64)
    right = np.rint(np.cumsum(dr)).astype(np.int64)
    tr = integrate(np.arange(left.size) * 0.05, left, right, P)
    # each count is 0.785 mm; a rounding error of half a count per corner bounds the closure
    assert math.hypot(tr.x[-1], tr.y[-1]) < 4 * P.right_metres_per_tick
    assert tr.heading[-1] == pytest.approx(
        2 * math.pi, abs=4 * P.right_metres_per_tick / P.track_width
    )


@given(arrays(np.float64, st.integers(2, 50), elements=st.floats(-200, 200)), dticks, methods)
def test_path_then_its_reverse_returns_to_start(dl, dr_int, method) -> None:  # type: ignore[no-untyped-def]
    n = min(dl.size, dr_int.size)
    dl, dr = dl[:n].copy(), dr_int[:n].astype(float)
    dl[0] = dr[0] = 0.0
    back_l = np.concatenate([[0.0], -dl[1:][::-1]])
    back_r = np.concatenate([[0.0], -dr[1:][::-1]])
    odo = Odometry(P, method)
    odo.update_increments(0.0, 0, 0)
    for k in range(1, n):
        odo.update_increments(k * 0.05, dl[k], dr[k])
    for k in range(1, n):
        pose = odo.update_increments((n + k) * 0.05, back_l[k], back_r[k])
    if n > 1:
        assert abs(pose.x) < 1e-9 and abs(pose.y) < 1e-9 and abs(pose.heading) < 1e-12


def test_arc_method_closes_a_circle_exactly() -> None:
    # constant wheel speeds: a circle; 100 cycles make one turn
    radius = 1.0
    b = P.track_width
    turn = 2 * math.pi / 100
    dsr, dsl = turn * (radius + b / 2), turn * (radius - b / 2)
    n = 101
    dl = np.full(n, dsl / P.left_metres_per_tick)
    dr = np.full(n, dsr / P.right_metres_per_tick)
    arc = integrate_increments(np.arange(n), dl, dr, P, "arc")
    mid = integrate_increments(np.arange(n), dl, dr, P, "midpoint")
    assert math.hypot(arc.x[-1], arc.y[-1]) < 1e-12
    assert np.max(np.abs(np.hypot(arc.x, arc.y - radius) - radius)) < 1e-12
    # the midpoint rule is close but not exact: each chord is drawn as the arc length
    assert np.max(np.hypot(mid.x, mid.y - radius) - radius) > 1e-5


def test_parallel_path_equals_sequential() -> None:
    n = PARALLEL_MIN_SAMPLES + 1234
    rng = np.random.default_rng(3)
    params = P.with_(encoder_modulus=32768)
    left = np.cumsum(rng.integers(-50, 80, n)) % 32768
    right = np.cumsum(rng.integers(-40, 80, n)) % 32768
    t = np.arange(n) * 0.05
    a = integrate(t, left, right, params, parallel=1)
    b = integrate(t, left, right, params, parallel=2)
    for name in ("x", "y", "theta", "heading"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    odo = Odometry(params)
    for k in range(n):
        pose = odo.update(t[k], left[k], right[k])
    assert pose.x == pytest.approx(a.x[-1], abs=1e-9)
    assert pose.y == pytest.approx(a.y[-1], abs=1e-9)
    assert pose.heading == pytest.approx(a.heading[-1], abs=1e-9)


def test_jump_is_reported_not_integrated() -> None:
    params = P.with_(encoder_modulus=32768)
    left = np.array([0, 10, 9000, 9010])
    right = np.array([0, 10, 20, 30])
    with pytest.raises(
        EncoderJumpError, match=r"left_ticks jumps by 8990 counts between samples 1 and 2"
    ):
        integrate([0, 1, 2, 3], left, right, params)
    # a looser limit accepts it
    tr = integrate([0, 1, 2, 3], left, right, params, max_dticks=10_000)
    assert tr.x[-1] > 0
    odo = Odometry(params)
    odo.update(0, 0, 0)
    odo.update(1, 10, 10)
    with pytest.raises(EncoderJumpError):
        odo.update(2, 9000, 20)


def test_time_errors() -> None:
    with pytest.raises(LogFormatError, match="time goes backwards at index 2"):
        integrate([0.0, 1.0, 0.5], [0, 1, 2], [0, 1, 2], P)
    with pytest.raises(LogFormatError, match="expected a number"):
        integrate([0.0, math.nan, 2.0], [0, 1, 2], [0, 1, 2], P)
    odo = Odometry(P)
    odo.update(1.0, 0, 0)
    with pytest.raises(LogFormatError, match="goes backwards"):
        odo.update(0.5, 1, 1)


def test_bad_ticks_rejected() -> None:
    with pytest.raises(LogFormatError, match=r"left_ticks\[1\] is nan"):
        integrate([0.0, 1.0], [0.0, math.nan], [0, 1], P)
    with pytest.raises(LogFormatError, match="expected an integer count"):
        integrate([0.0, 1.0], [0.0, 1.5], [0, 1], P)
    with pytest.raises(LogFormatError, match="samples"):
        integrate([0.0, 1.0, 2.0], [0, 1], [0, 1], P)


def test_start_pose_and_empty() -> None:
    tr = integrate([0.0, 1.0], [0, 100], [0, 100], P, start=(1.0, 2.0, math.pi / 2))
    assert tr.x[-1] == pytest.approx(1.0)
    assert tr.y[-1] == pytest.approx(2.0 + 100 * P.left_metres_per_tick)
    assert len(integrate([], [], [], P)) == 0


@pytest.mark.parametrize("bad", [0, -5, 2.5])
def test_max_dticks_must_be_a_positive_count(bad: float) -> None:
    # a negative limit used to mean "no limit" inside the compiled loop, silently
    from odolab.core.errors import OdolabError

    with pytest.raises(OdolabError, match="max_dticks"):
        integrate([0.0, 1.0], [0, 100], [0, 100], P, max_dticks=bad)  # type: ignore[arg-type]
    with pytest.raises(OdolabError, match="max_dticks"):
        Odometry(P, max_dticks=bad)  # type: ignore[arg-type]


def test_warm_up_loads_the_kernels_on_a_thread_and_leaves_errors_to_the_real_call() -> None:
    from odolab.core.odometry import warm_up
    from odolab.core.params import PRESETS

    jaguar = PRESETS["jaguar-lite"]
    warm_up(jaguar, "midpoint").join(timeout=120)
    th = warm_up(jaguar.with_(noise=None), "arc", covariance=True)  # no [noise]: not raised
    th.join(timeout=120)
    assert not th.is_alive()
