"""Invariants of the calibrations (hypothesis)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from odolab.calibration import ratios, umbmark
from odolab.core.params import PRESETS

P = PRESETS["jaguar-lite"]
ratio = st.floats(min_value=0.5, max_value=1.5)


@given(q_d=ratio, q_r=ratio)
def test_ratios_scale_radius_by_distance_and_track_by_their_quotient(q_d, q_r) -> None:
    new = ratios(P, q_d, q_r).params
    assert new.left_wheel_radius / P.left_wheel_radius == pytest.approx(q_d)
    assert new.track_width / P.track_width == pytest.approx(q_d / q_r)
    # the identity calibration changes nothing
    same = ratios(P, 1.0, 1.0).params
    assert same.track_width == P.track_width


@given(err=st.floats(min_value=-0.05, max_value=0.05), side=st.floats(min_value=0.5, max_value=5))
def test_umbmark_keeps_the_mean_radius_and_is_symmetric(err, side) -> None:
    cw = np.array([[err, 0.3 * err]])
    ccw = np.array([[0.5 * err, -err]])
    res = umbmark(cw, ccw, side, P)
    mean_new = 0.5 * (res.params.left_wheel_radius + res.params.right_wheel_radius)
    assert mean_new == pytest.approx(P.left_wheel_radius, rel=1e-12)
    assert res.params.right_wheel_radius / res.params.left_wheel_radius == pytest.approx(res.e_d)
    zero = umbmark(np.zeros((2, 2)), np.zeros((2, 2)), side, P)
    assert zero.e_d == 1.0 and zero.e_b == 1.0 and zero.e_max_syst == 0.0
