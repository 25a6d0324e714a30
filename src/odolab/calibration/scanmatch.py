"""Laser scans to the sensor's motion: pairwise scan matching with small_gicp's GICP.

Each 2-D scan is lifted to 3-D points twice, at z = 0 and at z = ``layer`` (GICP needs surfaces,
and a wall seen by a planar scanner is a line; two copies make it a vertical plane), downsampled on
a ``voxel`` grid, and matched to the scan ``every`` scans before it (initial guess: the previous
pair's motion, retried from no motion when that fits worse). The 3-D result is projected back to
``x, y, yaw``. Composing the pairwise motions gives the sensor's trajectory in the frame of its
first pose, stamped with the scans' stamps. Why small_gicp (measured against kiss-icp, open3d and
simpleicp): docs/ground-truth.md.

Per pair the result keeps ``fitness`` (the fraction of the newer scan's points within
``max_correspondence`` of the older scan after matching) and ``residual`` (their RMS distance, m),
so that :meth:`ScanMotions.outliers` can flag pairs that did not match.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from odolab.core.errors import CalibrationError, InsufficientDataError
from odolab.core.trajectory import Trajectory
from odolab.io.scans import LaserScans

__all__ = ["ScanMotions", "scan_motions"]

#: Fewest valid points a scan needs to be matched (fewer: the scan is skipped).
MIN_POINTS = 20


@dataclass(frozen=True, eq=False)
class ScanMotions:
    """The sensor's motion from scan matching.

    ``trajectory``: the sensor's poses at the matched scans (the first at the origin);
    ``index``: (m + 1,) which scans those are; ``motions``: (m, 3) each pair's motion
    ``dx, dy, dyaw`` in the earlier scan's frame; ``fitness``, ``residual`` (m), ``iterations``,
    ``converged``: (m,) per pair; ``skipped``: scans left out for having fewer than
    :data:`MIN_POINTS` valid ranges."""

    trajectory: Trajectory
    index: NDArray[np.int64]
    motions: NDArray[np.float64]
    fitness: NDArray[np.float64]
    residual: NDArray[np.float64]
    iterations: NDArray[np.int64]
    converged: NDArray[np.bool_]
    skipped: tuple[int, ...] = ()

    def __len__(self) -> int:
        return len(self.motions)

    def outliers(self, *, min_fitness: float = 0.8, max_residual: float = 0.1) -> NDArray[np.bool_]:
        """(m,) True for the pairs that probably did not match: too few points found a partner,
        their RMS distance is too large, or the optimiser did not converge."""
        return (self.fitness < min_fitness) | (self.residual > max_residual) | ~self.converged


def _pose_matrix(dx: float, dy: float, dyaw: float) -> NDArray[np.float64]:
    c, s = math.cos(dyaw), math.sin(dyaw)
    m = np.eye(4)
    m[0:2, 0:2] = ((c, -s), (s, c))
    m[0:2, 3] = (dx, dy)
    return m


def _to_planar(m: NDArray[np.float64]) -> tuple[float, float, float]:
    return float(m[0, 3]), float(m[1, 3]), math.atan2(float(m[1, 0]), float(m[0, 0]))


#: A scan's (cloud, tree, number of points) for small_gicp.
_Cloud = tuple[Any, Any, int]


def _check_options(
    max_range: float, voxel: float, max_correspondence: float, layer: float, every: int,
    max_iterations: int,
) -> None:  # fmt: skip
    for name, value in (
        ("max_range", max_range),
        ("voxel", voxel),
        ("max_correspondence", max_correspondence),
        ("layer", layer),
    ):
        if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
            raise CalibrationError(
                f"scan matching option {name} is {value!r}; expected a number > 0"
            )
    if not (isinstance(every, int) and every >= 1):
        raise CalibrationError(f"scan matching option every is {every!r}; expected an integer >= 1")
    if not (isinstance(max_iterations, int) and max_iterations >= 1):
        raise CalibrationError(f"max_iterations is {max_iterations!r}; expected an integer >= 1")


def _clouds(
    scans: LaserScans, every: int, max_range: float, voxel: float, height: float, threads: int
) -> tuple[list[_Cloud], list[int], list[int]]:
    """(cloud, tree, number of points) of every ``every``-th scan with enough points, their
    scan indexes, and the indexes of the scans skipped."""
    import small_gicp

    clouds: list[_Cloud] = []
    index: list[int] = []
    skipped: list[int] = []
    for i in range(0, len(scans), every):
        xy = scans.points(i, max_range)
        if len(xy) < MIN_POINTS:
            skipped.append(i)
            continue
        flat = np.column_stack((xy, np.zeros(len(xy))))
        up = flat.copy()
        up[:, 2] = height
        cloud, tree = small_gicp.preprocess_points(
            np.vstack((flat, up)),
            downsampling_resolution=voxel,
            num_neighbors=10,
            num_threads=threads,
        )
        clouds.append((cloud, tree, cloud.size()))
        index.append(i)
    if len(index) < 2:
        raise InsufficientDataError(
            f"{len(index)} of {len(scans)} scans have at least {MIN_POINTS} valid ranges within "
            f"{max_range} m; scan matching needs two"
        )
    return clouds, index, skipped


def _match(
    clouds: list[_Cloud],
    k: int,
    init: NDArray[np.float64],
    max_correspondence: float,
    max_iterations: int,
    threads: int,
) -> tuple[Any, float, float]:
    """Scan k+1 aligned to scan k from ``init``: the result, its fitness and RMS residual."""
    import small_gicp

    target, tree, _ = clouds[k]
    source, _, n = clouds[k + 1]
    res = small_gicp.align(
        target,
        source,
        tree,
        init_T_target_source=init,
        registration_type="GICP",
        max_correspondence_distance=max_correspondence,
        num_threads=threads,
        max_iterations=max_iterations,
    )
    pts = np.asarray(source.points())[:, 0:3]
    moved = pts @ res.T_target_source[0:3, 0:3].T + res.T_target_source[0:3, 3]
    _, sq = tree.batch_nearest_neighbor_search(moved, num_threads=threads)
    d2 = np.asarray(sq, dtype=np.float64)
    near = d2 <= max_correspondence**2
    fit = float(near.sum()) / max(n, 1)
    rms = float(np.sqrt(d2[near].mean())) if near.any() else math.inf
    return res, fit, rms


def _compose(
    motions: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The sensor's poses: pose_{k+1} = pose_k (+) motion_k from the origin."""
    m = len(motions)
    x = np.zeros(m + 1)
    y = np.zeros(m + 1)
    h = np.zeros(m + 1)
    for k, (dx, dy, dyaw) in enumerate(motions):
        c, s = math.cos(h[k]), math.sin(h[k])
        x[k + 1] = x[k] + c * dx - s * dy
        y[k + 1] = y[k] + s * dx + c * dy
        h[k + 1] = h[k] + dyaw
    return x, y, h


