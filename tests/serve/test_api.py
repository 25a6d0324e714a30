"""The JSON API: the CLI's sentences for every refusal, nothing stored on error, Table I."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any
from urllib.parse import quote

import pytest
from starlette.testclient import TestClient

from odolab.cli import main
from odolab.serve import ServeSettings, create_app
from odolab.serve.routes._measure import in_words

from .conftest import (
    HOSTILE_TRIAL,
    PATH_TRIAL,
    SCRIPT_TRIAL,
    compass_rotation,
    measured_pairs,
    rotation_ratio,
)


@pytest.fixture
def client(lab_db: Path) -> TestClient:
    return TestClient(create_app(ServeSettings(db=lab_db)), base_url="http://127.0.0.1:8000")


def url(trial_id: str, tail: str = "") -> str:
    return f"/api/trials/{quote(trial_id, safe='')}{tail}"


def snapshot(client: TestClient) -> list[dict[str, Any]]:
    """Every trial as the API shows it, with its measurement history."""
    ids = [t["trial_id"] for t in client.get("/api/trials").json()["trials"]]
    return [client.get(url(i)).json() for i in sorted(ids)]


def cli_error(capsys: pytest.CaptureFixture[str], *args: str) -> str:
    """The sentence ``odolab`` prints for a refused command (exit code 1, one line)."""
    capsys.readouterr()
    assert main(list(args)) == 1
    err = capsys.readouterr().err
    assert err.startswith("odolab: error: ") and err.count("\n") == 1, err
    return err.removeprefix("odolab: error: ").rstrip("\n")


def test_list_filters_and_awaiting_first(client: TestClient) -> None:
    trials = client.get("/api/trials").json()["trials"]
    statuses = [t["status"] for t in trials]
    assert statuses == sorted(statuses, key=["awaiting", "measured", "excluded"].index)
    assert statuses.count("awaiting") == 5 and statuses.count("excluded") == 1
    rot = client.get("/api/trials", params={"status": "awaiting", "kind": "rotation"}).json()
    assert [t["trial_id"] for t in rot["trials"]] == ["R20", PATH_TRIAL]
    tile = client.get("/api/trials", params={"terrain": "../../"}).json()["trials"]
    assert [t["trial_id"] for t in tile] == [HOSTILE_TRIAL]
    camp = client.get("/api/trials", params={"campaign": "fwd-lab"}).json()["trials"]
    assert [t["trial_id"] for t in camp] == ["F1", "F2"]
    bad = client.get("/api/trials", params={"status": "done"})
    assert bad.status_code == 400
    assert bad.json() == {"error": "status is 'done'; expected one of awaiting, measured, excluded"}


def test_one_trial_any_id(
    client: TestClient, capsys: pytest.CaptureFixture[str], lab_db: Path
) -> None:
    for tid in (PATH_TRIAL, HOSTILE_TRIAL, SCRIPT_TRIAL, "R1"):
        body = client.get(url(tid)).json()
        assert body["trial_id"] == tid
    r1 = client.get(url("R1")).json()
    assert r1["measured"]["rotation"] == pytest.approx(compass_rotation(324.0, 0.0, 0))
    assert r1["predicted"]["heading"] == pytest.approx(2 * math.pi + 0.010)
    assert r1["params_version"] == 1 and r1["measurement_history"] == []
    missing = client.get(url("nope"))
    assert missing.status_code == 404
    sentence = cli_error(capsys, "trials", "show", "nope", "--db", str(lab_db))
    assert missing.json() == {"error": sentence}


def test_measure_rotation_in_the_labs_terms(client: TestClient) -> None:
    r = client.post(url("R20", "/measurement"), json={"initial": 100, "final": 136, "turns": 9})
    assert r.status_code == 200, r.text
    m = r.json()["measured"]
    # 9 whole turns and (100 - 136) mod 360 = 324 deg, counter-clockwise
    assert m["rotation"] == pytest.approx(9 * 2 * math.pi + math.radians(324.0))
    assert m["raw"] == {"compass_initial_deg": 100.0, "compass_final_deg": 136.0, "turns": 9.0}
    assert m["sigma_rotation"] == pytest.approx(math.sqrt(2) * 0.05)
    assert r.json()["status"] == "measured"
    again = client.post(
        url("R20", "/measurement"),
        json={"initial": 100, "final": 130, "turns": 9, "replace": True},
    )
    assert again.status_code == 200
    history = client.get(url("R20")).json()["measurement_history"]
    assert len(history) == 1 and history[0]["raw"]["compass_final_deg"] == 136.0


def test_measure_translation(client: TestClient) -> None:
    r = client.post(url("F1", "/measurement"), json={"x": 2.41, "y": -0.07, "sigma": 0.01})
    assert r.status_code == 200, r.text
    m = r.json()["measured"]
    assert (m["x"], m["y"], m["sigma_xy"]) == (2.41, -0.07, 0.01)


#: (trial, CLI options after ``trials measure TRIAL``, API body): every refusal of an entry.
REFUSALS: list[tuple[str, list[str], dict[str, Any]]] = [
    ("R20", ["--initial", "360", "--final", "10", "--turns", "9"],
     {"initial": 360, "final": 10, "turns": 9}),
    ("R20", ["--initial", "10", "--final", "-5", "--turns", "9"],
     {"initial": 10, "final": -5, "turns": 9}),
    ("R20", ["--initial", "100", "--final", "136", "--turns", "3"],
     {"initial": 100, "final": 136, "turns": 3}),
    ("R20", ["--initial", "100", "--final", "136", "--turns", "-1"],
     {"initial": 100, "final": 136, "turns": -1}),
    ("R20", ["--initial", "nan", "--final", "136", "--turns", "9"],
     {"initial": math.nan, "final": 136, "turns": 9}),
    ("R20", ["--initial", "100", "--final", "136", "--turns", "9", "--sigma", "-0.1"],
     {"initial": 100, "final": 136, "turns": 9, "sigma": -0.1}),
    ("R20", ["--x", "1.0", "--y", "0.0"], {"x": 1.0, "y": 0.0}),
    ("R20", ["--initial", "100", "--x", "1.0"], {"initial": 100, "x": 1.0}),
    ("F1", ["--x", "250", "--y", "3"], {"x": 250, "y": 3}),
    ("F1", ["--x", "-2.5", "--y", "0"], {"x": -2.5, "y": 0}),
    ("F1", ["--x", "2.5", "--y", "0", "--sigma", "-1"], {"x": 2.5, "y": 0, "sigma": -1}),
    ("F1", ["--initial", "10", "--final", "20", "--turns", "0"],
     {"initial": 10, "final": 20, "turns": 0}),
    ("R1", ["--initial", "324", "--final", "0", "--turns", "0"],
     {"initial": 324, "final": 0, "turns": 0}),
    ("nope", ["--x", "1", "--y", "0"], {"x": 1, "y": 0}),
]  # fmt: skip


@pytest.mark.parametrize(("trial_id", "options", "body"), REFUSALS)
def test_every_refusal_is_the_clis_sentence(
    client: TestClient,
    capsys: pytest.CaptureFixture[str],
    lab_db: Path,
    trial_id: str,
    options: list[str],
    body: dict[str, Any],
) -> None:
    before = snapshot(client)
    sentence = cli_error(capsys, "trials", "measure", trial_id, *options, "--db", str(lab_db))
    r = client.post(
        url(trial_id, "/measurement"),
        content=json.dumps(body),  # NaN as Python's json writes it
        headers={"content-type": "application/json"},
    )
    assert 400 <= r.status_code < 500
    # the CLI's sentence, its flags in the API's words; a JSON number the API checks first
    # (NaN, sigma not more than 0) has the API's own sentence
    own = API_OWN.get(json.dumps(body))
    assert r.json() == {"error": own or in_words(sentence, api=True)}
    assert "--" not in r.json()["error"] and "sigma_reading_rad" not in r.json()["error"]
    assert snapshot(client) == before  # nothing stored, by the CLI or the API


_DEFAULT = "(leave it out for the default: 0.05 rad of one compass reading, 0.005 m for x and y)"
API_OWN = {
    json.dumps({"initial": math.nan, "final": 136, "turns": 9}):
        '"initial" is NaN; send a finite number',
    json.dumps({"initial": 100, "final": 136, "turns": 9, "sigma": -0.1}):
        f'"sigma" is -0.1; it must be more than 0 {_DEFAULT}',
    json.dumps({"x": 2.5, "y": 0, "sigma": -1}): f'"sigma" is -1; it must be more than 0 {_DEFAULT}',
}  # fmt: skip


def test_the_api_names_its_keys_not_the_clis_flags(client: TestClient) -> None:
    def error(tid: str, body: dict[str, Any]) -> str:
        return str(client.post(url(tid, "/measurement"), json=body).json()["error"])

    # the old answers: "give --replace ...", "it is measured with --initial, --final and --turns"
    assert error("R1", {"initial": 1, "final": 0, "turns": 0}).endswith(
        '; send "replace": true to overwrite its measurement'
    )
    assert error("R20", {"x": 1.0, "y": 0.0}) == (
        'trial R20 is a rotation: it is measured with "initial", "final" and "turns"'
    )
    assert error("F1", {"initial": 1, "final": 0, "turns": 0}) == (
        'trial F1 is a translation: it is measured with "x" and "y"'
    )


def test_the_sentences_say_what_to_fix(client: TestClient) -> None:
    def error(tid: str, body: dict[str, Any]) -> str:
        return str(client.post(url(tid, "/measurement"), json=body).json()["error"])

    assert "about 9 would fit" in error("R20", {"initial": 100, "final": 136, "turns": 3})
    assert "was it typed in cm or mm?" in error("F1", {"x": 250, "y": 3})
    assert error("R1", {"initial": 1, "final": 0, "turns": 0}).startswith(
        'trial R1 is already measured (rot 5.655 rad (1.80 pi) [compass]); send "replace": true'
    )


def test_exclusion_needs_a_reason_as_in_the_cli(
    client: TestClient, capsys: pytest.CaptureFixture[str], lab_db: Path
) -> None:
    sentence = cli_error(capsys, "trials", "exclude", "R2", "--reason", " ", "--db", str(lab_db))
    r = client.post(url("R2", "/exclude"), json={"reason": " "})
    assert r.status_code == 400 and r.json() == {"error": sentence}
    assert client.get(url("R2")).json()["status"] == "measured"
    ok = client.post(url("R2", "/exclude"), json={"reason": "wheel slipped"})
    assert ok.json()["status"] == "excluded" and ok.json()["exclusion_reason"] == "wheel slipped"
    back = client.post(url("R2", "/include"), json={})
    assert back.json()["status"] == "measured" and back.json()["exclusion_reason"] is None


def test_malformed_bodies(client: TestClient) -> None:
    before = snapshot(client)
    form = client.post(url("R20", "/measurement"), data={"initial": "1"})
    assert form.status_code == 415 and "application/json" in form.json()["error"]
    bad = client.post(
        url("R20", "/measurement"), content="{", headers={"content-type": "application/json"}
    )
    assert bad.status_code == 400 and bad.json()["error"].startswith("the body is not valid JSON")
    listed = client.post(url("R20", "/measurement"), json=[1, 2])
    assert listed.json() == {"error": "the body must be a JSON object"}
    typo = client.post(url("R20", "/measurement"), json={"initial": 1, "fianl": 2, "turns": 0})
    assert typo.json() == {
        "error": "unknown key 'fianl'; expected initial, final, turns, x, y, sigma, replace"
    }
    text = client.post(url("R20", "/measurement"), json={"initial": "ten", "final": 2, "turns": 9})
    assert text.json() == {
        "error": '"initial" is text; send a JSON number, e.g. "initial": 0.5 (not "0.5")'
    }
    assert snapshot(client) == before


def test_table1_follows_each_entry(client: TestClient) -> None:
    def rotation_row() -> dict[str, Any]:
        rows = client.get("/api/table1").json()["rows"]
        return next(r for r in rows if r["motion"] == "rotation")

    pairs = measured_pairs()
    row = rotation_row()
    assert row["n"] == 4
    assert row["ratio"] == pytest.approx(rotation_ratio(pairs), rel=1e-12)
    client.post(url("R20", "/measurement"), json={"initial": 100, "final": 136, "turns": 9})
    pairs.append((62.85, compass_rotation(100.0, 136.0, 9)))
    row = rotation_row()
    assert row["n"] == 5
    assert row["ratio"] == pytest.approx(rotation_ratio(pairs), rel=1e-12)
    client.post(url("R1", "/exclude"), json={"reason": "compass near a steel door"})
    row = rotation_row()
    assert row["n"] == 4
    assert row["ratio"] == pytest.approx(rotation_ratio(pairs[1:]), rel=1e-12)


def test_a_body_nested_too_deeply_is_a_400_not_a_crash(client: TestClient) -> None:
    # 100,000 nested arrays made the JSON parser recurse out: a 500 and a traceback on the server
    body = "[" * 100_000 + "]" * 100_000
    r = client.post(
        "/api/trials/R20/measurement", content=body, headers={"content-type": "application/json"}
    )
    assert r.status_code == 400
    assert r.json() == {"error": "the body is not valid JSON (nested too deeply)"}
