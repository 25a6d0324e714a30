"""The hostile corpus through the CLI (issue 39, items 1 and 2): one sentence, exit 1, no
traceback and no warning; what was already recorded is left as it was."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import pytest

from hostile.corpus import CASES, damaged_notebook, empty_database, notebook_json, prepare
from odolab.cli import main


def _one_sentence(args: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    capsys.readouterr()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's overflow warning reached the user
        code = main(args)
    captured = capsys.readouterr()
    assert code == 1, captured
    err = captured.err.strip().splitlines()
    assert err and err[-1].startswith("odolab: error: "), captured.err[-2000:]
    assert "Traceback" not in captured.err
    return err[-1]


def test_calibrate_lsq_on_a_truth_file_with_only_its_header(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # item 1: IndexError in calibration/lsq.py (gt.t[0]); evaluate said a sentence
    log = prepare(CASES["csv-run/truth-header-only"], tmp_path)
    line = _one_sentence(
        ["calibrate", "lsq", str(log), "-f", "csv", "-o", str(tmp_path / "p.toml")], capsys
    )
    assert "run_gt.csv: no poses after the header; expected at least one row" in line
    assert not (tmp_path / "p.toml").exists()


def test_odometry_of_an_optiodom_run_with_huge_increments(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # was integrated: heading 34,275,266 rad, exit 0
    run = prepare(CASES["optiodom/huge-increments"], tmp_path)
    out = tmp_path / "traj.csv"
    line = _one_sentence(["odometry", str(run), "--format", "optiodom", "-o", str(out)], capsys)
    assert "the left increment of 999999999 counts" in line and "expected at most 20 m/s" in line
    assert not out.exists()


@pytest.mark.parametrize(
    ("case", "expected"),
    [
        ("tum/zero-quaternion", "has length 0; expected a unit quaternion"),
        ("tum/position-1e308", "position x is 1e+308 m; expected a number of metres"),
        ("tum/constant-time", "expected times that advance"),
    ],
)
def test_evaluate_a_hostile_tum_file(
    case: str, expected: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the zero quaternion was heading 0, 1e308 gave numpy's warning and APE/RPE, exit 0
    gt = prepare(CASES[case], tmp_path)
    est = prepare(CASES["trajectory-csv/constant-time"], tmp_path / "est")
    est.write_text("t,x,y,theta\n0,0,0,0\n1,1,0,0\n2,2,0,0\n")
    assert expected in _one_sentence(["evaluate", str(gt), str(est)], capsys)


@pytest.mark.parametrize("case", ["encoder-csv/constant-time", "encoder-csv/time-1e308"])
def test_odometry_of_an_encoder_log_whose_time_does_not_advance(
    case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = prepare(CASES[case], tmp_path)
    out = tmp_path / "traj.csv"
    line = _one_sentence(["odometry", str(log), "-o", str(out)], capsys)
    assert "enc.csv: " in line and "expected" in line
    assert not out.exists()


@pytest.mark.parametrize("schema", ["absent", "null"])
def test_trials_import_of_a_notebook_json_without_its_schema(
    schema: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    def change(doc: dict[str, object]) -> None:
        if schema == "absent":
            del doc["schema"]
        else:
            doc["schema"] = None

    p = notebook_json(tmp_path, change)
    db = tmp_path / "into.db"
    line = _one_sentence(["trials", "import", str(p), "--db", str(db)], capsys)
    assert "expected the schema number (1 to 3)" in line
    if db.exists():
        assert main(["trials", "list", "--db", str(db)]) == 0
        assert "T0" not in capsys.readouterr().out  # nothing imported


@pytest.mark.parametrize(
    "args",
    [["trials", "list"], ["analyze"], ["trials", "export", "OUT"], ["trials", "campaigns"]],
)
def test_reading_an_empty_database_writes_nothing_into_it(
    args: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    db = empty_database(tmp_path)
    before = db.read_bytes()
    args = [str(tmp_path / "out.csv") if a == "OUT" else a for a in args]
    line = _one_sentence([*args, "--db", str(db)], capsys)
    assert "is an empty SQLite database, not an odolab notebook" in line
    assert db.read_bytes() == before  # odolab's tables were written into it
    assert not Path(f"{db}-wal").exists()


@pytest.mark.parametrize("args", [["trials", "list"], ["analyze"], ["trials", "show", "T3"]])
def test_a_notebook_that_fails_the_integrity_check_is_refused(
    args: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # one damaged page (512 zeroed bytes) was read with no warning
    db = damaged_notebook(tmp_path)
    before = db.read_bytes()
    line = _one_sentence([*args, "--db", str(db)], capsys)
    assert f"{db}: the notebook is damaged (SQLite: " in line
    assert f"odolab notebook rescue NEW.db --db {db}" in line
    assert db.read_bytes() == before
    # `notebook info` still opens it, and says what the integrity check says
    assert main(["notebook", "info", "--db", str(db)]) == 0
    assert "integrity 'ok'" not in capsys.readouterr().out


def test_the_untouched_export_carries_its_schema(tmp_path: Path) -> None:
    p = notebook_json(tmp_path, lambda doc: None)
    assert json.loads(p.read_text())["schema"] == 3  # the untouched export reads