def scan_motions(
    scans: LaserScans,
    *,
    max_range: float = 30.0,
    voxel: float = 0.05,
    every: int = 1,
    max_correspondence: float = 0.5,
    max_iterations: int = 50,
    layer: float = 0.1,
    threads: int = 1,
    progress: Callable[[int, int], None] | None = None,
) -> ScanMotions:
    """Match every ``every``-th scan to the one before it and compose the sensor's trajectory.

    ``max_range`` (m) drops far readings; ``voxel`` (m) is the downsampling grid;
    ``max_correspondence`` (m) the farthest two points may be to pair up; ``progress(done,
    total)`` is called after each pair. Raises :class:`CalibrationError` for bad settings and
    :class:`InsufficientDataError` when fewer than two scans have :data:`MIN_POINTS` points."""
    import small_gicp  # noqa: F401  (a missing extra fails here, before any check)

    _check_options(max_range, voxel, max_correspondence, layer, every, max_iterations)
    height = max(layer, 2.0 * voxel)  # the two copies must not share a voxel
    clouds, index, skipped = _clouds(scans, every, max_range, voxel, height, threads)

    m = len(index) - 1
    motions = np.zeros((m, 3))
    fitness = np.zeros(m)
    residual = np.zeros(m)
    iterations = np.zeros(m, dtype=np.int64)
    converged = np.zeros(m, dtype=bool)
    guess = np.eye(4)
    for k in range(m):
        res, fit, rms = _match(clouds, k, guess, max_correspondence, max_iterations, threads)
        if k and (fit < 0.9 or not res.converged):  # the constant-velocity guess may mislead
            res0, fit0, rms0 = _match(
                clouds, k, np.eye(4), max_correspondence, max_iterations, threads
            )
            if (fit0, -rms0) > (fit, -rms):
                res, fit, rms = res0, fit0, rms0
        t_ts = np.asarray(res.T_target_source, dtype=np.float64)
        motions[k] = _to_planar(t_ts)
        fitness[k], residual[k] = fit, rms
        iterations[k] = int(res.iterations)
        converged[k] = bool(res.converged)
        guess = _pose_matrix(*motions[k])
        if progress is not None:
            progress(k + 1, m)
    x, y, h = _compose(motions)
    idx = np.array(index, dtype=np.int64)
    return ScanMotions(
        trajectory=Trajectory.from_xyh(scans.t[idx], x, y, h),
        index=idx,
        motions=motions,
        fitness=fitness,
        residual=residual,
        iterations=iterations,
        converged=converged,
        skipped=tuple(skipped),
    )
