"""Exploration drives (issue 29): commands over the input space, held a few seconds, inside a
geofence watched by odometry."""

from __future__ import annotations

import numpy as np
import pytest

from odolab.errors import SimError
from odolab.params import PRESETS
from odolab.sim.explore import ExploreSettings, explore, sample_command
from odolab.sim.presets import TRUTH_PRESETS

NOMINAL = PRESETS["jaguar-lite"]
TRUTH = TRUTH_PRESETS["jaguar-lab-tracked"]


def test_commands_cover_the_input_space_within_the_wheel_limit() -> None:
    s = ExploreSettings(max_speed=1.0, max_turn_rate=2.0)
    rng = np.random.default_rng(0)
    cmds = np.array([sample_command(rng, s, 0.56) for _ in range(4000)])
    v, w = cmds[:, 0], cmds[:, 1]
    assert np.all(np.abs(v) + 0.28 * np.abs(w) <= 1.0 + 1e-12)
    assert v.min() < -0.9 and v.max() > 0.9 and w.min() < -1.9 and w.max() > 1.9
    assert abs(v.mean()) < 0.03 and abs(w.mean()) < 0.06  # no side preferred


def test_exploration_stays_inside_the_fence() -> None:
    s = ExploreSettings(seconds=60.0, fence_radius=2.0)
    d = explore(TRUTH, NOMINAL, s, seed=3)
    assert d.t[-1] == pytest.approx(60.05, abs=0.01)
    r = np.hypot(d.x, d.y)
    assert r.max() < 2.0  # the true pose too (the odometry keeps it within 0.7 R plus a turn)
    assert r.max() > 1.0  # it did explore
    speeds = np.abs(np.diff(d.dticks_left + d.dticks_right))
    assert speeds.max() > 0


def test_bad_settings_are_one_sentence() -> None:
    with pytest.raises(SimError, match="exploration distribution 'gauss' is unknown"):
        ExploreSettings(distribution="gauss")
    with pytest.raises(SimError, match="exploration hold"):
        ExploreSettings(hold=(3.0, 1.0))
