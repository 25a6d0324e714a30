"""Agreement with evo on evo's own test trajectories (../shared/data/evo-testdata).

Our metrics are planar: a trajectory is (t, x, y, yaw). evo reads the same TUM files in 3-D.
Both are compared on the same planar view of each file: evo's poses (its own quaternion
normalisation) projected to (x, y, yaw = atan2(R[1,0], R[0,0])); ours read by
:func:`odolab.io.read_tum`. The files keep their quaternions to 4 decimals (|q| != 1 by up to
about 1e-4), which is what checks our yaw formula: it must hold for any quaternion length.

evo's ``align`` (3-D Umeyama without scale) is compared with our ``se2`` alignment only where
evo's rotation stays in the plane (R[2,2] = +1). On fr2_desk it does not: the planar points are
degenerate in 3-D, and Umeyama's reflection guard picks R[2,2] = -1, a rotation that mirrors the
trajectory (x, y) -> a reflection in the plane; ours is the best proper planar rotation.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from odolab.core.trajectory import Trajectory
from odolab.io import read_tum
from odolab.metrics import Alignment, DeltaUnit, EvaluationOptions, evaluate
from shared_data import data_dir, require

evo_metrics = pytest.importorskip("evo.core.metrics")
from evo.core import sync as evo_sync  # noqa: E402
from evo.core.trajectory import PoseTrajectory3D  # noqa: E402
from evo.core.units import Unit  # noqa: E402
from evo.tools import file_interface  # noqa: E402

DATA = data_dir() / "evo-testdata"
PAIRS = [
    ("freiburg1_xyz-groundtruth.txt", "freiburg1_xyz-rgbdslam.txt"),
    ("freiburg1_xyz-groundtruth.txt", "freiburg1_xyz-ORB_kf_mono.txt"),
    ("fr2_desk_groundtruth.txt", "fr2_desk_ORB.txt"),
    ("fr2_desk_groundtruth.txt", "fr2_desk_ORB_kf_mono.txt"),
]
#: the pairs on which evo's Umeyama picks a reflection of the plane (R[2,2] = -1)
MIRRORED = {
    ("freiburg1_xyz-groundtruth.txt", "freiburg1_xyz-ORB_kf_mono.txt"),
    ("fr2_desk_groundtruth.txt", "fr2_desk_ORB.txt"),
    ("fr2_desk_groundtruth.txt", "fr2_desk_ORB_kf_mono.txt"),
}
STATS = ("rmse", "mean", "median", "std", "min", "max")


@pytest.fixture(scope="module", autouse=True)
def _data() -> None:
    require("evo-testdata")


def evo_planar(path: Path) -> PoseTrajectory3D:
    """evo's reading of a TUM file, projected onto the plane (z = 0, rotation about z only)."""
    traj = file_interface.read_tum_trajectory_file(str(path))
    rot = np.array([p[:3, :3] for p in traj.poses_se3])
    yaw = np.arctan2(rot[:, 1, 0], rot[:, 0, 0])
    xyz = traj.positions_xyz.copy()
    xyz[:, 2] = 0.0
    z = np.zeros(len(yaw))
    quat = np.column_stack((np.cos(yaw / 2), z, z, np.sin(yaw / 2)))
    return PoseTrajectory3D(xyz, quat, traj.timestamps.copy())


def _yaw(traj: PoseTrajectory3D) -> np.ndarray:
    rot = np.array([p[:3, :3] for p in traj.poses_se3])
    return np.arctan2(rot[:, 1, 0], rot[:, 0, 0])


@pytest.mark.parametrize(
    "name",
    sorted({n for pair in PAIRS for n in pair}),
)
def test_yaw_from_any_quaternion_length_matches_evo(name: str) -> None:
    ours = read_tum(DATA / name)
    theirs = _yaw(file_interface.read_tum_trajectory_file(str(DATA / name)))
    d = np.angle(np.exp(1j * (ours.theta - theirs)))
    assert np.abs(d).max() < 1e-12


