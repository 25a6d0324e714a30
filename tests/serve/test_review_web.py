"""What a review of the web found (each test names the old behaviour): a right-to-left override
in a name reversed the page's own sentences; re-excluding a trial replaced its reason and
including it dropped it; a superscript digit as a version gave a 500; an unknown campaign was
200 on Table I; the API and pages named the CLI's flags; a long name widened the page."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from starlette.testclient import TestClient

from odolab.cli import main
from odolab.serve import ServeSettings, create_app
from odolab.store import Notebook

LOCAL = "http://127.0.0.1:8000"
RLO = "\u202e"


def _client(db: Path) -> TestClient:
    return TestClient(create_app(ServeSettings(db=db)), base_url=LOCAL)


@pytest.fixture
def hostile(lab_db: Path) -> Path:
    """The server tests' notebook with a campaign and a trial named with a right-to-left
    override and an escape sequence."""
    name = f"camp{RLO}live\x1b[31m"
    assert main(["trials", "campaign-add", name, "--kind", "translation", "--terrain",
                 f"ter{RLO}r", "--db", str(lab_db)]) == 0  # fmt: skip
    assert main(["trials", "add", "--id", f"T{RLO}1", "--campaign", name, "--kind",
                 "translation", "--distance", "2", "--predicted-x", "2", "--x", "1.9",
                 "--y", "0", "--db", str(lab_db)]) == 0  # fmt: skip
    return lab_db


@pytest.mark.parametrize("page", ["/", "/table1", "/data"])
def test_bidi_and_control_characters_are_shown_not_obeyed(hostile: Path, page: str) -> None:
    text = _client(hostile).get(page).text
    assert RLO not in text and "\x1b" not in text
    assert "camp\\u202elive\\x1b[31m" in text  # as the CLI shows it


def test_the_report_shows_them_too(hostile: Path, tmp_path: Path) -> None:
    assert main(["report", "--db", str(hostile), "--out", str(tmp_path / "rep")]) == 0
    text = (tmp_path / "rep" / "report.html").read_text(encoding="utf-8")
    assert RLO not in text and "camp\\u202elive" in text


def test_an_exclusion_reason_is_never_lost(lab_db: Path) -> None:
    c = _client(lab_db)
    url = f"{LOCAL}/api/trials/R1"
    assert c.post(f"{url}/exclude", json={"reason": "first: wheel slipped"}).status_code == 200
    assert c.post(f"{url}/exclude", json={"reason": "second"}).status_code == 200
    with Notebook(lab_db) as nb:
        (t,) = [t for t in nb.load_trials(with_logs=False) if t.trial_id == "R1"]
    assert t.exclusion_reason == "second; earlier: first: wheel slipped"
    assert c.post(f"{url}/include", json={}).status_code == 200
    with Notebook(lab_db) as nb:
        (t,) = [t for t in nb.load_trials(with_logs=False) if t.trial_id == "R1"]
    assert t.exclusion_reason is None
    assert re.search(r"excluded until \S+: second; earlier: first: wheel slipped$", t.notes)


def test_a_version_that_is_no_number_is_no_500(lab_db: Path) -> None:
    r = _client(lab_db).get("/calibrate", params={"robot": "jaguar-lite", "version": "\u00b2"})
    assert r.status_code == 200


def test_an_unknown_campaign_is_a_bad_request_in_the_webs_words(lab_db: Path) -> None:
    c = _client(lab_db)
    api = c.get("/api/table1", params={"campaign": "nope"})
    assert api.status_code == 400
    assert api.json()["error"].startswith("campaign nope: no such campaign")
    page = c.get("/table1", params={"campaign": "nope"})
    assert page.status_code == 400 and "campaign nope: no such campaign" in page.text
    assert "--campaign" not in page.text.split("<main", 1)[1]
    cal = c.post("/api/calibrate", json={"method": "ratios", "exclude_campaign": ["x"]})
    assert cal.status_code == 400 and cal.json()["error"].startswith("exclude_campaign x:")


def test_names_without_spaces_wrap() -> None:
    import odolab.serve

    css = (Path(odolab.serve.__file__).parent / "templates" / "base.html.j2").read_text()
    assert ".card strong, p, .muted { overflow-wrap:anywhere; }" in css
