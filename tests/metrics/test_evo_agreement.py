"""APE, RPE, association and alignment agree with evo (the reference implementation) to 1e-9."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from metrics_drives import random_drive

from odolab.core.trajectory import Trajectory
from odolab.metrics import (
    Alignment,
    DeltaUnit,
    EvaluationOptions,
    SyncMethod,
    associate,
    evaluate,
)

evo_metrics = pytest.importorskip("evo.core.metrics")
from evo.core import sync as evo_sync  # noqa: E402
from evo.core.trajectory import PoseTrajectory3D  # noqa: E402
from evo.core.units import Unit  # noqa: E402

STATS = ("rmse", "mean", "median", "std", "min", "max")


def to_evo(traj: Trajectory) -> PoseTrajectory3D:
    xyz = np.column_stack((traj.x, traj.y, np.zeros(len(traj))))
    half = 0.5 * traj.heading
    z = np.zeros(len(traj))
    quat_wxyz = np.column_stack((np.cos(half), z, z, np.sin(half)))
    return PoseTrajectory3D(xyz, quat_wxyz, traj.t.copy())


def evo_rpe(ref, est, relation, delta, unit, all_pairs, from_ref=False):  # type: ignore[no-untyped-def]
    m = evo_metrics.RPE(
        relation, delta=delta, delta_unit=unit, all_pairs=all_pairs, pairs_from_reference=from_ref
    )
    m.process_data((ref, est))
    return m.get_all_statistics()


def evo_ape(ref, est, relation):  # type: ignore[no-untyped-def]
    m = evo_metrics.APE(relation)
    m.process_data((ref, est))
    return m.get_all_statistics()


def assert_stats(ours: object, theirs: dict[str, float]) -> None:
    for key in STATS:
        assert getattr(ours, key) == pytest.approx(theirs[key], abs=1e-9, rel=0), key


CASES = [
    (1.0, DeltaUnit.FRAMES, False),
    (7.0, DeltaUnit.FRAMES, False),
    (7.0, DeltaUnit.FRAMES, True),
    (0.5, DeltaUnit.METRES, False),
    (2.0, DeltaUnit.METRES, False),
    (0.5, DeltaUnit.METRES, True),
    (1.3, DeltaUnit.METRES, True),
]


@pytest.mark.parametrize(("delta", "unit", "all_pairs"), CASES)
@pytest.mark.parametrize("from_ref", [False, True])
def test_rpe_matches_evo(
    drive_pair: tuple[Trajectory, Trajectory],
    delta: float,
    unit: DeltaUnit,
    all_pairs: bool,
    from_ref: bool,
) -> None:
    ref, est = drive_pair
    opts = EvaluationOptions(
        delta=delta, delta_unit=unit, all_pairs=all_pairs, pairs_from_reference=from_ref
    )
    ours = evaluate(ref, est, opts)
    evo_unit = Unit.frames if unit is DeltaUnit.FRAMES else Unit.meters
    eref, eest = to_evo(ref), to_evo(est)
    d = int(delta) if unit is DeltaUnit.FRAMES else delta
    R = evo_metrics.PoseRelation
    theirs_t = evo_rpe(eref, eest, R.translation_part, d, evo_unit, all_pairs, from_ref)
    theirs_r = evo_rpe(eref, eest, R.rotation_angle_rad, d, evo_unit, all_pairs, from_ref)
    assert_stats(ours.rpe, theirs_t)
    assert_stats(ours.rpe_rot, theirs_r)
    m = evo_metrics.RPE(
        R.translation_part,
        delta=d,
        delta_unit=evo_unit,
        all_pairs=all_pairs,
        pairs_from_reference=from_ref,
    )
    m.process_data((eref, eest))
    assert ours.rpe.n == len(m.error)


def test_ape_matches_evo(drive_pair: tuple[Trajectory, Trajectory]) -> None:
    ref, est = drive_pair
    ours = evaluate(ref, est)
    R = evo_metrics.PoseRelation
    assert_stats(ours.ape, evo_ape(to_evo(ref), to_evo(est), R.translation_part))
    assert_stats(ours.ape_rot, evo_ape(to_evo(ref), to_evo(est), R.rotation_angle_rad))


def test_ape_after_se2_alignment_matches_evo_umeyama(
    drive_pair: tuple[Trajectory, Trajectory],
) -> None:
    ref, est = drive_pair
    ours = evaluate(ref, est, EvaluationOptions(alignment=Alignment.SE2))
    eref, eest = to_evo(ref), to_evo(est)
    eest.align(eref)
    R = evo_metrics.PoseRelation
    assert_stats(ours.ape, evo_ape(eref, eest, R.translation_part))
    assert_stats(ours.ape_rot, evo_ape(eref, eest, R.rotation_angle_rad))


def test_ape_after_origin_alignment_matches_evo(
    drive_pair: tuple[Trajectory, Trajectory],
) -> None:
    ref, est = drive_pair
    shifted = Trajectory.from_xyh(est.t, est.x + 3.0, est.y - 1.0, est.heading + 0.7)
    ours = evaluate(ref, shifted, EvaluationOptions(alignment=Alignment.ORIGIN))
    eref, eest = to_evo(ref), to_evo(shifted)
    eest.align_origin(eref)
    R = evo_metrics.PoseRelation
    assert_stats(ours.ape, evo_ape(eref, eest, R.translation_part))
    assert_stats(ours.ape_rot, evo_ape(eref, eest, R.rotation_angle_rad))


@pytest.mark.parametrize("method", [SyncMethod.NEAREST, SyncMethod.INTERPOLATE])
def test_association_matches_evo(method: SyncMethod) -> None:
    ref = random_drive(400, seed=5, dt=0.05)
    rng = np.random.default_rng(6)
    t_est = np.sort(1.0 + rng.uniform(0.0, 25.0, 900))
    dense = random_drive(900, seed=7)
    est = Trajectory.from_xyh(t_est, dense.x, dense.y, dense.heading)
    ours_ref, ours_est = associate(ref, est, method=method, max_diff=0.02)
    evo_method = (
        evo_sync.SyncMethod.interpolation
        if method is SyncMethod.INTERPOLATE
        else evo_sync.SyncMethod.nearest_time
    )
    eref, eest = evo_sync.associate_trajectories(
        to_evo(ref), to_evo(est), sync_method=evo_method, max_diff=0.02
    )
    np.testing.assert_array_equal(ours_ref.t, eref.timestamps)
    np.testing.assert_allclose(ours_est.t, eest.timestamps, atol=1e-12)
    np.testing.assert_allclose(ours_est.x, eest.positions_xyz[:, 0], atol=1e-9)
    np.testing.assert_allclose(ours_est.y, eest.positions_xyz[:, 1], atol=1e-9)
    R = evo_metrics.PoseRelation
    ours = evaluate(ref, est, EvaluationOptions(sync=method, max_diff=0.02, delta=3))
    assert_stats(ours.ape, evo_ape(copy.deepcopy(eref), eest, R.translation_part))
    assert_stats(ours.ape_rot, evo_ape(eref, eest, R.rotation_angle_rad))
    assert_stats(ours.rpe, evo_rpe(eref, eest, R.translation_part, 3, Unit.frames, False))
    assert_stats(ours.rpe_rot, evo_rpe(eref, eest, R.rotation_angle_rad, 3, Unit.frames, False))
