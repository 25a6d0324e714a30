"""Measure scan-matching libraries on the same synthetic 2-D laser drive (docs/ground-truth.md).

Usage: ``python benchmarks/compare_scan_matchers.py``. Candidates not installed are skipped
(``pip install small_gicp kiss-icp simpleicp open3d``). Prints, per library, the median and 95th
percentile of the per-pair translation (mm) and rotation (deg) error against the simulator's true
relative motion, and the time per scan pair (ms).
"""

from __future__ import annotations

import contextlib
import io
import itertools
import math
import time
from collections.abc import Callable

import numpy as np

from odolab.sim.laser import simulate_laser_drive

Pair = tuple[float, float, float]


def lift(r: np.ndarray, angles: np.ndarray, two_layers: bool) -> np.ndarray:
    ok = np.isfinite(r)
    pts = np.column_stack(
        (r[ok] * np.cos(angles[ok]), r[ok] * np.sin(angles[ok]), np.zeros(ok.sum()))
    )
    if two_layers:
        top = pts.copy()
        top[:, 2] = 0.1
        pts = np.vstack((pts, top))
    return pts


def to_xyyaw(T: np.ndarray) -> Pair:
    return float(T[0, 3]), float(T[1, 3]), math.atan2(T[1, 0], T[0, 0])


def rel_truth(p: np.ndarray) -> np.ndarray:
    d = p[1:] - p[:-1]
    c, s = np.cos(p[:-1, 2]), np.sin(p[:-1, 2])
    return np.column_stack((c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1], d[:, 2]))


def small_gicp_matcher(kind: str, two_layers: bool) -> Callable[[list[np.ndarray]], list[Pair]]:
    import small_gicp

    def run(clouds: list[np.ndarray]) -> list[Pair]:
        out = []
        for a, b in itertools.pairwise(clouds):
            res = small_gicp.align(
                a,
                b,
                registration_type=kind,
                downsampling_resolution=0.05,
                max_correspondence_distance=0.5,
                max_iterations=50,
            )
            out.append(to_xyyaw(res.T_target_source))
        return out

    return run


def kiss_icp_matcher(two_layers: bool) -> Callable[[list[np.ndarray]], list[Pair]]:
    from kiss_icp.config import KISSConfig
    from kiss_icp.kiss_icp import KissICP

    def run(clouds: list[np.ndarray]) -> list[Pair]:
        cfg = KISSConfig()
        cfg.data.deskew = False
        cfg.data.max_range = 30.0
        cfg.data.min_range = 0.0
        cfg.mapping.voxel_size = 0.05
        odo = KissICP(cfg)
        poses = []
        for c in clouds:
            odo.register_frame(c, np.zeros(len(c)))
            poses.append(odo.last_pose.copy())
        return [to_xyyaw(np.linalg.inv(p0) @ p1) for p0, p1 in itertools.pairwise(poses)]

    return run


def simpleicp_matcher() -> Callable[[list[np.ndarray]], list[Pair]]:
    from simpleicp import PointCloud, SimpleICP

    def run(clouds: list[np.ndarray]) -> list[Pair]:
        out = []
        for a, b in itertools.pairwise(clouds):
            icp = SimpleICP()
            icp.add_point_clouds(
                PointCloud(a, columns=["x", "y", "z"]), PointCloud(b, columns=["x", "y", "z"])
            )
            with contextlib.redirect_stdout(io.StringIO()):
                H, *_ = icp.run(
                    max_overlap_distance=0.5,
                    rbp_observation_weights=(math.inf, math.inf, 0, 0, 0, math.inf),
                )
            out.append(to_xyyaw(H))  # H maps the moving (newer) cloud onto the fixed one
        return out

    return run


def open3d_matcher(p2plane: bool) -> Callable[[list[np.ndarray]], list[Pair]]:
    import open3d as o3d

    reg = o3d.pipelines.registration

    def cloud(p: np.ndarray) -> object:
        pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(p))
        if p2plane:
            pc.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=0.2, max_nn=10))
        return pc

    def run(clouds: list[np.ndarray]) -> list[Pair]:
        out = []
        est = (
            reg.TransformationEstimationPointToPlane()
            if p2plane
            else reg.TransformationEstimationPointToPoint()
        )
        crit = reg.ICPConvergenceCriteria(max_iteration=50)
        for a, b in itertools.pairwise(clouds):
            res = reg.registration_icp(cloud(b), cloud(a), 0.5, np.eye(4), est, crit)
            out.append(to_xyyaw(np.asarray(res.transformation)))
        return out

    return run


def main() -> None:
    drive = simulate_laser_drive(seed=3)
    truth = rel_truth(drive.sensor)
    angles = drive.laser.angles
    candidates: list[tuple[str, Callable[[], Callable[[list[np.ndarray]], list[Pair]]], bool]] = [
        ("small_gicp GICP (z=0 and 0.1)", lambda: small_gicp_matcher("GICP", True), True),
        ("small_gicp GICP (z=0)", lambda: small_gicp_matcher("GICP", False), False),
        ("small_gicp ICP point-to-point (z=0)", lambda: small_gicp_matcher("ICP", False), False),
        ("small_gicp PLANE_ICP (z=0 and 0.1)", lambda: small_gicp_matcher("PLANE_ICP", True), True),
        ("kiss-icp (scan-to-map, z=0)", lambda: kiss_icp_matcher(False), False),
        ("kiss-icp (scan-to-map, z=0 and 0.1)", lambda: kiss_icp_matcher(True), True),
        ("simpleicp (point-to-plane, z=0 and 0.1)", simpleicp_matcher, True),
        ("open3d point-to-point (z=0)", lambda: open3d_matcher(False), False),
        ("open3d point-to-plane (z=0 and 0.1)", lambda: open3d_matcher(True), True),
    ]
    n = len(truth)
    print(
        f"{n} scan pairs, {drive.laser.beams} beams, range noise {drive.laser.range_sigma} m, "
        f"median true step {np.median(np.hypot(truth[:, 0], truth[:, 1])) * 1000:.0f} mm, "
        f"{np.degrees(np.median(np.abs(truth[:, 2]))):.1f} deg"
    )
    print(
        f"{'library':42s} {'dxy med':>8s} {'dxy p95':>8s} {'dyaw med':>9s} {'dyaw p95':>9s} {'ms/pair':>8s}"
    )
    for name, make, two in candidates:
        try:
            run = make()
        except ImportError as err:
            print(f"{name:42s} not installed ({err})")
            continue
        clouds = [lift(r, angles, two) for r in drive.ranges]
        t0 = time.perf_counter()
        try:
            est = np.array(run(clouds))
        except Exception as err:  # a candidate that fails on this data is a result too
            print(f"{name:42s} failed: {type(err).__name__}: {err}")
            continue
        ms = (time.perf_counter() - t0) / n * 1000
        exy = np.hypot(est[:, 0] - truth[:, 0], est[:, 1] - truth[:, 1]) * 1000
        eyaw = np.degrees(np.abs(np.angle(np.exp(1j * (est[:, 2] - truth[:, 2])))))
        print(
            f"{name:42s} {np.median(exy):8.2f} {np.percentile(exy, 95):8.2f} "
            f"{np.median(eyaw):9.3f} {np.percentile(eyaw, 95):9.3f} {ms:8.2f}"
        )


if __name__ == "__main__":
    main()
