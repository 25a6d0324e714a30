"""Hand-computed APE/RPE/drift values, association errors and invariants."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from metrics_drives import noisy_copy, random_drive

from odolab.core.errors import InsufficientDataError
from odolab.core.trajectory import Trajectory
from odolab.metrics import (
    Alignment,
    DeltaUnit,
    EvaluationOptions,
    Rigid2D,
    SyncMethod,
    associate,
    drift_per_distance,
    evaluate,
    pair_indices,
    rpe_errors,
    stats_from_errors,
    transform_trajectory,
)


def test_stats_by_hand() -> None:
    s = stats_from_errors(np.array([3.0, 4.0, 0.0, 1.0]))
    assert s.rmse == pytest.approx(math.sqrt(26 / 4))
    assert (s.mean, s.median, s.min, s.max, s.n) == (2.0, 2.0, 0.0, 4.0, 4)
    assert s.std == pytest.approx(math.sqrt(2.5))
    with pytest.raises(InsufficientDataError):
        stats_from_errors(np.array([]))


def test_rpe_by_hand() -> None:
    # reference: 1 m straight along x; estimate: turned 90 deg at the start, then 1 m along y
    ref = Trajectory.from_xyh([0, 1], [0, 1], [0, 0], [0, 0])
    est = Trajectory.from_xyh([0, 1], [0, 0], [0, 1], [math.pi / 2, math.pi / 2 + 0.1])
    t, r = rpe_errors(ref, est, np.array([0]), np.array([1]))
    # in its own start frame the estimate also moved 1 m forward: no translation error
    assert t[0] == pytest.approx(0.0, abs=1e-15)
    assert r[0] == pytest.approx(0.1)


def test_metres_pairs_by_hand() -> None:
    x = 0.35 * np.arange(7.0)
    tr = Trajectory.from_xyh(np.arange(7.0), x, np.zeros(7), np.zeros(7))
    i, j = pair_indices(tr, 1.0, DeltaUnit.METRES)
    np.testing.assert_array_equal(np.column_stack((i, j)), [[0, 3], [3, 6]])
    i, j = pair_indices(tr, 1.0, DeltaUnit.METRES, all_pairs=True, rel_tol=0.25)
    # nearest to 1 m is 1.05 m (3 steps) where the path is long enough; 0.7 m is off by > 0.25
    np.testing.assert_array_equal(j - i, [3, 3, 3, 3])
    with pytest.raises(InsufficientDataError, match="gives no pose pairs"):
        pair_indices(tr, 10.0, DeltaUnit.METRES)


def test_drift_by_hand() -> None:
    # estimate runs 2 % long on a straight 10 m line
    n = 101
    x = np.linspace(0.0, 10.0, n)
    ref = Trajectory.from_xyh(np.arange(n), x, np.zeros(n), np.zeros(n))
    est = Trajectory.from_xyh(np.arange(n), 1.02 * x, np.zeros(n), np.zeros(n))
    d = drift_per_distance(ref, est, 1.0)
    assert d.translation_pct == pytest.approx(2.0)
    assert d.rotation_deg_per_m == pytest.approx(0.0)
    assert d.endpoint_error == pytest.approx(0.2)
    assert d.endpoint_pct == pytest.approx(2.0)
    assert d.path_length == pytest.approx(10.0)


def test_trajectories_that_do_not_overlap_in_time() -> None:
    a = random_drive(50, seed=1, t0=0.0)
    b = random_drive(50, seed=2, t0=100.0)
    with pytest.raises(InsufficientDataError) as err:
        evaluate(a, b)
    assert "do not overlap in time" in str(err.value)
    assert "(0..2.45 s)" in str(err.value) and "(100..102.45 s)" in str(err.value)


def test_overlap_without_matching_stamps_suggests_interpolation() -> None:
    a = random_drive(50, seed=1, dt=0.1)
    b = random_drive(50, seed=2, t0=0.05, dt=0.1)
    with pytest.raises(InsufficientDataError, match="use interpolation"):
        associate(a, b, max_diff=0.01)
    ra, rb = associate(a, b, method=SyncMethod.INTERPOLATE, max_diff=0.06)
    np.testing.assert_array_equal(ra.t, rb.t)


def test_interpolation_by_hand() -> None:
    ref = Trajectory.from_xyh([0.0, 1.0, 2.0], [0, 1, 2], [0, 0, 2], [0, 1, 3])
    est = Trajectory.from_xyh([0.5, 1.5], [9, 9], [9, 9], [0, 0])
    r, _ = associate(ref, est, method=SyncMethod.INTERPOLATE, max_diff=0.5)
    np.testing.assert_allclose(r.x, [0.5, 1.5])
    np.testing.assert_allclose(r.y, [0.0, 1.0])
    np.testing.assert_allclose(r.heading, [0.5, 2.0])


angles = st.floats(-math.pi, math.pi)
offsets = st.floats(-50.0, 50.0)


@given(angles, offsets, offsets, st.integers(0, 10_000))
def test_rpe_and_aligned_ape_ignore_a_rigid_motion(
    a: float, tx: float, ty: float, seed: int
) -> None:
    ref = random_drive(120, seed=seed)
    est = noisy_copy(ref, seed=seed + 1)
    moved = transform_trajectory(est, Rigid2D(a, tx, ty))
    opts = EvaluationOptions(delta=5)
    base = evaluate(ref, est, opts)
    ev = evaluate(ref, moved, opts)
    assert ev.rpe.rmse == pytest.approx(base.rpe.rmse, abs=1e-9)
    assert ev.rpe_rot.rmse == pytest.approx(base.rpe_rot.rmse, abs=1e-9)
    for how in (Alignment.SE2, Alignment.ORIGIN):
        o2 = EvaluationOptions(delta=5, alignment=how)
        assert evaluate(ref, moved, o2).ape.rmse == pytest.approx(
            evaluate(ref, est, o2).ape.rmse, abs=1e-7
        )


@given(st.integers(0, 10_000))
def test_identical_trajectories_have_no_error(seed: int) -> None:
    ref = random_drive(80, seed=seed)
    ev = evaluate(
        ref, ref, EvaluationOptions(delta=0.3, delta_unit=DeltaUnit.METRES, all_pairs=True)
    )
    assert ev.ape.max == 0.0 and ev.rpe.max < 1e-12 and ev.rpe_rot.max < 1e-12


def test_se2_alignment_onto_one_point_is_refused_not_fitted_to_rounding() -> None:
    # three estimate poses that all match one reference pose (its nearest stamp): the
    # reference positions coincide, their centred values are rounding (~1e-16), and the angle
    # fitted to those would be noise
    from odolab.metrics.alignment import rigid_from_points

    est = np.array([[0.2157, 0.2085], [0.4721, 0.3642], [0.7721, 0.3603]])
    ref = np.tile([0.21573863836708154, 0.20846304208544403], (3, 1))
    ref[1] += np.spacing(ref[1])  # one unit of rounding apart: still one point
    with pytest.raises(InsufficientDataError, match="do not spread out"):
        rigid_from_points(est, ref)
    with pytest.raises(InsufficientDataError, match="do not spread out"):
        rigid_from_points(ref, est)
    # a spread of a micrometre at a kilometre from the origin is still a spread
    far = est * 1e-3 + 1000.0
    assert math.isfinite(rigid_from_points(far, far[::-1].copy()).angle)


@given(
    st.lists(
        st.floats(
            allow_nan=False, allow_infinity=False, width=64, min_value=-1e300, max_value=1e300
        ),
        min_size=1,
        max_size=60,
    )
)
def test_median_is_numpys_to_the_bit(values: list[float]) -> None:
    from odolab.metrics.pose_error import median

    a = np.array(values)
    assert median(a) == float(np.median(a))


def test_median_of_nan_is_nan_and_of_nothing_a_sentence() -> None:
    from odolab.core.errors import InsufficientDataError
    from odolab.metrics.pose_error import median

    assert np.isnan(median(np.array([1.0, np.nan, 2.0])))
    assert median(np.array([3.0, -np.inf, np.inf, 1.0])) == float(
        np.median([3.0, -np.inf, np.inf, 1.0])
    )
    with pytest.raises(InsufficientDataError, match="no values"):
        median(np.array([]))
