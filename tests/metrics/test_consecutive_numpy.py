"""The numpy choice of consecutive RPE pairs (by metres, by angle) is the compiled loop's,
index for index, where running sums land exactly on the step and where they round."""

from __future__ import annotations

import numpy as np
import pytest

from odolab.metrics import pose_error as pe


def _paths() -> list[tuple[np.ndarray, np.ndarray, float]]:
    rng = np.random.default_rng(11)
    out = []
    for n, delta in ((2, 0.5), (10, 1.0), (1000, 0.3), (5000, 0.1), (20_000, 2.5)):
        x = np.cumsum(rng.uniform(0.0, 0.05, n))
        y = np.cumsum(rng.normal(0.0, 0.02, n))
        out.append((x, y, delta))
    k = np.arange(200, dtype=np.float64)
    out.append((0.1 * k, np.zeros(200), 0.3))  # 0.1 + 0.1 + 0.1 < 0.3 in floating point
    out.append((k, np.zeros(200), 1.0))  # every step exactly delta
    out.append((np.zeros(50), np.zeros(50), 1.0))  # standing still: only pose 0
    out.append((np.repeat(k[:20], 5), np.zeros(100), 2.0))  # repeated poses (zero steps)
    return out


@pytest.mark.parametrize("case", range(9))
def test_by_path_equals_the_kernel(case: int) -> None:
    x, y, delta = _paths()[case]
    want = pe.consecutive_by_path_from(x, y, delta, 0.0, True)[0]
    got = pe._consecutive_by_path(x, y, delta)
    np.testing.assert_array_equal(got, want)
    assert got.dtype == np.int64


def test_by_angle_equals_the_kernel() -> None:
    rng = np.random.default_rng(5)
    heading = np.cumsum(rng.normal(0.0, 0.05, 30_000))
    steps = np.concatenate((np.zeros(1), np.abs(pe.wrap_angle(np.diff(heading)))))
    assert pe._consecutive(steps[1:], 0.01) is None  # ~120,000 pairs: the kernel's
    for rad in (0.1, np.radians(10.0), 1.0):
        want = pe.consecutive_by_steps_from(steps, rad, 0.0, True)[0]
        got = pe._consecutive(steps[1:], rad)
        assert got is not None
        np.testing.assert_array_equal(got, want)


def test_a_path_with_too_many_pairs_is_left_to_the_kernel() -> None:
    x = np.arange(100_000, dtype=np.float64)
    assert pe._consecutive(np.diff(x), 1.0) is None  # 99,999 pairs expected
    np.testing.assert_array_equal(
        pe._consecutive_by_path(x, np.zeros_like(x), 1.0), np.arange(100_000)
    )
