"""The compiled kernels' results on a small input, for tests/core/test_plain_kernels.py: run in
the test's process (numba) and, as ``python kernel_cases.py OUT.npz``, in a child process where
numba cannot be imported (the core without the fast extra: the kernels run as plain Python)."""

from __future__ import annotations

import sys

import numpy as np
from numpy.typing import NDArray

#: Long enough for the compiled passes (odolab.core.odometry.NUMPY_MAX_SAMPLES is 2048).
N = 2500


def _log(seed: int) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
    """A 50 Hz log of counters that turn both ways and roll over (jaguar-lite's 32768)."""
    rng = np.random.default_rng(seed)
    t = np.arange(N) * 0.02 + rng.uniform(0.0, 0.002, N)
    dl = np.round(20 + 15 * np.sin(np.arange(N) / 90) + rng.normal(0, 2, N)).astype(np.int64)
    dr = np.round(20 - 15 * np.sin(np.arange(N) / 70) + rng.normal(0, 2, N)).astype(np.int64)
    return t, (30000 + np.cumsum(dl)) % 32768, (100 + np.cumsum(dr)) % 32768


def compute() -> dict[str, NDArray[np.generic]]:
    """Odometry (both methods, a sideways model, two threads), its covariance and the RPE
    pair kernels, on one seeded log."""
    import odolab.core.odometry as odo
    import odolab.core.uncertainty as unc
    from odolab.core.models import IcrModel
    from odolab.core.odometry import integrate, integrate_with_covariance
    from odolab.core.params import PRESETS, NoiseParams
    from odolab.metrics import pose_error as pe

    params = PRESETS["jaguar-lite"].with_(noise=NoiseParams(1e-4, 3e-4, k_scrub=0.02))
    t, left, right = _log(7)
    out: dict[str, NDArray[np.generic]] = {}
    for method in ("midpoint", "arc"):
        traj, cov = integrate_with_covariance(t, left, right, params, method, start=(1, 2, 3))
        out[f"{method}_pose"] = np.stack([traj.x, traj.y, traj.heading])
        out[f"{method}_cov"] = cov
    icr = params.with_(model=IcrModel(0.33, -0.25, 0.06))  # sideways motion: the lateral passes
    traj = integrate(t, left, right, icr)
    out["icr_pose"] = np.stack([traj.x, traj.y, traj.heading])
    # the threaded passes (numba's prange and parallel_chunksize; range and one chunk without)
    odo.PARALLEL_MIN_SAMPLES, unc.PARALLEL_MIN_SAMPLES = 0, 0
    traj, cov = integrate_with_covariance(t, left, right, params, parallel=2)
    out["threads_pose"] = np.stack([traj.x, traj.y, traj.heading])
    out["threads_cov"] = cov
    steps = np.concatenate((np.zeros(1), np.abs(np.diff(traj.heading))))
    out["by_steps"] = pe.consecutive_by_steps_from(steps, 0.3, 0.0, True)[0]
    out["by_path"] = pe.consecutive_by_path_from(traj.x, traj.y, 0.5, 0.0, True)[0]
    out["pairs_angle"] = pe.all_pairs_by_angle(traj.heading[::5], 0.5, 0.05)
    out["pairs_path"] = pe.all_pairs_by_path(pe.path_distances(traj), 1.0, 0.1)
    return out


if __name__ == "__main__":
    sys.modules["numba"] = None  # type: ignore[assignment]  # as if not installed
    from odolab.core import _jit

    assert not _jit.HAVE_NUMBA
    np.savez(sys.argv[1], **compute())