def test_the_data_has_quaternions_off_unit_length() -> None:
    """The premise: 4-decimal quaternions, |q| off 1 by more than 1e-5 in some file."""
    off = [
        np.abs(np.linalg.norm(np.loadtxt(DATA / n, comments="#")[:, 4:8], axis=1) - 1.0).max()
        for n in sorted({n for pair in PAIRS for n in pair})
    ]
    # measured 8.6e-05 (evo's files: no seed); bound 1e-5
    assert max(off) > 1e-5


def _stats_equal(ours: object, theirs: dict[str, float], tol: float = 1e-9) -> None:
    for key in STATS:
        assert getattr(ours, key) == pytest.approx(theirs[key], rel=tol, abs=1e-12), key


def _evo(relation: object, ref: PoseTrajectory3D, est: PoseTrajectory3D, rpe: bool) -> dict:
    m = (
        evo_metrics.RPE(relation, delta=1, delta_unit=Unit.frames)
        if rpe
        else evo_metrics.APE(relation)
    )
    m.process_data((ref, est))
    return m.get_all_statistics()


def _pair(gt: str, est: str) -> tuple[PoseTrajectory3D, PoseTrajectory3D]:
    ref, e = evo_planar(DATA / gt), evo_planar(DATA / est)
    return evo_sync.associate_trajectories(ref, e, max_diff=0.01)


@pytest.mark.parametrize(("gt", "est"), PAIRS)
def test_ape_and_rpe_match_evo_on_its_own_data(gt: str, est: str) -> None:
    ours = evaluate(read_tum(DATA / gt), read_tum(DATA / est), EvaluationOptions())
    ref, e = _pair(gt, est)
    R = evo_metrics.PoseRelation
    _stats_equal(ours.ape, _evo(R.translation_part, ref, e, rpe=False))
    _stats_equal(ours.ape_rot, _evo(R.rotation_angle_rad, ref, e, rpe=False))
    _stats_equal(ours.rpe, _evo(R.translation_part, ref, e, rpe=True))
    _stats_equal(ours.rpe_rot, _evo(R.rotation_angle_rad, ref, e, rpe=True))
    ours_o = evaluate(
        read_tum(DATA / gt), read_tum(DATA / est), EvaluationOptions(alignment=Alignment.ORIGIN)
    )
    e.align_origin(ref)
    _stats_equal(ours_o.ape, _evo(R.translation_part, ref, e, rpe=False))


@pytest.mark.parametrize(("gt", "est"), PAIRS)
def test_se2_alignment_matches_evo_umeyama_where_evo_stays_planar(gt: str, est: str) -> None:
    ours = evaluate(
        read_tum(DATA / gt), read_tum(DATA / est), EvaluationOptions(alignment=Alignment.SE2)
    )
    ref, e = _pair(gt, est)
    r, _t, _s = e.align(ref)
    R = evo_metrics.PoseRelation
    theirs = _evo(R.translation_part, ref, e, rpe=False)
    if r[2, 2] > 0:  # evo's fit is a rotation about z: the same problem as ours
        _stats_equal(ours.ape, theirs)
    else:  # evo mirrors the plane; a reflection is not a rigid planar motion
        assert (gt, est) in MIRRORED
        assert r[2, 2] == pytest.approx(-1.0)
        assert np.linalg.det(r[:2, :2]) == pytest.approx(-1.0)
        # our proper rotation cannot fit better than evo's extra freedom, and differs
        assert ours.ape.rmse >= theirs["rmse"] - 1e-12
        # measured 0.22 against 0.037, 1.60 against 0.62, 1.62 against 1.23 (evo's files: no seed)
        assert ours.ape.rmse != pytest.approx(theirs["rmse"], rel=1e-6)


def test_planar_evo_projection_is_what_we_read() -> None:
    """Same poses on both sides: positions equal, yaw equal (the premise of the tests above)."""
    gt = DATA / "fr2_desk_groundtruth.txt"
    ours: Trajectory = read_tum(gt)
    theirs = evo_planar(gt)
    assert np.array_equal(ours.x, theirs.positions_xyz[:, 0])
    assert np.array_equal(ours.y, theirs.positions_xyz[:, 1])
    assert DeltaUnit.FRAMES.value == "frames"
