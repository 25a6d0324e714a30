"""The web's second lines (issue 39, item 6): a write from another site is refused whatever
token it carries; the Host check takes only a host and a port; NUL is refused at every entry;
a form python-multipart cannot read is a sentence; SIGTERM ends the server with status 0 (the
last is in test_connections.py)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from odolab.store import Notebook

from .test_security import client_for, csrf_of


@pytest.mark.parametrize(
    "headers",
    [
        {"origin": "https://evil.example"},
        {"origin": "null"},
        {"origin": "http://127.0.0.1:9999"},  # another program on this computer
        {"sec-fetch-site": "cross-site"},
        {"sec-fetch-site": "same-site"},
    ],
)
def test_writes_from_another_site_are_refused_on_the_api_and_forms(
    lab_db: Path, headers: dict[str, str]
) -> None:
    c = client_for(lab_db)
    token = csrf_of(c.get("/trial?id=R1").text)
    api = c.post("/api/trials/R1/exclude", json={"reason": "forged"}, headers=headers)
    assert api.status_code == 403
    assert api.json()["error"].startswith("a write from another site is refused (")
    form = c.post(
        "/trial/exclude",
        data={"id": "R1", "reason": "forged", "csrf": token},  # a valid CSRF token
        headers=headers,
        follow_redirects=False,
    )
    assert form.status_code == 403 and "a write from another site is refused" in form.text
    with Notebook(lab_db) as nb:
        assert nb.get_trial("R1").exclusion_reason is None
    assert c.get("/api/trials", headers=headers).status_code == 200  # reading is not a write


def test_writes_from_this_server_or_a_plain_client_pass(lab_db: Path) -> None:
    c = client_for(lab_db)
    ok = c.post(
        "/api/trials/R1/exclude",
        json={"reason": "slipped"},
        headers={"origin": "http://127.0.0.1:8000", "sec-fetch-site": "same-origin"},
    )
    assert ok.status_code == 200
    assert c.post("/api/trials/R1/include", json={}).status_code == 200  # no Origin: curl


@pytest.mark.parametrize(
    "host", ["[::1].evil.example", "[::1]evil.example:80", "[::1]:80x", "127.0.0.1:8000@evil"]
)
def test_the_host_check_takes_a_host_and_a_port_only(lab_db: Path, host: str) -> None:
    c = client_for(lab_db)
    r = c.get("/api/trials", headers={"host": host})
    assert r.status_code == 400 and "answers only to" in r.json()["error"]


def test_nul_is_refused_at_every_entry_and_the_export_reads_back(
    lab_db: Path, tmp_path: Path
) -> None:
    c = client_for(lab_db)
    r = c.post("/api/trials/R4/exclude", json={"reason": "a\x00b"})
    assert r.status_code == 400
    assert r.json()["error"] == (
        "excluding trial R4: the reason has a NUL character (character 2); expected text "
        "without NUL characters"
    )
    token = csrf_of(c.get("/trial?id=R4").text)
    form = c.post("/trial/exclude", data={"id": "R4", "reason": "x\x00", "csrf": token})
    assert form.status_code == 400 and "NUL character" in form.text
    with Notebook(lab_db) as nb:
        assert nb.get_trial("R4").exclusion_reason is None
        with pytest.raises(Exception, match="campaign: notes has a NUL character"):
            nb.add_campaign("nul-lab", "rotation", "lab", notes="\x00")
        nb.export_json(tmp_path / "all.json")
    doc = json.loads((tmp_path / "all.json").read_text())
    doc["trials"][0]["notes"] = "from\x00json"
    (tmp_path / "all.json").write_text(json.dumps(doc))
    with Notebook(tmp_path / "new.db") as nb, pytest.raises(Exception, match="NUL character"):
        nb.import_json(tmp_path / "all.json")


def test_an_unreadable_form_is_a_sentence(lab_db: Path) -> None:
    c = client_for(lab_db)
    r = c.post(
        "/data/import",
        data={"csrf": csrf_of(c.get("/data").text)},
        files={"file": ("a" * 5000 + ".csv", b"trial_id\n", "text/csv")},
    )
    assert r.status_code == 400
    assert "Invalid multipart data.</" not in r.text  # python-multipart's bare words
    assert "the form could not be read (invalid multipart data): a header line" in r.text
    with Notebook(lab_db) as nb:
        assert len(nb.trial_ids()) == 10
