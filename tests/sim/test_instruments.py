"""Compass with counted turns, meterstick, and flagging miscounted turns."""

from __future__ import annotations

import math

import numpy as np
import pytest

from odolab.core.errors import SimError
from odolab.core.params import PRESETS
from odolab.sim.instruments import Compass, Meterstick, flag_miscounted_turns
from odolab.sim.presets import TRUTH_PRESETS
from odolab.sim.protocols import parse_protocol, run_protocol

NOM = PRESETS["jaguar-lite"]


def test_compass_reads_bearing_and_counts_turns() -> None:
    rng = np.random.default_rng(0)
    compass = Compass(sigma=0.0, resolution_deg=1.0)
    h0 = np.array([0.0, 1.0, -2.0])
    total = np.array([20 * math.pi + 0.3, 0.5, -3 * math.pi - 0.2])
    r = compass.read_rotation(h0, h0 + total, rng)
    # bearings are clockwise: a counter-clockwise rotation lowers them; a clockwise one's
    # turns are counted clockwise (never negative: the notebook refuses those), and the
    # readings give the rotation back as the notebook's entry computes it
    from odolab.core.measurement import rotation_from_compass

    ways = ("ccw", "ccw", "cw")
    back = [rotation_from_compass(a, b, int(n), w)
            for a, b, n, w in zip(r.initial_deg, r.final_deg, r.turns, ways, strict=True)]  # fmt: skip
    np.testing.assert_allclose(r.rotation, back)
    np.testing.assert_array_equal(r.turns, [10, 0, 1])
    np.testing.assert_allclose(r.rotation, total, atol=math.radians(1.0))  # marks every degree
    assert ((r.initial_deg >= 0) & (r.initial_deg < 360)).all()


def test_compass_error_is_about_its_sigma() -> None:
    rng = np.random.default_rng(1)
    n = 20000
    h1 = np.full(n, 5.0)
    r = Compass(sigma=0.05, resolution_deg=0.0).read_rotation(np.zeros(n), h1, rng)
    err = r.rotation - 5.0
    assert err.std() == pytest.approx(0.05 * math.sqrt(2), rel=0.03)
    assert (r.miscounted == 0).all()


def test_miscounted_turn_is_a_2pi_outlier_and_is_flagged() -> None:
    truth = TRUTH_PRESETS["jaguar-lab"].with_(k_scrub=0.002)
    doc = {
        "protocol": {"campaign": "rot"},
        "instruments": {"miscount_probability": 0.15},
        "trials": [
            {"motion": "rotation", "angle_pi": {"from": 1, "to": 20, "step": 1}, "repeats": 3}
        ],
    }
    trials = run_protocol(parse_protocol(doc, "rot.toml"), truth, NOM, seed=4)
    meas = np.array([t.measured.rotation for t in trials])  # type: ignore[union-attr]
    start = np.array([float(t.notes.split("misalignment ")[1].split()[0]) for t in trials])
    true_rot = np.array([t.true.heading for t in trials]) - start  # type: ignore[union-attr]
    off = meas - true_rot
    turns_off = np.rint(off / (2 * math.pi))
    assert (np.abs(off - 2 * math.pi * turns_off) < 0.3).all()  # compass error is small
    miscounted = turns_off != 0
    assert 3 <= miscounted.sum() <= 20
    pred = np.array([t.predicted.heading for t in trials])
    flags = flag_miscounted_turns(meas, pred)
    np.testing.assert_array_equal(flags, miscounted)


def test_flag_nothing_on_a_clean_lab_campaign() -> None:
    doc = {
        "protocol": {"campaign": "rot"},
        "trials": [{"motion": "rotation", "angle_pi": {"from": 1, "to": 20, "step": 1}}],
    }
    trials = run_protocol(parse_protocol(doc, "rot.toml"), TRUTH_PRESETS["jaguar-lab"], NOM, seed=0)
    meas = np.array([t.measured.rotation for t in trials])  # type: ignore[union-attr]
    pred = np.array([t.predicted.heading for t in trials])
    assert not flag_miscounted_turns(meas, pred).any()


def test_meterstick() -> None:
    rng = np.random.default_rng(2)
    stick = Meterstick(sigma=0.003, resolution=0.001)
    r = stick.read(np.full(20000, 1.2345), rng)
    np.testing.assert_allclose(r * 1000, np.rint(r * 1000), atol=1e-9)
    assert r.mean() == pytest.approx(1.2345, abs=1e-4)
    assert r.std() == pytest.approx(math.sqrt(0.003**2 + 0.001**2 / 12), rel=0.03)
    with pytest.raises(SimError, match="meterstick sigma"):
        Meterstick(sigma=-1.0)
    with pytest.raises(SimError, match="miscount_probability"):
        Compass(miscount_probability=2.0)


def test_a_stall_is_never_read_a_whole_turn_off() -> None:
    # the robot (almost) did not turn: its readings can lie a hair either way, and the turns are
    # counted the way it truly turned, so the readings give about 0 back, never about 2 pi
    from odolab.core.measurement import rotation_from_compass

    compass = Compass()
    worst = 0.0
    for seed in range(200):
        b0, b1, turns, way = compass.read_turn(0.0, np.random.default_rng(seed))
        worst = max(worst, abs(rotation_from_compass(b0, b1, turns, way)))
        assert turns == 0
    assert (
        worst < 0.4
    )  # two readings of 0.05 rad on 1-degree marks: measured worst 0.23 rad (200 seeds)
    # the vectorized reader counts by the same rule and keeps the way it counted
    total = np.array([0.0, -0.0, 1e-3, -1e-3, 2 * math.pi, -2 * math.pi])
    r = compass.read_rotation(np.zeros(6), total, np.random.default_rng(3))
    np.testing.assert_allclose(r.rotation, total, atol=0.4)
    ways = ["cw" if c else "ccw" for c in r.clockwise]
    back = [rotation_from_compass(a, b, int(n), w)
            for a, b, n, w in zip(r.initial_deg, r.final_deg, r.turns, ways, strict=True)]  # fmt: skip
    np.testing.assert_allclose(r.rotation, back)
