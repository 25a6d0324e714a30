"""Measurements in the lab's terms: the compass sign convention and the refusals."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from odolab.core.errors import StoreError
from odolab.core.measurement import (
    rotation_from_compass,
    rotation_measurement_from_compass,
    translation_measurement,
)


def test_ccw_rotation_decreases_the_compass_reading() -> None:
    # 30 deg ccw from 100 deg: the compass (clockwise from north) now reads 70 deg
    assert rotation_from_compass(100.0, 70.0, 0) == pytest.approx(math.radians(30))
    # 2 whole turns + 30 deg ccw, crossing north: 10 -> 340
    m = rotation_measurement_from_compass(10.0, 340.0, 2)
    assert m.rotation == pytest.approx(4 * math.pi + math.radians(30))
    assert m.raw == {"compass_initial_deg": 10.0, "compass_final_deg": 340.0, "turns": 2.0}
    assert m.instrument == "compass"
    assert m.sigma_rotation == pytest.approx(math.sqrt(2) * 0.05)


def test_cw_rotation_is_negative_and_increases_the_reading() -> None:
    # commanded -pi/2 (cw): 350 -> 80 is 90 deg clockwise
    m = rotation_measurement_from_compass(350.0, 80.0, 0, commanded_angle=-math.pi / 2)
    assert m.rotation == pytest.approx(-math.pi / 2)
    assert rotation_from_compass(0.0, 45.0, 1, "cw") == pytest.approx(-(2 * math.pi + math.pi / 4))


def test_lab_20pi_rotation_at_0_875() -> None:
    # the lab's slope: 20 pi commanded, 0.875 of it done = 17.5 pi = 8 turns + 270 deg
    m = rotation_measurement_from_compass(200.0, 290.0, 8, commanded_angle=20 * math.pi)
    assert m.rotation == pytest.approx(17.5 * math.pi)


@given(
    rotation=st.floats(0.0, 130.0),
    initial=st.floats(0.0, 359.999),
)
def test_readings_invert_the_convention(rotation: float, initial: float) -> None:
    turns = int(rotation // (2 * math.pi))
    frac_deg = math.degrees(rotation - 2 * math.pi * turns)
    final = (initial - frac_deg) % 360.0
    if final >= 360.0:  # float rounding of a tiny negative
        final = 0.0
    got = rotation_from_compass(initial, final, turns)
    assert got == pytest.approx(rotation, abs=1e-9) or got == pytest.approx(
        rotation + 2 * math.pi, abs=1e-9
    )


@pytest.mark.parametrize(
    ("args", "kwargs", "match"),
    [
        ((360.0, 10.0, 1), {}, "compass initial reading is 360 deg"),
        ((10.0, -1.0, 1), {}, "compass final reading is -1 deg"),
        ((10.0, 20.0, -1), {}, "turns is -1"),
        ((10.0, 20.0, 2.5), {}, "whole number"),
        (("ten", 20.0, 2), {}, "must be a number"),
        ((10.0, float("nan"), 2), {}, "finite"),
        # 20 pi commanded but only 1 turn counted: check the turns, about 9 fit
        ((10.0, 20.0, 1), {"commanded_angle": 20 * math.pi}, r"about 9 would fit"),
        ((10.0, 200.0, 0), {"commanded_angle": math.pi, "direction": "cw"}, "contradicts"),
    ],
)
def test_out_of_range_readings_are_refused(args: tuple, kwargs: dict, match: str) -> None:
    with pytest.raises(StoreError, match=match):
        rotation_measurement_from_compass(*args, **kwargs)


def test_translation_measurement_and_refusals() -> None:
    m = translation_measurement(2.74, -0.03, commanded_distance=2.5)
    assert (m.x, m.y, m.sigma_xy, m.instrument) == (2.74, -0.03, 0.005, "meterstick")
    with pytest.raises(StoreError, match="typed in cm"):
        translation_measurement(274.0, 0.0)
    with pytest.raises(StoreError, match="from the commanded"):
        translation_measurement(-2.7, 0.0, commanded_distance=2.5)
    with pytest.raises(StoreError, match="sigma must be positive"):
        translation_measurement(1.0, 0.0, sigma=0.0)
    with pytest.raises(StoreError, match="y must be a number"):
        translation_measurement(1.0, "abc")  # type: ignore[arg-type]
