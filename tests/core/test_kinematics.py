from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from odolab.core.kinematics import (
    body_motion_from_wheel_displacements,
    chord_factor,
    pose_step,
    wheel_displacements_from_dticks,
    wrap_angle,
)


def test_wheel_displacement_eq_3_1() -> None:
    # one full revolution of a 0.1 m wheel rolls 2*pi*0.1 m
    dl, dr = wheel_displacements_from_dticks(380.0, 190.0, 0.1, 0.1, 380)
    assert dl == pytest.approx(2 * math.pi * 0.1)
    assert dr == pytest.approx(math.pi * 0.1)


def test_body_motion_eq_3_3_3_4() -> None:
    ds, dth = body_motion_from_wheel_displacements(0.1, 0.3, 0.5)
    assert ds == pytest.approx(0.2)
    assert dth == pytest.approx(0.4)


def test_midpoint_step_hand_computed() -> None:
    # heading 0, ds = 1, dtheta = pi/2: lab rule moves along heading pi/4
    x, y, h = pose_step(0.0, 0.0, 0.0, 1.0, math.pi / 2, "midpoint")
    assert (x, y, h) == pytest.approx((math.sqrt(0.5), math.sqrt(0.5), math.pi / 2))


def test_arc_step_is_exact_chord() -> None:
    # a quarter circle of radius R: arc length R*pi/2 ends at (R, R)
    r = 2.0
    x, y, h = pose_step(0.0, 0.0, 0.0, r * math.pi / 2, math.pi / 2, "arc")
    assert (x, y, h) == pytest.approx((r, r, math.pi / 2))


def test_chord_factor_continuous_near_zero() -> None:
    assert chord_factor(0.0, "arc") == 1.0
    assert chord_factor(2e-4, "arc") == pytest.approx(math.sin(1e-4) / 1e-4, abs=1e-15)
    assert chord_factor(0.3, "midpoint") == 1.0


@given(st.floats(-1e6, 1e6, allow_nan=False))
def test_wrap_angle_range_and_equivalence(a: float) -> None:
    w = wrap_angle(a)
    assert -math.pi < w <= math.pi
    assert math.isclose(math.cos(w), math.cos(a), abs_tol=1e-9)
    assert math.isclose(math.sin(w), math.sin(a), abs_tol=1e-9)
    arr = wrap_angle(np.array([a]))
    assert arr[0] == w  # scalar and array versions agree exactly


def test_wrap_angle_boundaries() -> None:
    assert wrap_angle(math.pi) == pytest.approx(math.pi)
    assert wrap_angle(-math.pi) == pytest.approx(math.pi)
    assert wrap_angle(3 * math.pi) == pytest.approx(math.pi)
    assert wrap_angle(20 * math.pi + 0.1) == pytest.approx(0.1)


def test_wrap_angle_of_a_non_finite_float_is_nan_like_the_array_branch() -> None:
    # math.floor(nan) used to raise ValueError here (a traceback from `trials add`)
    for bad in (math.nan, math.inf, -math.inf):
        assert math.isnan(wrap_angle(bad))
        with np.errstate(invalid="ignore"):
            assert np.isnan(wrap_angle(np.array([bad])))[0]
