"""Security of the server: the token, CSRF, escaping, uploads, the Host check."""

from __future__ import annotations

import re
from pathlib import Path
from urllib.parse import quote

import pytest
from markupsafe import escape
from starlette.testclient import TestClient

from odolab.serve import ServeSettings, create_app, is_loopback, settings_for
from odolab.serve.security import SESSION_COOKIE, TOKEN_COOKIE, csrf_token
from odolab.store import Notebook

from .conftest import (
    HOSTILE_CAMPAIGN,
    HOSTILE_REASON,
    HOSTILE_TRIAL,
    PATH_TRIAL,
    SCRIPT_TRIAL,
)

LOCAL = "http://127.0.0.1:8000"
TOKEN = "s3cret-token-for-the-test-0123456789abcdef"
PAGES = ["/", "/table1", "/params", "/calibrate", "/report", "/data"]


def client_for(db: Path, **kw: object) -> TestClient:
    return TestClient(create_app(ServeSettings(db=db, **kw)), base_url=LOCAL)  # type: ignore[arg-type]


def csrf_of(page: str) -> str:
    found = re.search(r'name="csrf" value="([0-9a-f]{64})"', page)
    assert found, "the form carries no CSRF token"
    return found.group(1)


# -- the token on a bind that is not loopback -------------------------------------------------


def test_settings_need_a_token_off_loopback(tmp_path: Path) -> None:
    for host in ("127.0.0.1", "localhost", "::1", "127.0.0.2"):
        assert is_loopback(host) and settings_for(tmp_path / "x.db", host).token is None
    for host in ("0.0.0.0", "192.168.1.20", "::", "lab-laptop.local"):
        s = settings_for(tmp_path / "x.db", host)
        assert not is_loopback(host)
        assert s.token is not None and len(s.token) >= 40 and s.allowed_hosts is None
    assert settings_for("a.db", "0.0.0.0").token != settings_for("a.db", "0.0.0.0").token


@pytest.mark.parametrize("path", [*PAGES, "/trial?id=R1", "/api/trials", "/api/table1",
                                  "/api/trials/R1", "/data/export?format=json",
                                  "/trial/plot.png?id=R1", "/params.toml?robot=jaguar-lite&version=1"])  # fmt: skip
def test_every_request_without_the_token_is_401(lab_db: Path, path: str) -> None:
    c = TestClient(
        create_app(ServeSettings(db=lab_db, token=TOKEN, allowed_hosts=None)),
        base_url="http://192.168.1.20:8000",
    )
    r = c.get(path)
    assert r.status_code == 401
    assert TOKEN not in r.text
    if path.startswith("/api/"):
        assert "token" in r.json()["error"]
    assert c.get(path, headers={"authorization": "Bearer wrong"}).status_code == 401
    assert c.get(path, headers={"x-odolab-token": TOKEN[:-1]}).status_code == 401
    served = 404 if path.startswith("/trial/plot.png") else 200  # R1 has no encoder log
    assert c.get(path, headers={"authorization": f"Bearer {TOKEN}"}).status_code == served
    assert c.get(path, headers={"x-odolab-token": TOKEN}).status_code == served


def test_posts_without_the_token_are_401_and_change_nothing(lab_db: Path) -> None:
    c = TestClient(
        create_app(ServeSettings(db=lab_db, token=TOKEN, allowed_hosts=None)),
        base_url="http://192.168.1.20:8000",
    )
    r = c.post("/api/trials/R20/measurement", json={"initial": 100, "final": 136, "turns": 9})
    assert r.status_code == 401
    assert c.post("/trial/exclude", data={"id": "R1", "reason": "x"}).status_code == 401
    with Notebook(lab_db) as nb:
        assert nb.get_trial("R20").measured is None
        assert nb.get_trial("R1").exclusion_reason is None


def test_token_in_the_address_once_then_a_cookie(lab_db: Path) -> None:
    c = TestClient(
        create_app(ServeSettings(db=lab_db, token=TOKEN, allowed_hosts=None)),
        base_url="http://192.168.1.20:8000",
    )
    assert c.get(f"/?token={TOKEN[:-1]}x", follow_redirects=False).status_code == 401
    r = c.get(f"/table1?token={TOKEN}&x=1", follow_redirects=False)
    assert r.status_code == 303
    assert r.headers["location"] == "/table1?x=1"  # the token leaves the address bar
    cookie = r.headers["set-cookie"]
    assert cookie.startswith(f"{TOKEN_COOKIE}={TOKEN};")
    assert "HttpOnly" in cookie and "SameSite=Strict" in cookie
    assert c.get("/table1").status_code == 200  # the client keeps the cookie
    assert c.get("/api/trials").status_code == 200


