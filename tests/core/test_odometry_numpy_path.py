"""A short log is integrated in numpy (no compiled kernel to load, issue 28's start-up goal); a
long one by the compiled passes. The two must give the same poses (to 1e-12) and the same
errors, for every model kind, both methods, rollover, start poses and fractional increments."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import odolab.core.odometry as odo
from odolab.core.errors import EncoderJumpError, LogFormatError
from odolab.core.models import DIFF_DRIVE, ExtendedDiffDrive, IcrModel, KinematicModel
from odolab.core.models.slip import SlipModel
from odolab.core.odometry import integrate, integrate_increments
from odolab.core.params import PRESETS
from odolab.core.trajectory import Trajectory

NOMINAL = PRESETS["jaguar-lite"]
MODELS: list[KinematicModel] = [
    DIFF_DRIVE,
    ExtendedDiffDrive(0.97, 1.02, 1.08),
    IcrModel(0.33, -0.25, 0.06),  # sideways motion: the lateral passes
    SlipModel(fwd_v=-0.05, fwd_v_absv=-0.2, lat_w_absv=0.03, yaw_w=-0.2),
]


def _both(monkeypatch: pytest.MonkeyPatch, run: object) -> tuple[Trajectory, Trajectory]:
    """``run()`` in numpy (no log is long enough for the kernels) and compiled (every log is)."""
    assert callable(run)
    monkeypatch.setattr(odo, "NUMPY_MAX_SAMPLES", 10**12)
    plain = run()
    monkeypatch.setattr(odo, "NUMPY_MAX_SAMPLES", 0)
    compiled = run()
    monkeypatch.undo()
    return plain, compiled


def _same(a: Trajectory, b: Trajectory) -> None:
    np.testing.assert_array_equal(a.t, b.t)
    for name in ("x", "y", "theta", "heading"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-14, atol=1e-12)


def test_short_log_takes_numpy_and_long_log_the_kernels() -> None:
    assert not odo._use_kernels(odo.NUMPY_MAX_SAMPLES - 1)
    assert odo._use_kernels(odo.NUMPY_MAX_SAMPLES)


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(0, 300),
    model=st.sampled_from(range(len(MODELS))),
    method=st.sampled_from(["midpoint", "arc"]),
    modulus=st.sampled_from([None, 1024, 32768]),
    start=st.sampled_from([None, (1.5, -2.0, 3.0), (0.0, 0.0, -7.0)]),
)
def test_numpy_equals_kernels_from_ticks(
    seed: int,
    n: int,
    model: int,
    method: str,
    modulus: int | None,
    start: tuple[float, float, float] | None,
) -> None:
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.0, 0.06, n))
    left = np.cumsum(rng.integers(-100, 100, n)) + int(rng.integers(0, 2**20))
    right = np.cumsum(rng.integers(-100, 100, n)) + int(rng.integers(0, 2**20))
    if modulus is not None:
        left, right = left % modulus, right % modulus
    params = NOMINAL.with_(model=MODELS[model], encoder_modulus=modulus)
    with pytest.MonkeyPatch.context() as mp:
        a, b = _both(mp, lambda: integrate(t, left, right, params, method, start=start))
    _same(a, b)


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(0, 300),
    model=st.sampled_from(range(len(MODELS))),
    method=st.sampled_from(["midpoint", "arc"]),
)
def test_numpy_equals_kernels_from_increments(seed: int, n: int, model: int, method: str) -> None:
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.0, 0.06, n))
    dl, dr = rng.normal(10.0, 40.0, n), rng.normal(10.0, 40.0, n)  # fractional counts
    params = NOMINAL.with_(model=MODELS[model])
    with pytest.MonkeyPatch.context() as mp:
        a, b = _both(
            mp, lambda: integrate_increments(t, dl, dr, params, method, start=(0.1, 0.2, 0.3))
        )
    _same(a, b)


def test_numpy_path_gives_hand_computed_poses() -> None:
    """One count per metre-ish: a straight step, then a turn in place (midpoint rule)."""
    p = NOMINAL.with_(encoder_modulus=None)
    k = p.left_metres_per_tick
    t = np.array([0.0, 0.1, 0.2])
    left = np.array([0, 100, 100 - 50])
    right = np.array([0, 100, 100 + 50])
    traj = integrate(t, left, right, p)  # three samples: the numpy path
    dth = 100 * k / p.track_width
    assert traj.x[1] == pytest.approx(100 * k, abs=1e-15)
    assert traj.y[1] == 0.0
    assert traj.heading[2] == pytest.approx(dth, abs=1e-15)
    assert traj.x[2] == pytest.approx(100 * k, abs=1e-15)  # turning in place moves nothing


@pytest.mark.parametrize(
    ("t", "left", "right", "error", "where"),
    [
        ([0.0, 0.1, 0.2, 0.3], [0, 10, 9000, 9010], [0, 10, 20, 30], EncoderJumpError, "left"),
        ([0.0, 0.1, 0.2, 0.3], [0, 10, 20, 30], [0, 10, 9000, 9010], EncoderJumpError, "right"),
        ([0.0, 0.1, 0.05, 0.3], [0, 10, 9000, 9010], [0, 10, 20, 30], LogFormatError, "t"),
        ([0.0, 0.1, np.nan, 0.3], [0, 10, 20, 9000], [0, 10, 20, 30], LogFormatError, "t"),
        ([0.0, 0.1, 0.2, 0.15], [0, 10, 9000, 9010], [0, 10, 20, 30], EncoderJumpError, "left"),
        ([0.0, 0.1, 0.2, 0.3], [0, 10, 9000, 9010], [0, 10, 9000, 9010], EncoderJumpError, "left"),
    ],
)
def test_numpy_and_kernels_raise_the_same_first_error(
    t: list[float], left: list[int], right: list[int], error: type[Exception], where: str
) -> None:
    p = NOMINAL.with_(encoder_modulus=32768)
    messages = []
    for limit in (10**12, 0):
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(odo, "NUMPY_MAX_SAMPLES", limit)
            with pytest.raises(error) as info:
                integrate(np.array(t), np.array(left), np.array(right), p)
        messages.append(str(info.value))
    assert messages[0] == messages[1]
    if where != "t":
        assert f"{where}_ticks jumps by 8990 counts between samples 1 and 2" in messages[0]
