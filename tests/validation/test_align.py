"""Clock offset by cross-correlating yaw rates: recovery accuracy, bounds, the no-overlap error."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from odolab.core.errors import ImuLogError
from odolab.io.sensorlog import ImuLog
from odolab.validation.align import find_clock_offset, rate_on_grid, require_overlap
from odolab.validation.simulate import rotation_scenario, simulate_phone_log


def _smooth_heading(t: np.ndarray) -> np.ndarray:
    """A heading with an uneven rate (so the correlation has one sharp peak)."""
    return 2.0 * t + 3.0 * np.sin(0.7 * t) + 1.5 * np.sin(2.3 * t + 0.4)


def test_rate_on_grid_of_a_parabola() -> None:
    # heading t^2: the mid-point difference quotient of a parabola is exact: rate 2t
    t = np.linspace(0.0, 2.0, 21)
    grid = np.array([0.05, 0.55, 1.95])
    np.testing.assert_allclose(rate_on_grid(t, t**2, grid), 2 * grid, atol=1e-12)


@pytest.mark.parametrize("true_offset", [-17.3333, -0.004, 0.0, 2.5, 9.87654])
def test_offset_recovered_on_exact_signals(true_offset: float) -> None:
    t_robot = np.arange(0.0, 40.0, 0.05)  # 20 Hz robot
    t_phone_robot = np.arange(-5.0, 45.0, 0.01)  # 100 Hz phone, on the robot clock
    imu = ImuLog(
        t_phone_robot + true_offset,
        _smooth_heading(t_phone_robot) + 1.234,
        2.0 + 2.1 * np.cos(0.7 * t_phone_robot) + 3.45 * np.cos(2.3 * t_phone_robot + 0.4),
    )
    a = find_clock_offset(t_robot, _smooth_heading(t_robot), imu, nominal_offset=0.0)
    assert a.clock_offset == pytest.approx(true_offset, abs=1e-3)
    assert a.correlation > 0.99
    assert a.overlap_start == pytest.approx(0.0)
    assert a.overlap_end == pytest.approx(t_robot[-1])


@pytest.mark.parametrize("true_offset", [-12.345, 0.0071, 3.217, 25.5])
def test_offset_recovered_on_a_simulated_phone(true_offset: float) -> None:
    sc = rotation_scenario(seed=1)
    phone = simulate_phone_log(
        sc.true_t, sc.true_heading, clock_offset=true_offset, gyro_noise=0.01, bias=0.002, seed=3
    )
    traj_t = sc.encoder_log.t
    from odolab.core.odometry import integrate

    h = integrate(traj_t, sc.encoder_log.left_ticks, sc.encoder_log.right_ticks, sc.old).heading
    a = find_clock_offset(traj_t, h, phone)
    # 10 ms grid, counters that lag the truth by half a count on average: a few ms
    assert a.clock_offset == pytest.approx(true_offset, abs=0.01)


@settings(max_examples=15, deadline=None)
@given(st.floats(-20.0, 20.0), st.integers(0, 2**16))
def test_offset_recovery_property(true_offset: float, seed: int) -> None:
    t_robot = np.arange(0.0, 30.0, 0.05)
    rng = np.random.default_rng(seed)
    t_phone_robot = np.arange(-3.0, 33.0, 0.02)
    imu = ImuLog(
        t_phone_robot + true_offset,
        _smooth_heading(t_phone_robot) + 0.01 * rng.standard_normal(t_phone_robot.size),
    )
    a = find_clock_offset(t_robot, _smooth_heading(t_robot), imu, max_offset=25.0)
    assert abs(a.clock_offset - true_offset) < 0.01


def test_search_bounds_are_respected_and_fixed_offset_is_kept() -> None:
    t = np.arange(0.0, 30.0, 0.05)
    imu = ImuLog(t + 4.0, _smooth_heading(t))
    fixed = find_clock_offset(t, _smooth_heading(t), imu, nominal_offset=3.9, max_offset=0.0)
    assert fixed.clock_offset == 3.9
    assert math.isnan(fixed.correlation)
    bounded = find_clock_offset(t, _smooth_heading(t), imu, nominal_offset=0.0, max_offset=2.0)
    assert -2.0 <= bounded.clock_offset <= 2.0
    found = find_clock_offset(t, _smooth_heading(t), imu, nominal_offset=3.0, max_offset=2.0)
    assert found.clock_offset == pytest.approx(4.0, abs=1e-3)
    anywhere = find_clock_offset(t, _smooth_heading(t), imu, max_offset=math.inf)
    assert anywhere.clock_offset == pytest.approx(4.0, abs=1e-3)


def test_no_overlap_is_one_clear_error_with_both_ranges() -> None:
    t = np.arange(0.0, 60.0, 0.05)
    imu = ImuLog(1000.0 + t, _smooth_heading(t), source="phone.csv")
    with pytest.raises(ImuLogError) as info:
        find_clock_offset(t, _smooth_heading(t), imu, robot_source="enc.csv")
    msg = str(info.value)
    assert msg.startswith("phone.csv: the IMU log (phone time 1000.000 to 1059.950 s)")
    assert "enc.csv (robot time 0.000 to 59.950 s)" in msg
    assert "from -30 to 30 s" in msg
    assert msg.count(". ") == 0 and "\n" not in msg  # one sentence


def test_require_overlap_edges() -> None:
    robot_t = np.array([0.0, 10.0])
    imu = ImuLog(np.array([35.0, 45.0]), np.zeros(2))
    # offset 30 puts the phone at robot 5..15: 5 s of overlap
    require_overlap(robot_t, imu, 30.0, 30.0, min_overlap=5.0)
    with pytest.raises(ImuLogError, match="clock offset of 30 s"):
        require_overlap(robot_t, imu, 30.0, 30.0, min_overlap=5.5)
    require_overlap(robot_t, imu, 0.0, 40.0, min_overlap=10.0)  # offset 35 overlaps fully
    with pytest.raises(ImuLogError, match="any clock offset from 0 to 24"):
        require_overlap(robot_t, imu, 0.0, 24.0, min_overlap=1.0)


def test_no_rotation_cannot_be_aligned() -> None:
    t = np.arange(0.0, 10.0, 0.05)
    imu = ImuLog(t, np.zeros(t.size), np.zeros(t.size))
    with pytest.raises(ImuLogError, match="neither log shows any rotation"):
        find_clock_offset(t, np.zeros(t.size), imu)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        # a Gaussian of 1e9 s on a 10 ms grid asked numpy for 5.8 TiB (MemoryError traceback)
        ({"smooth": 1e9}, r"smooth is 1e\+09 s; expected a number from 0 to 10 s"),
        ({"smooth": math.nan}, r"smooth is nan s; expected a number from 0 to 10 s"),
        ({"nominal_offset": math.inf}, r"offset \(phone minus robot\) is inf s; expected a finite"),
        ({"max_offset": -5.0}, r"max_offset is -5 s; expected a number >= 0 \(0 fixes"),
        ({"max_offset": math.nan}, r"max_offset is nan s; expected a number >= 0"),
    ],
)
def test_bad_search_settings_are_one_sentence(kwargs: dict, message: str) -> None:  # type: ignore[type-arg]
    t = np.arange(0.0, 10.0, 0.01)
    imu = ImuLog(t, _smooth_heading(t), 2.0 + np.zeros(t.size))
    with pytest.raises(ImuLogError, match=message):
        find_clock_offset(t, _smooth_heading(t), imu, **kwargs)


def test_a_log_shorter_than_the_overlap_says_so() -> None:
    # a 0.05 s encoder log was told to "widen the search": no offset can ever give 1 s
    imu = ImuLog(np.arange(0.0, 20.0, 0.01), np.zeros(2000), np.zeros(2000))
    short = np.array([0.0, 0.05])
    with pytest.raises(ImuLogError, match=r"the enc\.csv lasts 0\.05 s; expected at least 1 s"):
        require_overlap(short, imu, -math.inf, math.inf, min_overlap=1.0, robot_source="enc.csv")
    imu_short = ImuLog(np.array([5.0, 5.5]), np.zeros(2), np.zeros(2), source="p.csv")
    with pytest.raises(ImuLogError, match=r"p\.csv: the IMU log lasts 0\.5 s; expected at least"):
        require_overlap(np.arange(0.0, 20.0, 0.05), imu_short, -5, 5, min_overlap=1.0)
