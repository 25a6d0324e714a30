"""Which scan matcher for laser scans -> relative motions (issue 15, laser path)? A measurement.

A 270 degree laser (541 beams, 10 m, range noise 1 cm) on the virtual robot (sensor at
(0.20, -0.05) m, 0.3 rad) drives the calibration drive in a 10 x 8 m room with a few boxes; scans
at 10 Hz, consecutive scans matched. For each candidate library that is installed: the RMS error
of the relative motions (x, y in mm; theta in degrees) against the truth and the time per match.
Candidates are not odolab dependencies; install them to measure (pip install small_gicp kiss-icp).

    .venv/bin/python benchmarks/bench_scan_matching.py
"""

from __future__ import annotations

import importlib.util
import math
import time
from collections.abc import Callable

import numpy as np

from odolab.calibration.sensor import relative_motions
from odolab.params import PRESETS
from odolab.sim.drives import calibration_drive, record_drive
from odolab.sim.physics import TrueParams

WALLS = np.array(
    [
        [-5, -4, 5, -4], [5, -4, 5, 4], [5, 4, -5, 4], [-5, 4, -5, -4],
        [1, 1, 2, 1], [2, 1, 2, 1.5], [2, 1.5, 1, 1.5], [1, 1.5, 1, 1],
        [-3, -2, -2.2, -2.6], [-3.5, 2.5, -2.5, 3.2], [3, -3, 3.8, -2.2],
    ],
    dtype=float,
)  # fmt: skip


def scan(x: float, y: float, h: float, rng: np.random.Generator) -> np.ndarray:
    """Points (k, 3) of one 270 degree scan in the sensor frame, range noise 1 cm."""
    a = np.radians(np.linspace(-135, 135, 541))
    d = np.column_stack((np.cos(a + h), np.sin(a + h)))
    p, q = WALLS[:, :2], WALLS[:, 2:]
    e = q - p
    den = d[:, None, 0] * e[None, :, 1] - d[:, None, 1] * e[None, :, 0]
    w = p[None] - np.array([x, y])[None, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (w[..., 0] * e[None, :, 1] - w[..., 1] * e[None, :, 0]) / den
        u = (w[..., 0] * d[:, None, 1] - w[..., 1] * d[:, None, 0]) / den
    ok = (t > 0) & (u >= 0) & (u <= 1)
    r = np.where(ok, t, np.inf).min(axis=1)
    keep = r < 10
    r = r[keep] + rng.normal(0, 0.01, keep.sum())
    return np.column_stack((r * np.cos(a[keep]), r * np.sin(a[keep]), np.zeros(keep.sum())))


def se2(m: np.ndarray) -> tuple[float, float, float]:
    return float(m[0, 3]), float(m[1, 3]), math.atan2(m[1, 0], m[0, 0])


def small_gicp_matcher(
    kind: str, extrude: bool = False
) -> Callable[[np.ndarray, np.ndarray], tuple[float, float, float]]:
    import small_gicp

    from odolab.io.laserscan import _extruded

    def match(prev: np.ndarray, cur: np.ndarray) -> tuple[float, float, float]:
        if extrude:  # planar points as walls: proper normals (odolab's choice)
            prev, cur = _extruded(prev[:, :2], 0.01), _extruded(cur[:, :2], 0.01)
        r = small_gicp.align(
            prev, cur, registration_type=kind, downsampling_resolution=0.01,
            max_correspondence_distance=0.5, max_iterations=50,
        )  # fmt: skip
        return se2(r.T_target_source)

    return match


def kiss_icp_matcher() -> Callable[[np.ndarray, np.ndarray], tuple[float, float, float]]:
    from kiss_icp.config import load_config
    from kiss_icp.kiss_icp import KissICP

    cfg = load_config(None)
    cfg.data.max_range = 10.0
    cfg.data.deskew = False
    cfg.data.min_range = 0.0
    cfg.mapping.voxel_size = 0.05
    odom = KissICP(cfg)
    state: dict[str, np.ndarray] = {}

    def match(prev: np.ndarray, cur: np.ndarray) -> tuple[float, float, float]:
        if "last" not in state:
            odom.register_frame(prev, np.zeros(len(prev)))
            state["last"] = odom.last_pose.copy()
        odom.register_frame(cur, np.zeros(len(cur)))
        rel = np.linalg.inv(state["last"]) @ odom.last_pose
        state["last"] = odom.last_pose.copy()
        return se2(rel)

    return match


def main() -> None:
    nominal = PRESETS["jaguar-lite"]
    drive = record_drive(
        TrueParams(0.085, 0.085, 0.082, 0.082, 0.6), nominal, calibration_drive(), rate=10
    )
    tr = drive.truth
    c, s = np.cos(tr.heading), np.sin(tr.heading)
    lx, ly, lth = 0.20, -0.05, 0.3
    sx, sy, sh = tr.x + c * lx - s * ly - 1.0, tr.y + s * lx + c * ly - 0.5, tr.heading + lth
    rng = np.random.default_rng(0)
    scans = [scan(sx[i], sy[i], sh[i], rng) for i in range(tr.t.size)]
    idx = np.arange(tr.t.size - 1)
    true = relative_motions(sx, sy, sh, idx, idx + 1)
    candidates: dict[
        str, Callable[[], Callable[[np.ndarray, np.ndarray], tuple[float, float, float]]]
    ] = {}
    if importlib.util.find_spec("small_gicp"):
        for kind in ("ICP", "PLANE_ICP", "GICP"):
            candidates[f"small_gicp {kind}"] = lambda kind=kind: small_gicp_matcher(kind)
            candidates[f"small_gicp {kind} walls"] = lambda kind=kind: small_gicp_matcher(
                kind, extrude=True
            )
    if importlib.util.find_spec("kiss_icp"):
        candidates["kiss-icp"] = kiss_icp_matcher
    print(f"{len(scans)} scans, {np.mean([len(p) for p in scans]):.0f} points each")
    for name, make in candidates.items():
        match = make()
        t0 = time.perf_counter()
        got = np.array([match(scans[i], scans[i + 1]) for i in idx])
        took = (time.perf_counter() - t0) / idx.size
        err = got - true
        err[:, 2] = np.remainder(err[:, 2] + math.pi, 2 * math.pi) - math.pi
        rms = np.sqrt(np.mean(err**2, axis=0))
        turn = np.abs(true[:, 2]) > 0.05
        ratio = np.sum(got[turn, 2] * true[turn, 2]) / np.sum(true[turn, 2] ** 2)
        print(
            f"{name:22s} rotation scale {ratio:.3f}  x {rms[0] * 1000:7.2f} mm  y {rms[1] * 1000:7.2f} mm  "
            f"theta {math.degrees(rms[2]):6.3f} deg  {took * 1000:6.2f} ms/match"
        )


if __name__ == "__main__":
    main()
