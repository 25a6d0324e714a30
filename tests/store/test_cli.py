"""The notebook from the command line: entry in the lab's terms, refusals as one line."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from typer.testing import CliRunner

from odolab.cli import app, main
from odolab.cli.wording import CLI, worded
from odolab.store import Notebook

from .conftest import make_trials


def run_ok(*args: str, input: str | None = None) -> str:
    result = CliRunner().invoke(app, list(args), input=input)
    assert result.exit_code == 0, (result.output, result.exception)
    return result.output


def test_enter_a_lab_session(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    db = str(tmp_path / "lab.db")
    assert "created" in run_ok("notebook", "init", "--db", db)
    run_ok("trials", "campaign-add", "rot-lab", "--kind", "rotation", "--terrain", "lab",
           "--operator", "A.B.", "--db", db)  # fmt: skip
    run_ok("trials", "add", "--id", "R1", "--campaign", "rot-lab", "--kind", "rotation",
           "--angle-pi", "20", "--predicted-heading", "63.1", "--db", db)  # fmt: skip
    # typed at the terminal: an out-of-range reading is refused and asked again, then a
    # miscounted turn is refused (with the count that would fit), then the right readings
    out = run_ok("trials", "measure", "R1", "--db", db,
                 input="400\n200\n290\n1\n200\n290\n8\n")  # fmt: skip
    assert "refused: compass initial reading is 400 deg" in out
    assert "about 9 would fit" in out
    assert "17.50 pi" in out
    with Notebook(db) as nb:
        m = nb.get_trial("R1").measured
        assert m is not None and m.rotation == pytest.approx(17.5 * math.pi)
        assert m.raw == {"compass_initial_deg": 200.0, "compass_final_deg": 290.0, "turns": 8.0}
    listing = run_ok("trials", "list", "--db", db)
    assert "R1" in listing and "[compass]" in listing and "measured" in listing
    # non-interactive refusals are one line on stderr and exit 1; nothing changes
    assert main(["trials", "measure", "R1", "--initial", "10", "--final", "20", "--turns", "8",
                 "--replace", "--db", db]) == 0  # fmt: skip
    capsys.readouterr()
    code = main(["trials", "add", "--id", "F1", "--campaign", "fwd", "--terrain", "grass",
                 "--create-campaign", "--kind", "translation", "--distance", "2.5",
                 "--predicted-x", "2.49", "--x", "274", "--y", "0", "--db", db])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 1
    assert err.count("\n") == 1 and "typed in cm or mm" in err and "Traceback" not in err
    assert main(["trials", "exclude", "R1", "--reason", "box moved", "--db", db]) == 0
    with Notebook(db) as nb:
        assert [t.trial_id for t in nb.load_trials()] == ["R1"]
        assert nb.get_trial("R1").exclusion_reason == "box moved"


def test_import_export_and_versions(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    db = tmp_path / "a.db"
    with Notebook(db) as nb:
        nb.add_trials(make_trials(10, with_logs=True))
    assert main(["trials", "export", str(tmp_path / "a.json"), "--db", str(db)]) == 0
    assert main(["trials", "export", str(tmp_path / "a.csv"), "--status", "measured",
                 "--db", str(db)]) == 0  # fmt: skip
    assert "5 trials exported" in capsys.readouterr().out
    assert main(["trials", "import", str(tmp_path / "a.json"), "--db", str(tmp_path / "b.db")]) == 0
    assert main(["trials", "import", str(tmp_path / "a.csv"), "--db", str(tmp_path / "c.db")]) == 1
    assert "unknown campaign 'rot-lab'" in capsys.readouterr().err
    assert main(["trials", "import", str(tmp_path / "a.csv"), "--create-campaigns",
                 "--db", str(tmp_path / "c.db")]) == 0  # fmt: skip
    assert main(["trials", "params-add", "jaguar-lite", "--method", "preset", "--source-trial",
                 "T00000", "--db", str(db)]) == 0  # fmt: skip
    capsys.readouterr()
    assert main(["trials", "params-versions", "jaguar-lite", "--db", str(db)]) == 0
    out = capsys.readouterr().out
    assert "v2" in out and "preset from T00000" in out
    assert main(["notebook", "info", "--db", str(tmp_path / "b.db")]) == 0
    assert (
        "trials 10 (awaiting 4, excluded 1, measured 5), encoder logs 10" in capsys.readouterr().out
    )
    assert main(["trials", "list", "--db", str(tmp_path / "none.db")]) == 1
    assert "no such notebook" in capsys.readouterr().err
    assert not (tmp_path / "none.db").exists()


def test_calibrated_file_becomes_a_new_version_of_the_robot(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # docs/notebook.md: a calibration's TOML (named jaguar-lite-ratios) becomes version 2 of
    # jaguar-lite when added with --robot
    db = str(tmp_path / "lab.db")
    new = str(tmp_path / "calibrated.toml")
    assert main(["trials", "params-add", "jaguar-lite", "--method", "preset", "--db", db]) == 0
    assert main(["calibrate", "ratios", "-p", "jaguar-lite", "--distance-ratio", "0.905",
                 "--rotation-ratio", "0.875", "-o", new]) == 0  # fmt: skip
    assert main(["trials", "params-add", new, "--robot", "jaguar-lite", "--method", "ratios",
                 "--db", db]) == 0  # fmt: skip
    assert "jaguar-lite parameters version 2 (ratios)" in capsys.readouterr().out
    assert main(["trials", "params-versions", "jaguar-lite", "--db", db]) == 0
    out = capsys.readouterr().out
    assert "v2" in out and "ratios" in out
    assert "0.0755675" in out  # 0.905 * 0.0835


def test_measure_refuses_a_measured_trial_before_asking(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    db = str(tmp_path / "lab.db")
    run_ok("trials", "add", "--id", "R1", "--campaign", "rot", "--terrain", "tile", "--create-campaign", "--kind",
           "rotation", "--angle-pi", "20", "--predicted-heading", "63.1", "--initial", "200",
           "--final", "290", "--turns", "8", "--db", db)  # fmt: skip
    result = CliRunner().invoke(app, ["trials", "measure", "R1", "--db", db], input="10\n")
    assert result.exit_code != 0
    assert "compass initial reading" not in result.output  # nothing asked
    assert "already measured" in str(result.exception)
    # with --replace the readings are asked for and the new one is kept
    out = run_ok("trials", "measure", "R1", "--replace", "--db", db, input="200\n290\n9\n")
    assert "19.50 pi" in out  # 9 turns + 270 deg = 19.5 pi


def test_add_with_a_nan_heading_is_one_line(tmp_path: Path) -> None:
    db = str(tmp_path / "lab.db")
    result = CliRunner().invoke(
        app,
        ["trials", "add", "--id", "B", "--campaign", "c", "--terrain", "tile",
         "--create-campaign", "--kind", "rotation", "--angle-pi", "2",
         "--predicted-heading", "nan", "--db", db],
    )  # fmt: skip
    assert result.exit_code != 0
    assert "--predicted-heading" in CLI.error(result.exception)  # the sentence the CLI prints


def test_compass_readings_for_a_translation_are_refused(tmp_path: Path) -> None:
    db = str(tmp_path / "lab.db")
    run_ok("trials", "add", "--id", "D", "--campaign", "c", "--terrain", "tile",
           "--create-campaign", "--kind", "translation", "--distance", "1", "--predicted-x", "1",
           "--db", db)  # fmt: skip
    result = CliRunner().invoke(
        app, ["trials", "measure", "D", "--initial", "10", "--final", "20", "--turns", "1",
              "--db", db], input="0.9\n0.01\n")  # fmt: skip
    assert result.exit_code != 0
    assert "measured with --x and --y" in worded(result.exception)  # as the CLI prints it
    assert "x by meterstick" not in result.output  # nothing asked
