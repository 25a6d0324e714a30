"""CSV and JSON import/export: identical records after a round trip; bad input refused."""

from __future__ import annotations

import dataclasses
import hashlib
import sqlite3
from pathlib import Path

import pytest

from odolab.core.errors import StoreError
from odolab.core.trials import MotionKind
from odolab.store import Notebook, rotation_measurement_from_compass
from odolab.store.csvio import COLUMNS

from .conftest import fingerprint, make_trials


def _dump(db: Path) -> str:
    """A digest of every row of every table."""
    conn = sqlite3.connect(db)
    h = hashlib.sha256()
    for (name,) in conn.execute("SELECT name FROM sqlite_master WHERE type='table' ORDER BY name"):
        for row in conn.execute(f"SELECT * FROM {name} ORDER BY rowid"):
            h.update(repr(row).encode())
    conn.close()
    return h.hexdigest()


def _filled(nb: Notebook) -> list:
    nb.add_campaign("fwd-grass", "translation", "grass", date="2019-03-11")
    trials = make_trials(15, with_logs=True) + make_trials(
        6, prefix="F", campaign="fwd-grass", terrain="grass", kind=MotionKind.TRANSLATION
    )
    nb.add_trials(trials)
    return trials


def test_csv_export_then_import_gives_identical_records(tmp_path: Path) -> None:
    with Notebook(tmp_path / "a.db") as a:
        trials = _filled(a)
        assert a.export_csv(tmp_path / "t.csv") == 21
        frame_a = a.trials_frame(include_excluded=True)
    with Notebook(tmp_path / "b.db") as b:
        for c in ("rot-lab", "fwd-grass"):
            b.add_campaign(c, "free", "x")
        assert b.import_csv(tmp_path / "t.csv", batch_size=4) == 21
        back = b.load_trials()
        frame_b = b.trials_frame(include_excluded=True)
        # the CSV does not carry encoder logs (JSON does); everything else is identical
        assert [fingerprint(t, logs=False) for t in back] == [
            fingerprint(t, logs=False) for t in trials
        ]
        cols = [c for c in frame_a.columns if c not in ("has_encoder_log", "campaign_date")]
        assert frame_a[cols].equals(frame_b[cols])
        # and exporting again gives the same file
        b.export_csv(tmp_path / "t2.csv")
    assert (tmp_path / "t.csv").read_bytes() == (tmp_path / "t2.csv").read_bytes()


def test_json_export_then_import_gives_identical_records(tmp_path: Path) -> None:
    with Notebook(tmp_path / "a.db") as a:
        trials = _filled(a)
        a.add_params_version(trials[0].params.with_(track_width=0.64), method="ratios",
                             source_trials=["T00000", "T00002"])  # fmt: skip
        a.set_measurement("T00002", rotation_measurement_from_compass(1.0, 2.0, 3), replace=True)
        trials[2] = dataclasses.replace(
            trials[2], measured=rotation_measurement_from_compass(1.0, 2.0, 3)
        )
        history_a = a.measurement_history("T00002")
        a.export_json(tmp_path / "nb.json")
        versions_a = a.params_versions("jaguar-lite")
        campaigns_a = a.campaigns()
        rows_a = a._conn.execute("SELECT * FROM trials ORDER BY rowid").fetchall()
    with Notebook(tmp_path / "b.db") as b:
        assert b.import_json(tmp_path / "nb.json") == 21
        assert [fingerprint(t) for t in b.load_trials()] == [fingerprint(t) for t in trials]
        assert b.params_versions("jaguar-lite") == versions_a
        assert b.campaigns() == campaigns_a
        assert b.measurement_history("T00002") == history_a and len(history_a) == 1
        rows_b = b._conn.execute("SELECT * FROM trials ORDER BY rowid").fetchall()
        assert [tuple(r) for r in rows_b] == [tuple(r) for r in rows_a]
        # importing again: every id is taken, nothing changes
        before = b.info()
        with pytest.raises(StoreError, match="already in the notebook"):
            b.import_json(tmp_path / "nb.json")
        assert b.info() == before


HEADER = ",".join(COLUMNS)


