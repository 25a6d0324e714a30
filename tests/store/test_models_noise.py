"""A parameter set's kinematic model and noise survive the notebook (schema v3) exactly.

Before schema v3 a set with a ``[model]`` or ``[noise]`` table was stored as its ``[robot]``
values only and came back as a plain differential drive without noise; odometry re-run from the
notebook then silently used the wrong model.
"""

from __future__ import annotations

import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from typer.testing import CliRunner

from odolab.cli import app
from odolab.core.errors import StoreError
from odolab.core.models import DIFF_DRIVE, ExtendedDiffDrive, IcrModel
from odolab.core.params import NoiseParams, save_params
from odolab.core.prediction import final_pose_from_log
from odolab.store import Notebook

from .conftest import JAGUAR, fingerprint, make_trials

FIXTURES = Path(__file__).parent / "fixtures"

#: One set of each model kind, with and without noise (the values are the tracked Jaguar's kind).
ICR = IcrModel(y_icr_left=0.3412, y_icr_right=-0.3021, x_icr=0.0173)
EXTENDED = ExtendedDiffDrive(scale_left=0.981, scale_right=1.013, track_scale=1.27)
NOISE = NoiseParams(k_left=2.1e-5, k_right=1.7e-5, k_scrub=3.3e-3)
SETS = {
    "diff": JAGUAR,
    "diff+noise": JAGUAR.with_(noise=NoiseParams(k_left=1e-4, k_right=2e-4)),
    "extended": JAGUAR.with_(model=EXTENDED),
    "extended+noise": JAGUAR.with_(model=EXTENDED, noise=NOISE),
    "icr": JAGUAR.with_(model=ICR),
    "icr+noise": JAGUAR.with_(model=ICR, noise=NOISE),
}


@pytest.mark.parametrize("name", list(SETS))
def test_parameter_version_round_trip_is_exact(tmp_path: Path, name: str) -> None:
    params = SETS[name]
    db = tmp_path / "nb.db"
    with Notebook(db) as nb:
        version = nb.add_params_version(params, method="hand")
    with Notebook(db) as nb:  # read back from the file, not from a cache
        assert nb.get_params("jaguar-lite", version) == params
        assert nb.latest_params("jaguar-lite") == params
        (pv,) = nb.params_versions("jaguar-lite")
        assert pv.params.model == params.model
        assert pv.params.noise == params.noise
        assert nb.find_params_version(params) == version


@pytest.mark.parametrize("name", list(SETS))
def test_trial_keeps_its_model_and_noise(tmp_path: Path, name: str) -> None:
    params = SETS[name]
    (trial, *_) = make_trials(1, params=params, with_logs=True)
    with Notebook(tmp_path / "nb.db") as nb:
        nb.add_trial(trial)
        back = nb.get_trial(trial.trial_id)
        assert back.params == params
        assert fingerprint(back) == fingerprint(trial)
        # odometry from the notebook is the odometry of the set that was recorded
        assert back.encoder_log is not None
        got = final_pose_from_log(back.encoder_log, back.params, source="notebook")
        want = final_pose_from_log(back.encoder_log, params, source="original")
        assert tuple(got) == tuple(want)


def test_same_radii_different_model_are_different_versions(tmp_path: Path) -> None:
    """Matching a trial's set by value looks at the model and the noise too: an ICR trial is not
    filed under the diff-drive version that has the same [robot] values."""
    diff_trials = make_trials(2, params=JAGUAR, prefix="D", with_logs=True)
    icr_trials = make_trials(2, params=SETS["icr"], prefix="I", with_logs=True)
    noisy_trials = make_trials(2, params=SETS["icr+noise"], prefix="N", with_logs=True)
    with Notebook(tmp_path / "nb.db") as nb:
        nb.add_trials(diff_trials + icr_trials + noisy_trials)
        assert [nb.trial_params_version(t.trial_id)[1] for t in nb.load_trials()] == [
            1, 1, 2, 2, 3, 3]  # fmt: skip
        assert [v.params.model.kind for v in nb.params_versions("jaguar-lite")] == [
            "diff", "icr", "icr"]  # fmt: skip
        # the ICR set really moves the pose differently (the loss would have shown)
        log = icr_trials[0].encoder_log
        assert log is not None
        icr_pose = final_pose_from_log(log, nb.get_trial("I00000").params, source="icr")
        diff_pose = final_pose_from_log(log, JAGUAR, source="diff")
        assert abs(icr_pose.heading - diff_pose.heading) > 1e-3


def test_zero_and_negative_zero_x_icr_are_one_version(tmp_path: Path) -> None:
    a = JAGUAR.with_(model=IcrModel(0.3, -0.3, 0.0))
    b = JAGUAR.with_(model=IcrModel(0.3, -0.3, -0.0))
    with Notebook(tmp_path / "nb.db") as nb:
        v = nb.add_params_version(a, method="hand")
        assert nb.find_params_version(b) == v