def test_loopback_answers_only_to_loopback_names(lab_db: Path) -> None:
    c = client_for(lab_db)
    assert c.get("/", headers={"host": "127.0.0.1:8000"}).status_code == 200
    assert c.get("/", headers={"host": "localhost:8000"}).status_code == 200
    assert c.get("/", headers={"host": "[::1]:8000"}).status_code == 200
    rebound = c.get("/api/trials", headers={"host": "attacker.example:8000"})
    assert rebound.status_code == 400 and "answers only to" in rebound.json()["error"]


# -- CSRF ---------------------------------------------------------------------------------------


def test_form_posts_need_the_sessions_csrf_token(lab_db: Path) -> None:
    c = client_for(lab_db)
    page = c.get("/trial?id=R20")
    token = csrf_of(page.text)
    assert SESSION_COOKIE in page.headers["set-cookie"]
    assert "SameSite=Strict" in page.headers["set-cookie"]
    readings = {"id": "R20", "initial": "100", "final": "136", "turns": "9"}
    for data in (readings, {**readings, "csrf": ""}, {**readings, "csrf": "0" * 64}):
        r = c.post("/trial/measure", data=data, follow_redirects=False)
        assert r.status_code == 403 and "CSRF" in r.text
    # another session's token is refused too
    other = client_for(lab_db)
    other_token = csrf_of(other.get("/trial?id=R20").text)
    assert other_token != token
    r = c.post("/trial/measure", data={**readings, "csrf": other_token}, follow_redirects=False)
    assert r.status_code == 403
    for path, data in (
        ("/trial/exclude", {"id": "R1", "reason": "forged"}),
        ("/trial/include", {"id": SCRIPT_TRIAL}),
        ("/calibrate", {"method": "ratios", "robot": "jaguar-lite"}),
    ):
        assert c.post(path, data=data).status_code == 403
    with Notebook(lab_db) as nb:
        assert nb.get_trial("R20").measured is None
        assert nb.get_trial("R1").exclusion_reason is None
        assert nb.get_trial(SCRIPT_TRIAL).exclusion_reason == HOSTILE_REASON
        assert nb.latest_params_version("jaguar-lite") == 1
    ok = c.post("/trial/measure", data={**readings, "csrf": token}, follow_redirects=False)
    assert ok.status_code == 303
    with Notebook(lab_db) as nb:
        assert nb.get_trial("R20").measured is not None


def test_csrf_token_is_bound_to_the_session_and_secret() -> None:
    a, b = b"k" * 32, b"j" * 32
    assert csrf_token(a, "s1") != csrf_token(a, "s2") != csrf_token(b, "s1")


# -- escaping -------------------------------------------------------------------------------------


def _assert_inert(body: str) -> None:
    assert "<script>alert" not in body
    assert "<img src=x" not in body and "<img src=y" not in body
    assert "<b>bold</b>" not in body and "<i>op</i>" not in body


def test_hostile_names_are_text_on_every_page(lab_db: Path) -> None:
    c = client_for(lab_db)
    ids = [HOSTILE_TRIAL, SCRIPT_TRIAL, PATH_TRIAL]
    pages = [*PAGES, *(f"/trial?id={quote(i, safe='')}" for i in ids),
             f"/?campaign={quote(HOSTILE_CAMPAIGN)}", "/?terrain=..%2F..%2F"]  # fmt: skip
    for path in pages:
        r = c.get(path)
        assert r.status_code == 200, path
        _assert_inert(r.text)
    index = c.get("/").text
    for name in (HOSTILE_TRIAL, SCRIPT_TRIAL, PATH_TRIAL, HOSTILE_CAMPAIGN):
        assert escape(name) in index  # shown, as text
    # links carry ids percent-encoded, never as a path the browser would resolve
    assert f'href="/trial?id={quote(PATH_TRIAL, safe="")}"' in index
    assert 'href="/trial?id=../' not in index
    trial = c.get(f"/trial?id={quote(SCRIPT_TRIAL, safe='')}").text
    assert escape(HOSTILE_REASON) in trial
    # a refused entry echoes the typed values escaped, too
    token = csrf_of(c.get("/trial?id=F1").text)
    r = c.post(
        "/trial/measure",
        data={"id": "F1", "x": '"><script>alert(3)</script>', "y": "0", "csrf": token},
    )
    assert r.status_code == 400
    assert "x has 27 characters; type a measurement of at most 24 (e.g. -0.031)" in r.text
    assert 'value="&#34;&gt;&lt;script&gt;alert(3)&lt;/script&gt;"' in r.text  # kept, as text
    _assert_inert(r.text)
    assert "alert(3)</script>" not in r.text


def test_pages_forbid_scripts(lab_db: Path) -> None:
    r = client_for(lab_db).get("/")
    csp = r.headers["content-security-policy"]
    assert "default-src 'none'" in csp and "script-src" not in csp
    assert r.headers["x-frame-options"] == "DENY"
    assert r.headers["x-content-type-options"] == "nosniff"
    assert "<script" not in r.text


# -- uploads and downloads ------------------------------------------------------------------------