def _good_rows() -> list[dict[str, str]]:
    base = dict.fromkeys(COLUMNS, "")
    r1 = base | {
        "trial_id": "R1",
        "campaign": "rot-lab",
        "terrain": "lab",
        "kind": "rotation",
        "angle_rad": "62.83185307179586",
        "predicted_x_m": "0.01",
        "predicted_y_m": "-0.02",
        "predicted_heading_rad": "63.0",
        "robot": "jaguar-lite",
        "left_wheel_radius_m": "0.0835",
        "right_wheel_radius_m": "0.0835",
        "track_width_m": "0.56",
        "ticks_per_rev": "380",
        "encoder_modulus": "32768",
        "compass_initial_deg": "200",
        "compass_final_deg": "290",
        "turns": "8",
    }
    r2 = r1 | {"trial_id": "R2", "compass_initial_deg": "", "compass_final_deg": "", "turns": ""}
    return [r1, r2]


def _write(path: Path, rows: list[dict[str, str]], header: list[str] | None = None) -> Path:
    import csv

    cols = header or list(COLUMNS)
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for r in rows:
            w.writerow([r.get(c, "") for c in cols])
    return path


def test_spreadsheet_rows_in_lab_terms(tmp_path: Path) -> None:
    with Notebook(tmp_path / "n.db") as nb:
        nb.add_campaign("rot-lab", "rotation", "lab")
        rows = _good_rows()
        rows[1]["angle_rad"] = "3.14159 rad"  # a cell may carry its own column's unit
        assert nb.import_csv(_write(tmp_path / "ok.csv", rows)) == 2
        r1 = nb.get_trial("R1")
        # 8 turns + (200 - 290) mod 360 = 270 deg ccw: 17.5 pi (the lab's 0.875 x 20 pi)
        assert r1.measured is not None and r1.measured.rotation == pytest.approx(17.5 * 3.14159265)
        assert r1.measured.instrument == "compass"
        assert r1.predicted.theta == pytest.approx(63.0 - 20 * 3.141592653589793)
        assert nb.get_trial("R2").measured is None
        assert nb.get_trial("R2").command.angle == 3.14159


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        # wrong unit, in the header and in a cell
        (("header", "distance_m", "distance_cm"),
         "line 1, column 'distance_cm' is in unit 'cm'; expected 'distance_m'"),
        ((2, "predicted_x_m", "12 cm"),
         "line 3, column 'predicted_x_m': '12 cm' has the wrong unit 'cm'; expected m"),
        ((1, "compass_final_deg", "1.5 rad"),
         "line 2, column 'compass_final_deg': '1.5 rad' has the wrong unit 'rad'"),
        # a missing value
        ((2, "predicted_heading_rad", ""), "line 3, column 'predicted_heading_rad': missing"),
        ((1, "turns", ""), "line 2, column 'turns': missing value"),
        # an unknown campaign
        ((2, "campaign", "rot-moon"), "line 3, column 'campaign': unknown campaign 'rot-moon'"),
        # a duplicate trial id, in the file and against the notebook
        ((2, "trial_id", "R1"), "line 3, column 'trial_id': 'R1' is a duplicate of line 2"),
        ((2, "trial_id", "OLD"), "line 3, column 'trial_id': 'OLD' is already in the notebook"),
        # text in a number column
        ((1, "track_width_m", "wide"), "line 2, column 'track_width_m': 'wide' is not a number"),
        # out-of-range readings, bad enums
        ((1, "compass_initial_deg", "361"), "line 2, column 'compass_initial_deg': 361 deg"),
        ((1, "turns", "2.5"), "line 2, column 'turns': '2.5'; expected a whole number"),
        ((1, "turns", "1"), "line 2, column 'turns': rotation of"),
        ((2, "kind", "spin"), "line 3, column 'kind': 'spin'; expected one of"),
        ((2, "status", "measured"), "line 3, column 'status': 'measured' but no measurement"),
        ((2, "status", "excluded"), "line 3, column 'exclusion_reason': missing value"),
        (("header", "colour", None), "line 1, unknown column 'colour'"),
        # the ranges of the trial record (odolab.core.trials.TRIAL_FIELDS), as for `trials add`
        ((2, "predicted_theta_rad", "7"),
         "line 3, column 'predicted_theta_rad': predicted_theta is 7 rad; expected -3.14159"),
        ((2, "kind", "translation"),
         "line 3, column 'distance_m': missing value (a translation needs its commanded distance)"),
        ((2, "angle_rad", ""), "line 3, column 'angle_rad': a rotation command needs its angle"),
        ((1, "sigma_rotation_rad", "5"),
         "line 2, column 'sigma_rotation_rad': sigma_rotation is 5 rad; expected 0 rad to 3.14159 rad"),
    ],
)  # fmt: skip
def test_bad_csv_gets_one_clear_error_and_changes_nothing(
    tmp_path: Path, edit: tuple, message: str
) -> None:
    db = tmp_path / "n.db"
    with Notebook(db) as nb:
        nb.add_campaign("rot-lab", "rotation", "lab")
        nb.add_trials(make_trials(3, with_logs=True))
        nb.add_trials(make_trials(1, prefix="OLD"))
        nb._conn.execute("UPDATE trials SET trial_id = 'OLD' WHERE trial_id = 'OLD00000'")
    before = _dump(db)
    rows = _good_rows()
    header = list(COLUMNS)
    where, col, value = edit
    if where == "header":
        header = [value if c == col else c for c in header] if value else [*header, col]
        for r in rows:
            r[value or col] = r.pop(col, "") if value else "red"
    else:
        rows[where - 1][col] = value
    path = _write(tmp_path / "bad.csv", rows, header)
    with Notebook(db) as nb, pytest.raises(StoreError) as info:
        nb.import_csv(path)
    assert message in str(info.value)
    assert str(info.value).startswith(str(path))
    assert "\n" not in str(info.value)
    assert _dump(db) == before