@given(
    left=st.floats(0.01, 2.0),
    right=st.floats(-2.0, -0.01),
    x=st.floats(-1.0, 1.0),
    k=st.floats(0.0, 1.0),
)
def test_any_icr_set_round_trips_bit_for_bit(
    tmp_path_factory: pytest.TempPathFactory, left: float, right: float, x: float, k: float
) -> None:
    params = JAGUAR.with_(
        model=IcrModel(left, right, x), noise=NoiseParams(k_left=k, k_right=k / 3, k_scrub=k / 7)
    )
    with Notebook(tmp_path_factory.mktemp("h") / "nb.db") as nb:
        v = nb.add_params_version(params, method="hand")
        back = nb.get_params("jaguar-lite", v)
    assert back.model.to_dict() == params.model.to_dict()
    assert back.noise == params.noise


def _filled(nb: Notebook) -> list:
    trials = []
    for i, name in enumerate(SETS):
        trials += make_trials(3, params=SETS[name], prefix=f"S{i}-", with_logs=True)
    nb.add_trials(trials)
    return trials


def test_json_export_import_keeps_models_and_noise(tmp_path: Path) -> None:
    with Notebook(tmp_path / "a.db") as a:
        trials = _filled(a)
        a.export_json(tmp_path / "nb.json")
        versions_a = a.params_versions("jaguar-lite")
    with Notebook(tmp_path / "b.db") as b:
        assert b.import_json(tmp_path / "nb.json") == len(trials)
        assert b.params_versions("jaguar-lite") == versions_a
        assert [v.params for v in versions_a] == list(SETS.values())
        assert [fingerprint(t) for t in b.load_trials()] == [fingerprint(t) for t in trials]


def test_json_from_schema_2_means_diff_drive_without_noise(tmp_path: Path) -> None:
    import json

    with Notebook(tmp_path / "a.db") as a:
        a.add_trials(make_trials(2))
        a.export_json(tmp_path / "nb.json")
    doc = json.loads((tmp_path / "nb.json").read_text())
    for pv in doc["params_versions"]:  # what an odolab before schema 3 wrote
        del pv["model"], pv["noise"]
    doc["schema"] = 2
    (tmp_path / "old.json").write_text(json.dumps(doc))
    with Notebook(tmp_path / "b.db") as b:
        assert b.import_json(tmp_path / "old.json") == 2
        assert b.latest_params("jaguar-lite") == JAGUAR


def test_json_with_a_bad_model_is_one_sentence(tmp_path: Path) -> None:
    import json

    with Notebook(tmp_path / "a.db") as a:
        a.add_trials(make_trials(2, params=SETS["icr"]))
        a.export_json(tmp_path / "nb.json")
    doc = json.loads((tmp_path / "nb.json").read_text())
    doc["params_versions"][0]["model"]["y_icr_right"] = 0.2
    (tmp_path / "bad.json").write_text(json.dumps(doc))
    with Notebook(tmp_path / "b.db") as b:
        with pytest.raises(StoreError, match=r"params_versions\[0\].*y_icr_right must be < 0"):
            b.import_json(tmp_path / "bad.json")
        assert b.info().trials == 0


def test_json_import_refuses_a_version_that_differs_only_in_its_model(tmp_path: Path) -> None:
    with Notebook(tmp_path / "a.db") as a:
        a.add_trials(make_trials(2, params=SETS["icr"]))
        a.export_json(tmp_path / "nb.json")
    with Notebook(tmp_path / "b.db") as b:
        b.add_params_version(JAGUAR, method="recorded with a trial")
        with pytest.raises(StoreError, match="parameter version 1 of 'jaguar-lite' differs"):
            b.import_json(tmp_path / "nb.json")


def test_csv_export_import_keeps_models_and_noise(tmp_path: Path) -> None:
    with Notebook(tmp_path / "a.db") as a:
        trials = _filled(a)
        a.export_csv(tmp_path / "nb.csv")
    text = (tmp_path / "nb.csv").read_text()
    assert "kind=icr; y_icr_left=0.3412; y_icr_right=-0.3021; x_icr=0.0173" in text
    assert "k_left=2.1e-05; k_right=1.7e-05; k_scrub=0.0033" in text
    with Notebook(tmp_path / "b.db") as b:  # a notebook that knows none of the versions
        assert b.import_csv(tmp_path / "nb.csv", create_campaigns=True) == len(trials)
        assert [fingerprint(t, logs=False) for t in b.load_trials()] == [
            fingerprint(t, logs=False) for t in trials
        ]
        assert [v.params for v in b.params_versions("jaguar-lite")] == list(SETS.values())
    with Notebook(tmp_path / "a.db") as a:  # the same notebook: rows name known versions
        a.export_csv(tmp_path / "again.csv")
    with Notebook(tmp_path / "c.db") as c:
        _filled(c)
        text = (tmp_path / "again.csv").read_text().replace("S", "R")  # new trial ids
        (tmp_path / "renamed.csv").write_text(text)
        assert c.import_csv(tmp_path / "renamed.csv", create_campaigns=True) == len(trials)
        assert len(c.params_versions("jaguar-lite")) == len(SETS)


