"""The application layer's rules, one at a time (the faces' parity is tests/parity)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from tests.parity.notebooks import ROBOT_A, VALIDATION, make_notebook
from tests.worded import raises_worded

from odolab.app.calibration import CalibrationRequest, calibrate, choose_base, choose_robot
from odolab.app.exports import ExportRequest
from odolab.app.odometry import choose_params
from odolab.app.selection import SelectionRequest, open_notebook, select
from odolab.core.errors import CalibrationError, ParamsError, StoreError
from odolab.core.params import PRESETS, save_params
from odolab.store import Notebook


@pytest.fixture(scope="module")
def two(tmp_path_factory: pytest.TempPathFactory):  # type: ignore[no-untyped-def]
    return make_notebook(tmp_path_factory.mktemp("app"), 0, two_robots=True)


def test_the_base_is_the_version_most_trials_were_driven_with_and_says_so(two) -> None:  # type: ignore[no-untyped-def]
    with Notebook(two.db) as nb:
        sel = select(nb, SelectionRequest(robot="jaguar-lite"))
        base = choose_base(nb, "jaguar-lite", sel.trials)
        assert nb.latest_params_version("jaguar-lite") == 4  # the validation runs' own
        # parameters the user names win, and the reason says whose they are
        named = choose_base(nb, "jaguar-lite", sel.trials, PRESETS["jaguar-lite"], "--params x")
    assert base.version == 1 and base.params == ROBOT_A
    n1 = sum(1 for t in sel.measured if t.params == ROBOT_A)
    assert f"version 1, the one most of its measured trials were driven with ({n1} of " in (
        base.reason
    )
    assert "the others: version 2 (3)" in base.reason
    assert named.version is None and named.reason == "--params x (named by the user)"


def test_the_robot_of_a_calibration(two) -> None:  # type: ignore[no-untyped-def]
    with Notebook(two.db) as nb:
        trials = select(nb).trials
        with pytest.raises(CalibrationError, match=r"of 2 robots \(jaguar-lite, rover-b\)"):
            choose_robot(trials, None, None)
        assert choose_robot(trials, None, ROBOT_A) == "jaguar-lite"
        assert choose_robot(trials, "rover-b", ROBOT_A) == "rover-b"
        with pytest.raises(StoreError, match="no parameters of robot 'nobody'"):
            calibrate(nb, CalibrationRequest("ratios", robot="nobody"))
        with pytest.raises(CalibrationError, match="method is 'lsq'; expected one of ratios"):
            calibrate(nb, CalibrationRequest("lsq", robot="rover-b"))


def test_a_selection_leaves_validation_out_and_filters_a_robot(two) -> None:  # type: ignore[no-untyped-def]
    with Notebook(two.db) as nb:
        every = select(nb)
        b = select(nb, SelectionRequest(robot="rover-b"))
        named = select(nb, SelectionRequest(campaigns=(VALIDATION,)))
    assert VALIDATION not in every.used
    assert every.left_out[VALIDATION].startswith("validation campaign")
    assert {t.params.name for t in b.trials} == {"rover-b"} and b.other_robots == ("jaguar-lite",)
    assert set(b.used) == {"rotation-b", "translation-b", "square-b", "rotation-b2"}
    assert "(robot rover-b)" in b.describe()
    assert set(named.used) == {VALIDATION}


def test_a_missing_notebook_is_one_sentence(tmp_path: Path) -> None:
    with raises_worded(StoreError, match=r"no-such\.db: no such lab notebook; give --db FILE"):
        open_notebook(tmp_path / "no-such.db")


def test_which_parameters_a_log_is_integrated_with(tmp_path: Path) -> None:
    log = tmp_path / "log.csv"
    log.write_text("t,left_ticks,right_ticks\n0,0,0\n1,10,10\n", encoding="utf-8")
    default = choose_params([log], None)
    assert default.by == "default" and default.params == PRESETS["jaguar-lite"]
    assert default.source == "preset jaguar-lite"
    preset = choose_params([log], "jaguar-lite")
    assert preset.by == "user" and "the default" not in preset.describe()
    toml = save_params(tmp_path / "p.toml", ROBOT_A, provenance={"notebook_version": 7})
    chosen = choose_params([log], str(toml))
    assert chosen.source == str(toml) and chosen.version == "notebook version 7"
    # a run.json that is not JSON is one sentence naming it, never a traceback
    (tmp_path / "run.json").write_text("{not json", encoding="utf-8")
    with pytest.raises(ParamsError, match=r"run\.json: cannot read the run's parameters"):
        choose_params([log], None)
    (tmp_path / "run.json").write_text(json.dumps({"params": {"track_width": 1}}))
    with pytest.raises(ParamsError, match="missing key"):
        choose_params([log], None)
    # many logs: no one run folder speaks for them all
    assert choose_params([log, log], None).by == "default"


def test_an_export_request_is_checked() -> None:
    with pytest.raises(StoreError, match="format is 'xlsx'; expected one of csv, json"):
        ExportRequest("xlsx").checked()
    with pytest.raises(StoreError, match="kind is 'hop'; expected one of"):
        ExportRequest("csv", kind="hop").checked()
    assert ExportRequest("json", campaign="").checked().campaign is None