def test_params_by_version_only(tmp_path: Path) -> None:
    with Notebook(tmp_path / "n.db") as nb:
        nb.add_campaign("rot-lab", "rotation", "lab")
        p = make_trials(1)[0].params
        nb.add_params_version(p, method="preset")
        v2 = nb.add_params_version(p.with_(track_width=0.64), method="ratios")
        rows = _good_rows()
        for r in rows:
            for c in ("left_wheel_radius_m", "right_wheel_radius_m", "track_width_m",
                      "ticks_per_rev", "encoder_modulus"):  # fmt: skip
                r[c] = ""
            r["params_version"] = str(v2)
        nb.import_csv(_write(tmp_path / "v.csv", rows))
        assert nb.get_trial("R1").params.track_width == 0.64
        assert nb.trial_params_version("R1") == ("jaguar-lite", 2)
        rows[0]["trial_id"], rows[1]["trial_id"] = "S1", "S2"
        rows[1]["params_version"] = "9"
        with pytest.raises(StoreError, match="line 3, column 'params_version': version 9"):
            nb.import_csv(_write(tmp_path / "w.csv", rows))


def test_semicolon_spreadsheet_with_bom(tmp_path: Path) -> None:
    rows = _good_rows()
    path = tmp_path / "excel.csv"
    lines = [";".join(COLUMNS)] + [";".join(r[c] for c in COLUMNS) for r in rows]
    path.write_bytes(b"\xef\xbb\xbf" + "\r\n".join(lines).encode())
    with Notebook(tmp_path / "n.db") as nb:
        nb.add_campaign("rot-lab", "rotation", "lab")
        assert nb.import_csv(path) == 2
        assert nb.get_trial("R1").command.angle == pytest.approx(20 * 3.141592653589793)
        assert nb.params_versions("jaguar-lite")[0].method == "imported from excel.csv"


def test_bad_json_is_refused_and_changes_nothing(tmp_path: Path) -> None:
    db = tmp_path / "n.db"
    with Notebook(db) as nb:
        nb.add_trials(make_trials(3))
        nb.export_json(tmp_path / "a.json")
    before = _dump(db)
    (tmp_path / "b.json").write_text('{"format": "something-else", "params_versions": [], '
                                     '"campaigns": [], "trials": []}')  # fmt: skip
    (tmp_path / "c.json").write_text("{not json")
    text = (tmp_path / "a.json").read_text().replace('"trial_id": "T00001"', '"trial_id": "X"')
    (tmp_path / "d.json").write_text(text.replace('"predicted_x": ', '"predicted_x": "abc", "_": '))
    with Notebook(db) as nb:
        with pytest.raises(StoreError, match="format is 'something-else'"):
            nb.import_json(tmp_path / "b.json")
        with pytest.raises(StoreError, match="not valid JSON"):
            nb.import_json(tmp_path / "c.json")
        deep = tmp_path / "deep.json"  # a hostile file: Python's reader recursed to a crash
        deep.write_text('{"trials": ' + "[" * 100_000 + "]" * 100_000 + "}")
        with pytest.raises(StoreError, match=r"deep\.json: JSON nested too deeply"):
            nb.import_json(deep)
        # every key's type is checked first (reading the file), then against the notebook
        with pytest.raises(StoreError, match=r"trials\[0\], key 'predicted_x': 'abc'; expected"):
            nb.import_json(tmp_path / "d.json")
        with pytest.raises(StoreError, match=r"trials\[0\], key 'trial_id': 'T00000' is already"):
            nb.import_json(tmp_path / "a.json")
    assert _dump(db) == before
    with Notebook(tmp_path / "fresh.db") as nb:
        with pytest.raises(
            StoreError, match=r"trials\[0\], key 'predicted_x': 'abc'; expected a finite number"
        ):
            nb.import_json(tmp_path / "d.json")
        assert nb.info().trials == 0