@pytest.mark.parametrize(
    ("cell", "column", "problem"),
    [
        ("kind=icr; y_icr_left=abc", "model", "'y_icr_left' = 'abc' is not a number"),
        ("kind=tank", "model", "unknown model kind 'tank'"),
        ("kind=icr; y_icr_left=0.3", "model", "y_icr_right"),
        ("k_left=1e-4", "noise", "missing key 'k_right'"),
        ("k_left=1e-4; k_right=-1", "noise", "k_right must be a number from 0"),
        ("k_left", "noise", "expected key=value pairs"),
    ],
)
def test_csv_bad_model_or_noise_cell_names_line_and_column(
    tmp_path: Path, cell: str, column: str, problem: str
) -> None:
    with Notebook(tmp_path / "a.db") as a:
        a.add_trials(make_trials(1))
        a.export_csv(tmp_path / "nb.csv")
    lines = (tmp_path / "nb.csv").read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[1].split(",")
    cells[header.index(column)] = f'"{cell}"'
    (tmp_path / "bad.csv").write_text("\n".join([lines[0], ",".join(cells)]) + "\n")
    with Notebook(tmp_path / "b.db") as b:
        with pytest.raises(StoreError, match=rf"line 2, column '{column}': .*{problem}"):
            b.import_csv(tmp_path / "bad.csv", create_campaigns=True)
        assert b.info().trials == 0


def test_v2_notebook_migrates_to_v3_as_diff_drive_without_noise(tmp_path: Path) -> None:
    db = tmp_path / "v2.db"
    shutil.copy(FIXTURES / "notebook_v2.db", db)
    with Notebook(db) as nb:
        assert nb.migrated_from == 2
        assert nb.integrity_check() == "ok"
        versions = nb.params_versions("jaguar-lite")
        assert [(v.params.model, v.params.noise) for v in versions] == [(DIFF_DRIVE, None)] * 2
        old = nb.get_trial("R01")
        assert old.params.model == DIFF_DRIVE
        # the migrated notebook takes a tracked set next to the old ones
        v = nb.add_params_version(SETS["icr+noise"], method="least-squares")
        assert v == 3
        assert nb.get_params("jaguar-lite", 3) == SETS["icr+noise"]
        with pytest.raises(sqlite3.IntegrityError, match="never changed"):
            nb._conn.execute("UPDATE params_versions SET model_kind = 'diff' WHERE version = 3")
    conn = sqlite3.connect(db)
    assert conn.execute("PRAGMA user_version").fetchone()[0] == 3
    conn.close()


def test_v1_notebook_migrates_through_to_v3(tmp_path: Path) -> None:
    db = tmp_path / "v1.db"
    shutil.copy(FIXTURES / "notebook_v1.db", db)
    with Notebook(db) as nb:
        assert nb.migrated_from == 1
        assert nb.latest_params("other").model == DIFF_DRIVE
        assert nb.latest_params("other").noise is None
        assert nb.get_trial("R01").measured is not None


def test_params_add_cli_keeps_model_and_noise(tmp_path: Path) -> None:
    toml = tmp_path / "tracked.toml"
    save_params(toml, SETS["icr+noise"])
    db = tmp_path / "nb.db"
    runner = CliRunner()
    res = runner.invoke(
        app, ["trials", "params-add", str(toml), "--method", "lsq", "--db", str(db)]
    )
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["trials", "params-versions", "jaguar-lite", "--db", str(db)])
    assert res.exit_code == 0, res.output
    assert "model icr (y_icr_left 0.3412, y_icr_right -0.3021, x_icr 0.0173 m)" in res.output
    assert "noise k_left 2.1e-05, k_right 1.7e-05 m, k_scrub 0.0033 rad" in res.output
    with Notebook(db) as nb:
        assert nb.latest_params("jaguar-lite") == SETS["icr+noise"]


def test_mcap_of_a_notebook_campaign_uses_the_stored_model_and_noise(tmp_path: Path) -> None:
    """`odolab export mcap --campaign` integrates each trial with the parameters the notebook
    gives back: the ICR model and a covariance from [noise], as recorded."""
    from odolab.core.odometry import integrate
    from odolab.export.mcap import stream_from_campaign

    params = SETS["icr+noise"]
    trials = make_trials(3, params=params, with_logs=True, campaign="tracked")
    with Notebook(tmp_path / "nb.db") as nb:
        nb.add_trials(trials)
    with Notebook(tmp_path / "nb.db") as nb:
        stream = stream_from_campaign(nb, "tracked")
    assert stream.covariance is not None  # no [noise] would mean no covariance
    log = trials[0].encoder_log
    assert log is not None
    want = integrate(log.t, log.left_ticks, log.right_ticks, params)
    n = len(log)
    np.testing.assert_allclose(stream.odometry.x[:n], want.x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(stream.odometry.heading[:n], want.heading, rtol=0, atol=1e-12)
    plain = integrate(log.t, log.left_ticks, log.right_ticks, JAGUAR)  # what v2 gave back
    assert np.max(np.abs(plain.heading - want.heading)) > 1e-3
