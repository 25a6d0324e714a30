"""The notebook API: parameter versions, campaigns, trials, measurements, the analysis frame."""

from __future__ import annotations

import dataclasses
import math
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from odolab.core.errors import StoreError
from odolab.core.trials import EncoderLog, MotionKind, TrialStatus
from odolab.store import Notebook, rotation_measurement_from_compass

from .conftest import JAGUAR, fingerprint, make_trials


@pytest.fixture
def nb(tmp_path: Path) -> Notebook:
    with Notebook(tmp_path / "nb.db") as notebook:
        yield notebook


def test_params_versions_are_appended_never_overwritten(nb: Notebook) -> None:
    assert nb.add_params_version(JAGUAR, method="preset") == 1
    wider = JAGUAR.with_(track_width=0.64)
    nb.add_trials(make_trials(2))
    v2 = nb.add_params_version(wider, method="ratios", source_trials=["T00000"], notes="sec VIII")
    assert v2 == 2
    assert nb.latest_params("jaguar-lite") == wider
    assert nb.get_params("jaguar-lite", 1) == JAGUAR
    pv = nb.params_versions("jaguar-lite")
    assert [(v.version, v.method, v.source_trials) for v in pv] == [
        (1, "preset", ()),
        (2, "ratios", ("T00000",)),
    ]
    with pytest.raises(sqlite3.IntegrityError, match="never changed"):
        nb._conn.execute("UPDATE params_versions SET track_width = 1 WHERE version = 1")
    with pytest.raises(StoreError, match="source trial 'nope'"):
        nb.add_params_version(wider, method="ratios", source_trials=["nope"])
    with pytest.raises(StoreError, match="no parameter version 7"):
        nb.get_params("jaguar-lite", 7)
    with pytest.raises(StoreError, match="no parameters of robot 'x'"):
        nb.latest_params("x")


def test_trials_round_trip_through_the_database(nb: Notebook) -> None:
    trials = make_trials(12, with_logs=True)
    nb.add_trials(trials)
    back = nb.load_trials()
    assert [fingerprint(t) for t in back] == [fingerprint(t) for t in trials]
    assert fingerprint(nb.get_trial("T00005")) == fingerprint(trials[5])
    # one parameter version was recorded for them, by value
    assert [v.method for v in nb.params_versions("jaguar-lite")] == ["recorded with a trial"]
    # the campaign was created from the first trial
    c = nb.get_campaign("rot-lab")
    assert (c.kind, c.terrain) == ("rotation", "lab")


def test_a_failing_batch_writes_nothing(nb: Notebook) -> None:
    nb.add_trials(make_trials(3))
    before = nb.info()
    batch = make_trials(5, prefix="N") + make_trials(1)  # the last one repeats T00000
    with pytest.raises(StoreError, match="'T00000' is already in"):
        nb.add_trials(batch)
    assert nb.info() == before
    with pytest.raises(StoreError, match="appears twice"):
        nb.add_trials(make_trials(2, prefix="D") * 2)
    with pytest.raises(StoreError, match="unknown campaign"):
        nb.add_trials(make_trials(1, prefix="Q", campaign="new"), create_campaigns=False)
    assert nb.info() == before


def test_filters_and_frame(nb: Notebook) -> None:
    nb.add_campaign("fwd-grass", "translation", "grass", date="2019-03-11", operator="C.D.")
    nb.add_trials(make_trials(6, with_logs=True))
    nb.add_trials(make_trials(4, prefix="F", campaign="fwd-grass", terrain="grass",
                              kind=MotionKind.TRANSLATION))  # fmt: skip
    assert len(nb.load_trials(campaign="fwd-grass")) == 4
    assert len(nb.load_trials(terrain="lab", status="measured")) == 3
    assert [t.trial_id for t in nb.load_trials(status=TrialStatus.EXCLUDED)] == [
        "T00003",
        "F00003",
    ]
    df = nb.trials_frame()
    assert len(df) == 8  # the two excluded trials are left out
    assert len(nb.trials_frame(include_excluded=True)) == 10
    row = df.set_index("trial_id").loc["F00000"]
    assert row["measured_x"] == pytest.approx(make_trials(1, kind=MotionKind.TRANSLATION)[0]
                                              .measured.x)  # fmt: skip
    assert row["operator"] == "C.D." and row["campaign_date"] == "2019-03-11"
    assert row["kind"] == "translation" and row["params_version"] == 1
    assert math.isnan(row["measured_rotation"])
    lab = nb.trials_frame(terrain="lab")
    assert lab["has_encoder_log"].all()
    assert lab["track_width"].eq(0.56).all()
    for col in ("predicted_heading", "true_heading", "sigma_rotation", "status", "instrument"):
        assert col in df.columns


