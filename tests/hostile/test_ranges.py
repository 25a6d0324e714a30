"""Implausible numbers are refused the same way on every entry path: a parameters TOML, a CSV
import, a JSON import and ``trials add``; each refusal is one line naming where."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from odolab.cli import main
from odolab.store import Notebook

GOOD = {
    "left_wheel_radius": "0.0835",
    "right_wheel_radius": "0.0835",
    "track_width": "0.56",
    "ticks_per_rev": "380",
}


def _error(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert err.startswith("odolab: error: ") and err.count("\n") == 1, err
    return err


@pytest.mark.parametrize(
    ("key", "value", "needle"),
    [
        ("left_wheel_radius", "8.35", "a radius of 8.35 m looks like centimetres: 0.0835 m?"),
        ("track_width", "56", "a track width of 56 m looks like centimetres: 0.56 m?"),
        ("right_wheel_radius", "835", "looks like millimetres: 0.835 m?"),
        ("track_width", "5e-324", "track_width = 4.94066e-324 m is outside the plausible 0.01"),
        ("left_wheel_radius", "1e308", "left_wheel_radius = 1e+308 m is outside the plausible"),
        ("ticks_per_rev", "1e-300", "ticks_per_rev = 1e-300 counts per revolution is outside"),
        ("ticks_per_rev", "1e12", "outside the plausible 1 to 1e+08 counts per revolution"),
        ("encoder_modulus", str(2**70), "encoder_modulus must be an integer >= 2 (at most 2^63)"),
    ],
)
def test_implausible_parameters_in_a_toml_are_refused_with_a_unit_hint(
    tmp_path: Path, key: str, value: str, needle: str, capsys: pytest.CaptureFixture[str]
) -> None:
    doc = {**GOOD, key: value}
    path = tmp_path / "p.toml"
    path.write_text("[robot]\n" + "".join(f"{k} = {v}\n" for k, v in doc.items()))
    assert main(["params", "show", str(path)]) == 1
    err = _error(capsys)
    assert str(path) in err and needle in err


HEADER = (
    "trial_id,campaign,terrain,kind,distance_m,predicted_x_m,predicted_y_m,"
    "predicted_heading_rad,robot,left_wheel_radius_m,right_wheel_radius_m,track_width_m,"
    "ticks_per_rev,measured_x_m,measured_y_m"
)
ROW = "T1,c,lab,translation,1.0,1.0,0,0,jag,0.0835,0.0835,0.56,380,1.01,0.02"


@pytest.mark.parametrize(
    ("change", "needle"),
    [
        (("1.01", "1e308"), "line 2, column 'measured_x_m': measured_x_m is 1e+308 m; a measured "
         "position must be within 100 m"),
        ((",0.02", ",-250"), "line 2, column 'measured_y_m': measured_y_m is -250 m"),
        (("translation,1.0,", "translation,,"), "line 2, column 'distance_m': missing value (a "
         "translation needs its commanded distance)"),
        ((",0.56,", ",56,"), "line 2, column 'track_width_m': track_width = 56 m is outside the "
         "plausible 0.01 to 20 m; a track width of 56 m looks like centimetres: 0.56 m?"),
        ((",380,", ",1e-300,"), "line 2, column 'ticks_per_rev': ticks_per_rev = 1e-300 counts per"),
    ],
)  # fmt: skip
def test_csv_import_refuses_what_trials_add_refuses(
    tmp_path: Path, change: tuple[str, str], needle: str, capsys: pytest.CaptureFixture[str]
) -> None:
    db = tmp_path / "lab.db"
    good = tmp_path / "good.csv"
    good.write_text(f"{HEADER}\n{ROW}\n")
    args = ["--create-campaigns", "--db", str(db)]
    assert main(["trials", "import", str(good), *args]) == 0
    bad = tmp_path / "bad.csv"
    bad.write_text(f"{HEADER}\n{ROW.replace(*change).replace('T1', 'T2')}\n")
    capsys.readouterr()
    assert main(["trials", "import", str(bad), *args]) == 1
    err = _error(capsys)
    assert f"{bad}: {needle}" in err
    with Notebook(db) as nb:
        assert nb.trial_ids() == {"T1"}  # nothing written, nothing lost


def test_trials_add_refuses_the_same(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    db = str(tmp_path / "lab.db")
    base = ["trials", "add", "--campaign", "c", "--terrain", "lab", "--create-campaign",
            "--kind", "translation", "--db", db]  # fmt: skip
    assert main([*base, "--id", "T1", "--distance", "1", "--x", "1e308", "--y", "0"]) == 1
    assert "x is 1e+308 m; a measured position must be within 100 m" in _error(capsys)
    assert main([*base, "--id", "T2"]) == 1
    assert "a translation needs --distance" in _error(capsys)


@pytest.mark.parametrize(
    ("path", "value", "needle"),
    [
        (("trials", 0, "measured_x"), 1e308, "trials[0]: measured_x is 1e+308 m; a measured"),
        (("trials", 0, "distance"), None, "trials[0]: key 'distance' is null; a translation"),
        (("params_versions", 0, "track_width"), 56.0, "params_versions[0]: track_width = 56 m "
         "is outside the plausible 0.01 to 20 m; a track width of 56 m looks like centimetres"),
        (("params_versions", 0, "ticks_per_rev"), 5e-324, "params_versions[0]: ticks_per_rev"),
    ],
)  # fmt: skip
def test_json_import_refuses_what_trials_add_refuses(
    tmp_path: Path,
    path: tuple[str, int, str],
    value: float | None,
    needle: str,
    capsys: pytest.CaptureFixture[str],
) -> None:
    src = tmp_path / "src.db"
    good = tmp_path / "good.csv"
    good.write_text(f"{HEADER}\n{ROW}\n")
    assert main(["trials", "import", str(good), "--create-campaigns", "--db", str(src)]) == 0
    exported = tmp_path / "nb.json"
    assert main(["trials", "export", str(exported), "--db", str(src)]) == 0
    doc = json.loads(exported.read_text())
    table, index, key = path
    doc[table][index][key] = value
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(doc))
    capsys.readouterr()
    db = tmp_path / "new.db"
    assert main(["trials", "import", str(bad), "--db", str(db)]) == 1
    assert f"{bad}: {needle}" in _error(capsys)
    with Notebook(db) as nb:
        assert nb.trial_ids() == set()
