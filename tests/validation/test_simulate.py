"""The simulated phone and the turning-in-place scenario."""

from __future__ import annotations

import math

import numpy as np
import pytest

from odolab.core.errors import ImuLogError
from odolab.core.odometry import integrate
from odolab.validation import ImuLog, rotation_scenario, simulate_phone_log, validate


def test_phone_sees_the_true_heading_on_its_own_clock() -> None:
    t = np.linspace(0.0, 10.0, 201)
    heading = 0.3 * t**2  # rate 0.6 t
    phone = simulate_phone_log(t, heading, clock_offset=4.0, gyro_noise=0.0, yaw0=1.0, seed=0)
    assert phone.t[0] == pytest.approx(4.0) and phone.t[-1] == pytest.approx(14.0)
    assert np.diff(phone.t) == pytest.approx(0.01)
    assert phone.yaw_rate is not None
    np.testing.assert_allclose(phone.yaw_rate[1:-1], 0.6 * (phone.t[1:-1] - 4.0), atol=2e-3)
    np.testing.assert_allclose(phone.yaw - 1.0, 0.3 * (phone.t - 4.0) ** 2, atol=2e-3)


def test_gyro_bias_makes_the_yaw_drift_and_noise_is_seeded() -> None:
    t = np.linspace(0.0, 20.0, 401)
    still = simulate_phone_log(t, np.zeros_like(t), clock_offset=0.0, gyro_noise=0.0, bias=0.01)
    assert still.yaw[-1] - still.yaw[0] == pytest.approx(0.2, abs=1e-9)  # 0.01 rad/s * 20 s
    a = simulate_phone_log(t, np.zeros_like(t), clock_offset=0.0, gyro_noise=0.05, seed=3)
    b = simulate_phone_log(t, np.zeros_like(t), clock_offset=0.0, gyro_noise=0.05, seed=3)
    np.testing.assert_array_equal(a.yaw, b.yaw)
    assert a.yaw_rate is not None
    assert np.std(a.yaw_rate) == pytest.approx(0.05, rel=0.1)
    with pytest.raises(ImuLogError, match="rate_hz"):
        simulate_phone_log(t, t, clock_offset=0.0, rate_hz=0.0)


def test_scenario_counts_follow_the_true_track_width() -> None:
    sc = rotation_scenario(turns=2.0, slip_noise=0.0)
    assert sc.new.track_width == pytest.approx(0.56 / 0.875)
    assert sc.true_heading[-1] == pytest.approx(4 * math.pi, rel=1e-3)
    new = integrate(sc.encoder_log.t, sc.encoder_log.left_ticks, sc.encoder_log.right_ticks, sc.new)
    old = integrate(sc.encoder_log.t, sc.encoder_log.left_ticks, sc.encoder_log.right_ticks, sc.old)
    count = sc.new.right_metres_per_tick / (0.5 * sc.new.track_width)  # rad per count pair
    np.testing.assert_allclose(new.heading, sc.true_heading, atol=count)
    assert old.heading[-1] / sc.true_heading[-1] == pytest.approx(1 / 0.875, rel=1e-3)
    np.testing.assert_allclose(new.x, 0.0, atol=2e-3)  # in place: within a count (1.4 mm)


def test_an_imu_without_yaw_rate_is_aligned_from_its_yaw() -> None:
    sc = rotation_scenario(seed=4)
    phone = simulate_phone_log(sc.true_t, sc.true_heading, clock_offset=-6.25, seed=5)
    no_rate = ImuLog(phone.t, phone.yaw, None, "compass-like")
    r = validate(sc.encoder_log, no_rate, sc.old, sc.new)
    assert r.clock_offset == pytest.approx(-6.25, abs=0.01)
    assert r.new.rms < 0.1 < 1.0 < r.old.rms
