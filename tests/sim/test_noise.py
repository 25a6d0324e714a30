"""Random error: Monte Carlo spread against the analytic covariance (odolab.core.uncertainty)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from odolab.core.errors import OdolabError
from odolab.core.params import PRESETS
from odolab.core.uncertainty import (
    pose_covariance,
    rotation_heading_variance,
    straight_line_covariance,
)
from odolab.sim.physics import TrueParams
from odolab.sim.protocols import parse_protocol, run_protocol

NOM = PRESETS["jaguar-lite"]
N = 2500
# sample variances of N normal draws have relative sigma sqrt(2 / (N - 1)) ~ 2.8 %: allow 4 sigma
REL = 4 * math.sqrt(2 / (N - 1))


def _final(truth: TrueParams, trial: dict[str, object], seed: int) -> np.ndarray:
    proto = parse_protocol({"protocol": {"campaign": "mc"}, "trials": [trial]}, "mc.toml")
    trials = run_protocol(proto, truth, NOM, seed=seed)
    return np.array([(t.true.x, t.true.y, t.true.heading) for t in trials if t.true])


@pytest.mark.parametrize("distance", [1.0, 2.5])
def test_straight_run_covariance_grows_as_predicted(distance: float) -> None:
    kl, kr = 4e-4, 1e-3
    truth = TrueParams.from_nominal(NOM, k_left=kl, k_right=kr)
    poses = _final(truth, {"motion": "translation", "distance": distance, "repeats": N}, seed=1)
    d = float(np.ceil(distance / NOM.left_metres_per_tick) * NOM.left_metres_per_tick)
    want = straight_line_covariance(d, NOM.track_width, kl, kr)
    got = np.cov(poses.T)
    for i in range(3):
        assert got[i, i] == pytest.approx(want[i, i], rel=REL), i
    # correlation of y and heading: 3/4 * sqrt(3) ... from the closed form
    rho_want = want[1, 2] / math.sqrt(want[1, 1] * want[2, 2])
    rho_got = got[1, 2] / math.sqrt(got[1, 1] * got[2, 2])
    assert rho_want == pytest.approx(math.sqrt(3) / 2)
    assert rho_got == pytest.approx(rho_want, abs=0.03)


def test_sigma_grows_with_distance_like_the_model() -> None:
    k = 1e-3
    truth = TrueParams.from_nominal(NOM, k_left=k, k_right=k)
    s1 = _final(truth, {"motion": "translation", "distance": 1.0, "repeats": N}, seed=2)
    s4 = _final(truth, {"motion": "translation", "distance": 4.0, "repeats": N}, seed=3)
    # sigma_y ~ d^1.5 and sigma_heading ~ d^0.5 for a pure per-wheel random walk
    assert s4[:, 1].std() / s1[:, 1].std() == pytest.approx(8.0, rel=REL)
    assert s4[:, 2].std() / s1[:, 2].std() == pytest.approx(2.0, rel=REL)


def test_rotation_heading_variance_wheels_and_scrub() -> None:
    angle = 4 * math.pi
    wheels = TrueParams.from_nominal(NOM, k_left=1e-3, k_right=1e-3)
    h = _final(wheels, {"motion": "rotation", "angle": angle, "repeats": N}, seed=4)[:, 2]
    a = float(np.ceil(angle * NOM.track_width / 2 / NOM.left_metres_per_tick))
    a *= 2 * NOM.left_metres_per_tick / NOM.track_width  # the commanded (predicted) angle
    assert h.var(ddof=1) == pytest.approx(
        rotation_heading_variance(a, NOM.track_width, 1e-3, 1e-3), rel=REL
    )
    scrub = TrueParams.from_nominal(NOM, k_scrub=0.05)
    h = _final(scrub, {"motion": "rotation", "angle": angle, "repeats": N}, seed=5)[:, 2]
    assert h.var(ddof=1) == pytest.approx(0.05 * a, rel=REL)
    assert h.mean() == pytest.approx(a, abs=4 * math.sqrt(0.05 * a / N))


def test_pose_covariance_matches_closed_form_and_rotates() -> None:
    ds = np.full(2000, 2.0 / 2000)
    p = pose_covariance(ds, ds, 0.5, 2e-4, 6e-4)
    assert p.shape == (2001, 3, 3)
    np.testing.assert_allclose(p[-1], straight_line_covariance(2.0, 0.5, 2e-4, 6e-4), rtol=2e-3)
    q = pose_covariance(ds, ds, 0.5, 2e-4, 6e-4, heading0=math.pi / 2)[-1]
    # driving along +y: the x and y variances swap
    assert q[0, 0] == pytest.approx(p[-1, 1, 1], rel=1e-9)
    assert q[1, 1] == pytest.approx(p[-1, 0, 0], rel=1e-9)
    with pytest.raises(OdolabError, match="k_left"):
        pose_covariance(ds, ds, 0.5, -1.0, 0.0)


def test_per_run_track_width_gives_error_proportional_to_angle() -> None:
    sigma = 0.02
    truth = TrueParams.from_nominal(NOM, track_sigma=sigma)
    for angle in (math.pi, 8 * math.pi):
        h = _final(truth, {"motion": "rotation", "angle": angle, "repeats": N}, seed=6)[:, 2]
        # heading = predicted / (1 + e): sigma = predicted * sigma_e to first order
        assert h.std(ddof=1) / h.mean() == pytest.approx(sigma, rel=REL)
