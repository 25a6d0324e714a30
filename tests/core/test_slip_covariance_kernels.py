"""The slip model's covariance with its loops compiled (odolab.core.models._slip_covariance_jit)
equals the numpy loops that run without numba, cycle by cycle: the first-order propagation
(poses, every term's basis, the posterior's share, the heading's sensitivities) and the
second-order share."""

from __future__ import annotations

import numpy as np
import pytest

from odolab.core._jit import HAVE_NUMBA
from odolab.core.models import SlipModel
from odolab.core.models import slip_covariance as sc
from odolab.core.params import PRESETS

NOMINAL = PRESETS["jaguar-lite"]

pytestmark = pytest.mark.skipif(not HAVE_NUMBA, reason="numba is not installed: one loop only")


def _drive(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Track motion (m per cycle) of a drive that speeds up, turns both ways and spins."""
    rng = np.random.default_rng(seed)
    t = 0.05 * np.arange(n)
    v = 0.6 * np.sin(0.3 * t) + 0.1 * rng.standard_normal(n)
    w = 1.2 * np.sin(0.7 * t + 1.0) + 0.1 * rng.standard_normal(n)
    b = NOMINAL.track_width
    dsl, dsr = (v - 0.5 * b * w) * 0.05, (v + 0.5 * b * w) * 0.05
    dsl[0] = dsr[0] = 0.0
    return t, dsl, dsr


def _model(with_posterior: bool) -> SlipModel:
    rng = np.random.default_rng(4)
    half = rng.standard_normal((24, 24)) * 3e-3
    sigma = half @ half.T + 1e-6 * np.eye(24)
    return SlipModel(
        fwd_v_absv=-0.05, yaw_w=-0.1, lat_w=0.02, q_fwd=1e-4, q_lat=3e-5, q_yaw=2e-3,
        k_fwd=1e-3, k_yaw=0.15, d_fwd=2e-4, d_yaw=1e-3, d_turn=2e-3,
        posterior=tuple(sigma.ravel()) if with_posterior else (),
    )  # fmt: skip


@pytest.mark.parametrize("with_posterior", [True, False])
@pytest.mark.parametrize(("n", "seed"), [(2, 1), (61, 2), (240, 3)])
def test_compiled_loops_equal_the_numpy_loops(
    monkeypatch: pytest.MonkeyPatch, with_posterior: bool, n: int, seed: int
) -> None:
    params = NOMINAL.with_(model=_model(with_posterior))
    t, dsl, dsr = _drive(n, seed)
    start = (1.0, -2.0, 0.4)
    got = {}
    for compiled in (True, False):
        monkeypatch.setattr(sc, "COMPILED", compiled)
        prop = sc.propagate_terms(t, dsl, dsr, params, start)
        theta = sc.terms_of(params.model)  # type: ignore[arg-type]
        got[compiled] = (prop, prop.covariance(theta))
    (a, cov_a), (b, cov_b) = got[True], got[False]
    for name in ("poses", "basis", "post", "drift_heading", "coef_heading", "sigma"):
        x, y = getattr(a, name), getattr(b, name)
        scale = max(float(np.max(np.abs(y))), 1e-300)
        # the same sums in another order: measured at most 3e-16 of the largest entry (poses,
        # basis, post) over these cases; bound 1e-12
        assert np.max(np.abs(x - y)) <= 1e-12 * scale, name
    scale = float(np.max(np.abs(cov_b)))
    assert np.max(np.abs(cov_a - cov_b)) <= 1e-12 * scale
    if n > 60:
        second = cov_b - b.covariance(sc.terms_of(params.model), second_order=False)  # type: ignore[arg-type]
        assert float(np.max(np.abs(second))) > 1e-6 * scale  # the second-order share is there
