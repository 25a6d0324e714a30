"""The one trial-record definition (odolab.core.trials.TRIAL_FIELDS) agrees with every place it feeds."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import pytest

from odolab.core.trials import TRIAL_FIELDS, FieldType, trial_field
from odolab.store import Notebook
from odolab.store.csvio import COLUMNS, REQUIRED
from odolab.store.records import NUMERIC_COLUMNS, TRIAL_COLUMNS

from .conftest_trials import one_trial


def test_the_sql_table_has_the_fields_names_types_and_not_nulls(tmp_path: Path) -> None:
    with Notebook(tmp_path / "n.db"):
        pass
    conn = sqlite3.connect(tmp_path / "n.db")
    info = {r[1]: (r[2], bool(r[3] or r[5])) for r in conn.execute("PRAGMA table_info(trials)")}
    conn.close()
    stamps = {"created", "updated"}
    assert [c for c in info if c not in stamps] == [f.name for f in TRIAL_FIELDS]
    for f in TRIAL_FIELDS:
        sql_type, not_null = info[f.name]
        assert sql_type == f.sql_type, f.name
        if f.required:  # a required field is NOT NULL (or the primary key) in SQL
            assert not_null, f.name


def test_csv_headers_and_units_come_from_the_fields() -> None:
    for f in TRIAL_FIELDS:
        if f.type is FieldType.JSON:
            continue  # raw readings: compass columns and raw_<key>
        assert f.csv in COLUMNS, f.name
        assert COLUMNS[f.csv] == f.unit, f.name
        if f.unit:
            assert f.csv.endswith("_" + f.unit), f.name  # the unit is in the header
    assert set(REQUIRED) == {f.csv for f in TRIAL_FIELDS if f.required} - {"status"}


def test_record_columns_and_json_keys_are_the_field_names(tmp_path: Path) -> None:
    assert tuple(f.json_key for f in TRIAL_FIELDS) == TRIAL_COLUMNS
    assert set(NUMERIC_COLUMNS) == {f.name for f in TRIAL_FIELDS if f.numeric}
    with Notebook(tmp_path / "n.db") as nb:
        nb.add_trial(one_trial())
        nb.export_json(tmp_path / "n.json")
    rec = json.loads((tmp_path / "n.json").read_text())["trials"][0]
    assert [k for k in rec if k in TRIAL_COLUMNS] == list(TRIAL_COLUMNS)


@pytest.mark.parametrize(
    ("name", "inside", "outside"),
    [
        ("measured_x", 100.0, 100.0001),  # MAX_POSITION_M, as `odolab trials add`
        ("sigma_xy", 0.0, -1e-12),
        ("predicted_theta", 3.141592653589793, 3.1416),
        ("params_version", 1, 0),
    ],
)
def test_ranges_are_inclusive_at_the_documented_bounds(
    name: str, inside: float, outside: float
) -> None:
    from odolab.core.errors import InvalidTrialError
    from odolab.core.trials import check_field

    check_field(name, inside, "here")
    with pytest.raises(InvalidTrialError) as info:
        check_field(name, outside, "here")
    assert info.value.field == name and str(info.value).startswith(f"here: {name} is ")
    assert trial_field(name).low is not None
