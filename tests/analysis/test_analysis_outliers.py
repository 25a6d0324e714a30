"""A miscounted turn is flagged, left out of the fit, and listed with its reason."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from synth_trials import rotation_trials

from odolab.analysis import analyze_trials, miscounted_turns


def test_clean_rotations_flag_nothing() -> None:
    for seed in range(20):
        trials = rotation_trials(np.random.default_rng(seed))
        pred = [t.predicted.heading for t in trials]
        act = [t.measured.rotation for t in trials]
        assert not miscounted_turns(pred, act).any()


def test_miscounted_turn_is_flagged_and_does_not_bend_the_fit() -> None:
    rng = np.random.default_rng(8)
    trials = rotation_trials(rng, sigma_a=0.02, repeats_at_20pi=5)
    clean = analyze_trials(trials).get("rotation")
    bad = trials[4]  # 5 pi
    meas = dataclasses.replace(bad.measured, rotation=bad.measured.rotation + 2 * math.pi)
    trials[4] = dataclasses.replace(bad, measured=meas)
    res = analyze_trials(trials)
    rot = res.get("rotation")
    assert rot is not None and clean is not None
    assert [o.trial_id for o in res.outliers] == [bad.trial_id]
    assert "miscounted turn" in res.outliers[0].reason
    # measured |value - expected| 0.0053-0.135 over seed shifts 0-3; tolerance 0.3; at seed shift 0
    # it is 1.73x the spread over seeds away
    assert res.outliers[0].residual == pytest.approx(2 * math.pi, abs=0.3)
    assert bad.trial_id not in rot.fit.trial_ids
    assert rot.fit.n == clean.fit.n - 1
    assert rot.fit.slope == pytest.approx(clean.fit.slope, abs=3 * clean.fit.slope_se)
    assert res.to_dict()["outliers"][0]["trial_id"] == bad.trial_id