def test_measure_exclude_include(nb: Notebook) -> None:
    nb.add_trials(make_trials(2))
    m = rotation_measurement_from_compass(10.0, 340.0, 2)
    nb.set_measurement("T00001", m)
    t = nb.get_trial("T00001")
    assert t.status is TrialStatus.MEASURED
    assert t.measured is not None and t.measured.rotation == pytest.approx(
        4 * math.pi + math.radians(30)
    )
    with pytest.raises(StoreError, match="already measured"):
        nb.set_measurement("T00001", m)
    nb.set_measurement("T00001", dataclasses.replace(m, instrument="compass 2"), replace=True)
    assert nb.get_trial("T00001").measured.instrument == "compass 2"  # type: ignore[union-attr]
    nb.exclude_trial("T00001", "robot slipped on tape")
    t = nb.get_trial("T00001")
    assert (t.status, t.exclusion_reason) == (TrialStatus.EXCLUDED, "robot slipped on tape")
    assert t.measured is not None  # kept
    nb.include_trial("T00001")
    assert nb.get_trial("T00001").status is TrialStatus.MEASURED
    with pytest.raises(StoreError, match="needs a reason"):
        nb.exclude_trial("T00001", " ")
    with pytest.raises(StoreError, match="no trial 'zz'"):
        nb.exclude_trial("zz", "x")
    with pytest.raises(StoreError, match="no trial 'zz'"):
        nb.set_measurement("zz", m)


def test_encoder_log_is_stored_compactly_and_exactly(nb: Notebook) -> None:
    trials = make_trials(3, with_logs=True)
    nb.add_trials(trials)
    log = nb.encoder_log("T00002")
    assert log is not None
    assert np.array_equal(log.left_ticks, trials[2].encoder_log.left_ticks)
    assert log.modulus == 32768
    blob = nb._conn.execute(
        "SELECT length(t) + length(left_ticks) + length(right_ticks) FROM encoder_logs "
        "WHERE trial_id = 'T00002'"
    ).fetchone()[0]
    assert blob < 24 * len(log)


def test_campaigns(nb: Notebook) -> None:
    nb.add_campaign("sq", "square", "concrete", date="2024-05-01", notes="UMBmark")
    with pytest.raises(StoreError, match="already in"):
        nb.add_campaign("sq", "square", "concrete")
    with pytest.raises(StoreError, match="kind 'spin'"):
        nb.add_campaign("x", "spin", "lab")
    assert [c.name for c in nb.campaigns()] == ["sq"]
    assert nb.get_campaign("sq").notes == "UMBmark"


def test_replaced_measurements_are_kept_in_the_history(nb: Notebook) -> None:
    nb.add_trials(make_trials(2, measured_every=10**6))
    first = rotation_measurement_from_compass(10.0, 340.0, 2)
    second = rotation_measurement_from_compass(10.0, 330.0, 2)
    nb.set_measurement("T00001", first)
    assert nb.measurement_history("T00001") == []
    nb.set_measurement("T00001", second, replace=True)
    history = nb.measurement_history("T00001")
    assert len(history) == 1
    when, old = history[0]
    assert old == first and when[:4].isdigit()
    assert nb.get_trial("T00001").measured == second


def test_repredict_from_the_stored_log(nb: Notebook) -> None:
    # a pure in-place ccw rotation: 1000 counts back on the left, 1000 forward on the right,
    # counters wrapping; heading = (d_right - d_left) / track = 2 * 1000 * m_per_tick / track
    n = 101
    right = (32000 + 10 * np.arange(n)) % 32768
    left = (500 - 10 * np.arange(n)) % 32768
    trial = make_trials(1)[0]
    trial = dataclasses.replace(
        trial, encoder_log=EncoderLog(np.arange(n) * 0.05, left, right, 32768)
    )
    nb.add_trial(trial)
    mpt = 2 * math.pi * 0.0835 / 380
    pose = nb.repredict("T00000", JAGUAR)
    assert pose.heading == pytest.approx(2 * 1000 * mpt / 0.56, rel=1e-12)
    assert pose.x == pytest.approx(0.0, abs=1e-12) and pose.y == pytest.approx(0.0, abs=1e-12)
    wider = nb.repredict("T00000", JAGUAR.with_(track_width=1.12))
    assert wider.heading == pytest.approx(pose.heading / 2, rel=1e-12)
    nb.add_trials(make_trials(1, prefix="NOLOG"))
    with pytest.raises(StoreError, match="no encoder log"):
        nb.repredict("NOLOG00000", JAGUAR)
