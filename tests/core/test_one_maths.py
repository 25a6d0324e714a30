"""Issue 41: one plain statement each of the angle wrap, the counter rollover and the odometry
step, and their compiled twins equal to them (the twins are what the kernels inline)."""

from __future__ import annotations

import math

import numpy as np

from odolab.core._encoders_jit import unwrap_diff
from odolab.core._kinematics_jit import chord, step_pose, wrap
from odolab.core.encoders import counter_delta
from odolab.core.kinematics import SMALL_ANGLE, chord_factors, odometry_step, wrap_angle

# headings, body motions and heading changes around the series switch, large and negative
DTHETA = np.array([0.0, 1e-9, -SMALL_ANGLE, 2 * SMALL_ANGLE, 1.9999e-4, 0.01, -0.3, 1.2, -3.0])
HEADING = np.array([0.0, -7.0, 3.1, 100.0, -0.5])


def _cases() -> list[tuple[float, float, float, float, float, float]]:
    rng = np.random.default_rng(41)
    out = []
    for h in HEADING:
        for d in DTHETA:
            x, y, fwd, lat = rng.normal(size=4)
            out.append((float(x), float(y), float(h), float(fwd), float(lat), float(d)))
    return out


def test_compiled_step_equals_the_plain_step() -> None:
    for arc in (False, True):
        for x, y, h, fwd, lat, d in _cases():
            got = step_pose(x, y, h, fwd, lat, d, arc)
            want = odometry_step(x, y, h, fwd, lat, d, arc)
            # numpy's sin/cos and libm's may differ in the last bit: equal to rounding
            np.testing.assert_allclose(got, [float(v) for v in want], rtol=1e-15, atol=1e-15)
            assert got[2] == float(want[2])  # the heading sum is the same operation


def test_plain_step_on_arrays_equals_it_per_element() -> None:
    cases = np.array(_cases())
    xs, ys, hs = odometry_step(*cases.T, True)
    for k, row in enumerate(cases):
        one = odometry_step(*row, True)
        assert (xs[k], ys[k], hs[k]) == (float(one[0]), float(one[1]), float(one[2]))


def test_compiled_chord_equals_the_plain_chord() -> None:
    plain = chord_factors(DTHETA)
    for d, p in zip(DTHETA, plain, strict=True):
        assert math.isclose(chord(float(d), True), float(p), rel_tol=1e-15)
        assert chord(float(d), False) == 1.0
    assert (chord_factors(DTHETA, arc=False) == 1.0).all()


def test_compiled_wrap_equals_wrap_angle() -> None:
    angles = np.concatenate(
        [np.linspace(-50.0, 50.0, 2001), [math.pi, -math.pi, 3 * math.pi, -3 * math.pi, 0.0]]
    )
    plain = wrap_angle(angles)
    for a, p in zip(angles, plain, strict=True):
        assert wrap(float(a)) == float(p) == wrap_angle(float(a))


def test_compiled_rollover_equals_counter_delta() -> None:
    for modulus in (2, 1024, 32768, 65536):
        half = modulus // 2
        diffs = np.arange(-modulus + 1, modulus, max(1, modulus // 257), dtype=np.int64)
        plain = counter_delta(diffs, modulus)
        assert ((plain >= -half) & (plain < modulus - half)).all()
        for d, p in zip(diffs, plain, strict=True):
            assert unwrap_diff(int(d), modulus, half) == int(p) == counter_delta(int(d), modulus)


def test_the_plain_kernels_give_their_compiled_twins_numbers() -> None:
    # streaming odometry, the virtual board and pose_step run odolab.core._step_kernels as
    # Python; the batch passes inline numba's twins of the same source. Bit-equal here over
    # 200,000 random cases of each (libm's sin and cos on both sides, no fused multiply-add);
    # asserted to rounding, as another machine's numba may fuse
    from odolab.core import _step_kernels as plain
    from odolab.core._kinematics_jit import body_motion, chord_derivative

    rng = np.random.default_rng(7)
    for x, y, h, fwd, lat, d in _cases():
        for arc in (False, True):
            got = step_pose(x, y, h, fwd, lat, d, arc)
            np.testing.assert_allclose(
                plain.step_pose(x, y, h, fwd, lat, d, arc), got, rtol=1e-15, atol=1e-15
            )
            assert math.isclose(plain.chord(d, arc), chord(d, arc), rel_tol=1e-15)
            assert math.isclose(
                plain.chord_derivative(d, arc),
                chord_derivative(d, arc),
                rel_tol=1e-15,
                abs_tol=1e-18,
            )
        assert plain.wrap(h) == wrap(h)  # floor, multiply, subtract: the same operations
        coefficients = rng.normal(size=8)
        np.testing.assert_allclose(
            plain.body_motion(*coefficients), body_motion(*coefficients), rtol=1e-15, atol=1e-15
        )
    assert not hasattr(plain.step_pose, "signatures")  # the source itself, not a dispatcher
    twin_source = getattr(step_pose, "py_func", step_pose)  # without numba, the copy itself
    assert twin_source.__code__ is plain.step_pose.__code__  # the twin's code is the source


def test_the_python_callers_give_the_compiled_nan_on_infinite_angles() -> None:
    """math's sin and cos raise on infinity where numba's give NaN: pose_step and chord_factor
    run the plain kernels and still answer as the compiled ones do."""
    from odolab.core.kinematics import chord_factor, pose_step

    inf = math.inf
    for arc, method in ((False, "midpoint"), (True, "arc")):
        for args in ((0.0, 0.0, 0.0, 1.0, 0.0, inf), (0.0, 0.0, inf, 1.0, 0.0, 0.1)):
            want = step_pose(*args, arc)
            x, y, h, fwd, lat, d = args
            got = pose_step(x, y, h, fwd, d, method, lat)
            assert [str(v) for v in got] == [str(v) for v in want], (got, want)
        assert str(chord_factor(inf, method)) == str(chord(inf, arc))
        assert str(chord_factor(math.nan, method)) == str(chord(math.nan, arc))


def test_streaming_refuses_a_non_finite_increment_as_the_batch_does() -> None:
    import pytest

    from odolab.core.errors import LogFormatError
    from odolab.core.odometry import Odometry
    from odolab.core.params import PRESETS

    odo = Odometry(PRESETS["jaguar-lite"])
    odo.update_increments(0.0, 0, 0)
    before = odo.update_increments(0.05, 10.0, 12.0)
    for bad in (math.nan, math.inf, -math.inf):
        with pytest.raises(LogFormatError, match=r"dticks_right is .* expected a finite number"):
            odo.update_increments(0.1, 5.0, bad)
    assert odo.pose == before and odo.cycles == 1  # unchanged: NaN would have poisoned the rest
    assert odo.update_increments(0.1, 5.0, 5.0).x > before.x