def test_upload_is_size_limited_and_validated(lab_db: Path, tmp_path: Path) -> None:
    c = client_for(lab_db, max_upload_bytes=4096)
    token = csrf_of(c.get("/data").text)
    big = c.post(
        "/data/import",
        data={"csrf": token},
        files={"file": ("trials.csv", b"x" * 10_000, "text/csv")},
    )
    assert big.status_code == 413
    bad = c.post(
        "/data/import",
        data={"csrf": token},
        files={"file": ("../../etc/passwd.csv", b"trial_id,campaign\nA,rot-lab\n", "text/csv")},
    )
    assert bad.status_code == 400
    # the message names the upload (made safe), never a path on the server
    assert "passwd.csv: " in bad.text and "/tmp" not in bad.text and "odolab-upload" not in bad.text
    with Notebook(lab_db) as nb:
        assert len(nb.trial_ids()) == 10


def test_an_upload_nested_too_deeply_is_a_sentence(lab_db: Path) -> None:
    # the store's JSON reader recursed out: a 500 and a traceback on the server
    c = client_for(lab_db)
    r = c.post(
        "/data/import",
        data={"csrf": csrf_of(c.get("/data").text)},
        files={"file": ("deep.json", b"[" * 100_000 + b"]" * 100_000, "application/json")},
    )
    assert r.status_code == 400
    assert "deep.json: JSON nested too deeply to read" in r.text
    with Notebook(lab_db) as nb:
        assert len(nb.trial_ids()) == 10


def test_export_then_import_into_another_notebook(lab_db: Path, tmp_path: Path) -> None:
    from .conftest import cli

    src = client_for(lab_db)
    csv_text = src.get("/data/export", params={"format": "csv", "campaign": "rot-lab"})
    assert csv_text.status_code == 200
    assert csv_text.headers["content-disposition"] == 'attachment; filename="trials.csv"'
    assert csv_text.text.count("\n") == 1 + 7  # header + the 7 rotations of rot-lab
    js = src.get("/data/export", params={"format": "json"})
    assert js.status_code == 200 and len(js.json()["trials"]) == 10
    empty = tmp_path / "other.db"
    cli("notebook", "init", "--db", str(empty))
    dst = client_for(empty)
    token = csrf_of(dst.get("/data").text)
    r = dst.post("/data/import", data={"csrf": token},
                 files={"file": ("lab.json", js.content, "application/json")})  # fmt: skip
    assert r.status_code == 200 and "10 trials imported from lab.json" in r.text
    again = dst.post("/data/import", data={"csrf": token},
                     files={"file": ("lab.json", js.content, "application/json")})  # fmt: skip
    assert again.status_code == 400 and "is already in the notebook" in again.text
    with Notebook(empty) as nb:
        assert len(nb.trial_ids()) == 10
        assert nb.get_trial("R1").measured == Notebook(lab_db).get_trial("R1").measured


@pytest.mark.parametrize(
    ("path", "location"),
    [
        ("//evil.example/", "/evil.example/"),  # was Location: //evil.example/ (another site)
        ("/%5C%5Cevil.example/", "/evil.example/"),  # a browser reads /\ as //
        ("/%E2%82%AC", "/%E2%82%AC"),  # was raw UTF-8 in a header
        ("/x%0d%0aSet-Cookie:%20a=1", "/x%0D%0ASet-Cookie:%20a=1"),  # was a 500 (h11 refused it)
    ],
)
def test_the_token_redirect_stays_on_this_server(lab_db: Path, path: str, location: str) -> None:
    c = TestClient(
        create_app(ServeSettings(db=lab_db, token=TOKEN, allowed_hosts=None)),
        base_url="http://192.168.1.20:8000",
    )
    r = c.get(f"http://192.168.1.20:8000{path}?token={TOKEN}", follow_redirects=False)
    assert r.status_code == 303
    assert r.headers["location"] == location


def test_a_loopback_address_other_than_127_0_0_1_answers_to_itself(lab_db: Path) -> None:
    # bound to 127.0.0.2, every request (Host: 127.0.0.2:port) was refused as a rebinding attempt
    s = settings_for(lab_db, "127.0.0.2")
    assert s.token is None and s.allowed_hosts is not None
    c = TestClient(create_app(s), base_url="http://127.0.0.2:8000")
    assert c.get("/").status_code == 200
    assert c.get("/", headers={"host": "attacker.example"}).status_code == 400


def test_only_this_servers_redirect_can_say_saved(lab_db: Path) -> None:
    # /trial?id=R1&saved=measured: x 0.9 m showed a green "measured" banner from any link
    c = client_for(lab_db)
    forged = c.get("/trial", params={"id": "R1", "saved": "measured: 90.0 deg (forged)"})
    assert forged.status_code == 200 and "forged" not in forged.text
    form = c.get("/trial?id=R1").text
    r = c.post(
        "/trial/exclude", data={"id": "R1", "reason": "wheel slipped", "csrf": csrf_of(form)}
    )
    assert r.status_code == 200  # followed the redirect
    assert "excluded: wheel slipped" in r.text
