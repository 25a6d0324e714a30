"""The two-thread pipeline of batch odometry (issue 42): the same poses, bit for bit, and the
same errors at the same samples, as the passes one after the other (``parallel=1``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from odolab import PRESETS, integrate
from odolab.core import _jit
from odolab.core import odometry as od
from odolab.core.errors import EncoderJumpError, OdolabError
from odolab.core.models.icr import IcrModel

pytestmark = pytest.mark.skipif(not _jit.HAVE_NUMBA, reason="the pipeline runs compiled kernels")

N = od.PIPELINE_MIN_SAMPLES + 3 * od.PIPELINE_BLOCK + 17  # several blocks and a short last one


def _log(seed: int, n: int = N, modulus: int = 32768) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    # forwards, backwards and turning, so that both counters wrap both ways
    left = np.cumsum(rng.integers(-40, 41, n) + np.where(np.arange(n) % 50_000 < 25_000, 9, -9))
    right = np.cumsum(rng.integers(-40, 41, n))
    t = np.arange(n) * 0.05
    return t, left % modulus, right % modulus


def _same(a: object, b: object) -> None:
    for name in ("t", "x", "y", "theta", "heading"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


def test_the_pipeline_is_taken_for_a_long_log_on_two_threads() -> None:
    params = PRESETS["jaguar-lite"]
    lat = np.empty(0)
    assert od._pipelines(N, lat, params, 2)
    assert not od._pipelines(N, lat, params, 1)
    assert not od._pipelines(od.PIPELINE_MIN_SAMPLES - 1, lat, params, 2)


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("method", ["midpoint", "arc"])
def test_poses_are_bit_identical_to_the_passes_in_turn(seed: int, method: str) -> None:
    params = PRESETS["jaguar-lite"]
    t, left, right = _log(seed)
    piped = integrate(t, left, right, params, method, parallel=2, start=(1.5, -2.0, 3.0))
    in_turn = integrate(t, left, right, params, method, parallel=1, start=(1.5, -2.0, 3.0))
    _same(piped, in_turn)
    assert np.ptp(piped.heading) > 2 * np.pi  # the heading went round: theta was wrapped


def test_a_counter_outside_its_range_takes_the_careful_loop_with_the_same_result() -> None:
    params = PRESETS["jaguar-lite"]
    t, left, right = _log(2)
    left = left.copy()
    left[N // 2 :] += params.encoder_modulus  # raw values past the modulus: the modulo fallback
    _same(
        integrate(t, left, right, params, parallel=2), integrate(t, left, right, params, parallel=1)
    )


@pytest.mark.parametrize("where", [0, 1, od.PIPELINE_BLOCK, od.PIPELINE_BLOCK + 1, N - 1])
@pytest.mark.parametrize("fault", ["jump", "right-jump", "nan", "backwards"])
def test_a_fault_is_refused_at_the_same_sample(where: int, fault: str) -> None:
    params = PRESETS["jaguar-lite"]
    t, left, right = (a.copy() for a in _log(3))
    if fault == "jump":
        at = max(where, 1)  # a jump needs a sample before it
        left[at:] = (left[at:] + 9000) % params.encoder_modulus
    elif fault == "right-jump":
        right[max(where, 1) :] = (right[max(where, 1) :] - 9000) % params.encoder_modulus
    elif fault == "nan":
        t[where] = np.nan
    else:
        t[where:] -= 1.0 if where else 0.0
        if where == 0:
            t[1] = -5.0
    errors = []
    for threads in (2, 1):
        with pytest.raises((EncoderJumpError, OdolabError)) as info:
            integrate(t, left, right, params, parallel=threads)
        errors.append((type(info.value), str(info.value)))
    assert errors[0] == errors[1]


def test_headings_past_the_polynomial_limit_use_libm_for_their_blocks() -> None:
    # a heading beyond SINCOS_LIMIT from the start: every block turns with libm, as in turn
    params = PRESETS["jaguar-lite"]
    t, left, right = _log(4)
    start = (0.0, 0.0, 2.0e7)
    _same(
        integrate(t, left, right, params, start=start, parallel=2),
        integrate(t, left, right, params, start=start, parallel=1),
    )


def test_an_asymmetric_model_is_pipelined_and_one_with_sideways_motion_is_not() -> None:
    base = PRESETS["jaguar-lite"]
    t, left, right = _log(5)
    skewed = replace(base, model=IcrModel(0.31, -0.26))
    _same(
        integrate(t, left, right, skewed, parallel=2), integrate(t, left, right, skewed, parallel=1)
    )
    sideways = replace(base, model=IcrModel(0.31, -0.26, x_icr=0.05))
    _, lat = od._model_arrays(sideways, N)
    assert lat.size and not od._pipelines(N, lat, sideways, 2)
    _same(
        integrate(t, left, right, sideways, parallel=2),
        integrate(t, left, right, sideways, parallel=1),
    )


def test_counter_steps_past_int32_take_the_careful_loop(monkeypatch: pytest.MonkeyPatch) -> None:
    # the vectorized phase A converts a counter step through int32: a step of 2**31 or more
    # (no modulus, no limit) must take the careful loop, and give numpy's poses
    base = PRESETS["jaguar-lite"]
    params = replace(base, encoder_modulus=None)
    n = 5000
    rng = np.random.default_rng(6)
    left = np.cumsum(rng.integers(-40, 41, n)).astype(np.int64)
    right = np.cumsum(rng.integers(-40, 41, n)).astype(np.int64)
    left[n // 2 :] += 3 * 2**31  # one step of 6.4e9 counts
    t = np.arange(n) * 0.05
    compiled = integrate(t, left, right, params, max_dticks=2**40, parallel=1)
    monkeypatch.setattr(od, "NUMPY_MAX_SAMPLES", 10**12)
    plain = integrate(t, left, right, params, max_dticks=2**40)
    for name in ("x", "y", "heading"):
        np.testing.assert_allclose(getattr(compiled, name), getattr(plain, name), rtol=1e-13)
    assert abs(compiled.heading[n // 2] - compiled.heading[n // 2 - 1]) > 1e3  # the step is in


@pytest.mark.skipif(not _jit.HAVE_NUMBA, reason="the kernels are compiled only with numba")
def test_writable_read_only_and_strided_arrays_share_one_compiled_pass() -> None:
    """A polars or pyarrow column is read-only and a column of a 2-D array strided: each was a
    signature of its own, compiled anew (2-2.5 s) the first time (issue 36)."""
    from odolab.core._odometry_kernels import _steps_from_ticks

    p = PRESETS["jaguar-lite"]
    n = 4 * od.NUMPY_MAX_SAMPLES
    t = 0.05 * np.arange(n)
    ticks = np.cumsum(np.ones(n, dtype=np.int64))

    def kinds(a: np.ndarray) -> list[np.ndarray]:  # type: ignore[type-arg]
        read_only = a.copy()
        read_only.flags.writeable = False
        return [a, read_only, np.stack([a, a], axis=1)[:, 0]]

    poses = [integrate(tt, lt, rt, p, parallel=1) for tt in kinds(t) for lt in kinds(ticks)
             for rt in kinds(ticks)[::-1]]  # fmt: skip
    assert len(_steps_from_ticks.signatures) == 1  # type: ignore[attr-defined]
    assert len(poses) == 27
    for other in poses[1:]:
        np.testing.assert_array_equal(other.x, poses[0].x)
        np.testing.assert_array_equal(other.t, t)
    assert t.flags.writeable and ticks.flags.writeable  # the caller's arrays are left as they were
    with pytest.raises(OdolabError, match="t has 1 samples"):
        integrate(5.0, [0], [0], p)  # a number is no series of times