def test_campaign_date_must_be_a_date(tmp_path: Path) -> None:
    with Notebook(tmp_path / "n.db") as nb, pytest.raises(StoreError, match="YYYY-MM-DD"):
        nb.add_campaign("c", "rotation", "lab", date="last tuesday")


def test_json_duplicate_inside_the_file_says_so(tmp_path: Path) -> None:
    import json

    with Notebook(tmp_path / "a.db") as a:
        _filled(a)
        a.export_json(tmp_path / "nb.json")
    doc = json.loads((tmp_path / "nb.json").read_text())
    doc["trials"][3]["trial_id"] = doc["trials"][1]["trial_id"]
    (tmp_path / "dup.json").write_text(json.dumps(doc))
    with Notebook(tmp_path / "b.db") as b:  # empty: "already in the notebook" would be wrong
        with pytest.raises(
            StoreError, match=r"trials\[3\], key 'trial_id': .* is a duplicate of trials\[1\]"
        ):
            b.import_json(tmp_path / "dup.json")
        assert not b.trial_ids()  # nothing imported


def _translation_row(**cells: str) -> dict[str, str]:
    row = _good_rows()[1] | {"kind": "translation", "angle_rad": "", "distance_m": "2.5",
                              "predicted_x_m": "2.5", "predicted_heading_rad": "0.01"}  # fmt: skip
    return row | cells


@pytest.mark.parametrize(
    ("cells", "message"),
    [
        # (measured positions, parameters and a missing distance: tests/hostile/test_ranges.py)
        ({"measured_x_m": "2.5", "measured_y_m": "0", "sigma_xy_m": "250"},
         "line 2, column 'sigma_xy_m': sigma_xy is 250 m; expected 0 m to 100 m"),
        ({"speed": "1e9"}, "line 2, column 'speed': speed is 1e+09; expected -100 to 100"),
        ({"distance_m": "-2e4"},
         "line 2, column 'distance_m': distance is -20000 m; expected -10000 m to 10000 m"),
        ({"true_x_m": "1", "true_y_m": "0", "true_heading_rad": "1e5"},
         "line 2, column 'true_heading_rad': true_heading is 100000 rad; expected -10000 rad to "
         "10000 rad"),
    ],
)  # fmt: skip
def test_csv_import_enforces_the_trial_record_ranges(
    tmp_path: Path, cells: dict[str, str], message: str
) -> None:
    path = _write(tmp_path / "t.csv", [_translation_row(**cells)])
    with Notebook(tmp_path / "n.db") as nb:
        nb.add_campaign("rot-lab", "translation", "lab")
        with pytest.raises(StoreError) as info:
            nb.import_csv(path)
        assert str(info.value) == f"{path}: {message}"
        assert nb.info().trials == 0


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ('"speed": 0.3', '"speed": 1e9',
         r"trials\[0\], key 'speed': trial F00000: speed is 1e\+09; expected -100 to 100"),
        ('"predicted_theta": ', '"predicted_theta": 7, "_": ',
         r"trials\[0\], key 'predicted_theta': trial F00000: predicted_theta is 7 rad"),
    ],
)  # fmt: skip
def test_json_import_enforces_the_trial_record_ranges(
    tmp_path: Path, old: str, new: str, message: str
) -> None:
    with Notebook(tmp_path / "a.db") as nb:
        nb.add_trials(make_trials(2, prefix="F", kind=MotionKind.TRANSLATION))
        nb.export_json(tmp_path / "a.json")
    text = (tmp_path / "a.json").read_text()
    assert old in text
    (tmp_path / "b.json").write_text(text.replace(old, new, 1))
    with Notebook(tmp_path / "b.db") as nb:
        with pytest.raises(StoreError, match=message):
            nb.import_json(tmp_path / "b.json")
        assert nb.info().trials == 0


def test_add_trials_refuses_what_import_refuses(tmp_path: Path) -> None:
    good = make_trials(1, prefix="F", kind=MotionKind.TRANSLATION)[0]
    far = dataclasses.replace(good, command=dataclasses.replace(good.command, distance=None))
    with Notebook(tmp_path / "n.db") as nb:
        with pytest.raises(StoreError, match="a translation command needs its distance"):
            nb.add_trials([far])
        assert nb.info().trials == 0
