"""``odolab serve`` as a user runs it: prints the address, serves, stops."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import httpx
import pytest

from odolab.cli import main


def test_serve_prints_a_loopback_address_and_serves(lab_db: Path) -> None:
    proc = subprocess.Popen(
        [sys.executable, "-m", "odolab.cli", "serve", "--db", str(lab_db), "--port", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        lines = [proc.stdout.readline() for _ in range(3)]
        url = lines[2].strip()
        assert lines[0].startswith(f"odolab notebook {lab_db} served at:")
        assert url.startswith("http://127.0.0.1:") and url.endswith("/") and "token" not in url
        r = httpx.get(url + "api/trials", params={"status": "awaiting"}, timeout=30)
        assert r.status_code == 200 and len(r.json()["trials"]) == 5
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def test_serve_refuses_a_missing_notebook(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    db = tmp_path / "nope.db"
    assert main(["serve", "--db", str(db), "--port", "0"]) == 1
    err = capsys.readouterr().err
    assert err == (
        f"odolab: error: {db}: no such notebook; create it with `odolab notebook init --db {db}`\n"
    )
    assert not db.exists()


def test_serve_refuses_a_bad_port(lab_db: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["serve", "--db", str(lab_db), "--port", "70000"]) == 1
    assert capsys.readouterr().err == "odolab: error: --port is 70000; expected 0..65535\n"
