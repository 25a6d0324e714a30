"""Issue 14's acceptance: the propagated covariance against 2,000 simulator runs per motion."""

from __future__ import annotations

import numpy as np
import pytest

from odolab.core.odometry import integrate_increments
from odolab.core.params import PRESETS, NoiseParams
from odolab.core.uncertainty import covariance_matrix, propagate_covariance
from odolab.sim.physics import TrueParams, kernel_params, simulate_batch
from odolab.sim.terrains import get_terrain

NOMINAL = PRESETS["jaguar-lite"]
NOISE = NoiseParams(2e-4, 1e-4, k_scrub=0.004)
RUNS = 2000
#: (left metres, right metres, wheel speed m/s) per segment
MOTIONS = {
    "straight": [(2.0, 2.0, 0.4)],
    "turn in place": [(-0.88, 0.88, 0.3)],
    "mixed": [(1.5, 1.5, 0.4), (-0.44, 0.44, 0.3), (1.0, 1.6, 0.4)],
}


@pytest.mark.parametrize("motion", list(MOTIONS))
def test_propagated_covariance_matches_the_simulator(motion: str) -> None:
    truth = TrueParams.from_nominal(NOMINAL).noiseless.with_(
        k_left=NOISE.k_left, k_right=NOISE.k_right, k_scrub=NOISE.k_scrub
    )
    p = kernel_params(truth, NOMINAL, get_terrain("tile"))
    segs = MOTIONS[motion]
    kl = NOMINAL.left_metres_per_tick

    def per_run(values: list[float], dtype: type) -> np.ndarray:
        return np.tile(np.array([values], dtype=dtype), (RUNS, 1))

    res = simulate_batch(
        np.tile(p, (RUNS, 1)),
        per_run([round(a / kl) for a, _, _ in segs], np.int64),
        per_run([round(b / kl) for _, b, _ in segs], np.int64),
        per_run([v * np.sign(a) for a, _, v in segs], float),
        per_run([v * np.sign(b) for _, b, v in segs], float),
        np.full(RUNS, len(segs)),
        rng=np.random.default_rng(1),
    )
    m = int(res.n_samples[0])
    left, right = res.ticks_left[0, :m], res.ticks_right[0, :m]
    assert (res.ticks_left[:, :m] == left).all()  # the motors stop by encoder: same counts
    dl = np.diff(left, prepend=left[0]).astype(float)
    dr = np.diff(right, prepend=right[0]).astype(float)
    params = NOMINAL.with_(noise=NOISE)
    cov = covariance_matrix(propagate_covariance(dl, dr, params, "arc")[-1])
    sample = np.cov(res.final_pose.T)
    np.testing.assert_allclose(np.diag(sample), np.diag(cov), rtol=0.10)
    est = integrate_increments(np.arange(m) * 0.05, dl, dr, params, "arc")
    d = res.final_pose[:, :2] - np.array([est.x[-1], est.y[-1]])
    m2 = np.einsum("ij,jk,ik->i", d, np.linalg.inv(cov[:2, :2]), d)
    assert 0.93 <= float(np.mean(m2 <= 5.991464547107979)) <= 0.97  # chi2(2) 95 %
