"""Small things a new user trips over: grammar, campaign names, hints, --help."""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import pytest

from odolab.cli import main


def test_one_trial_is_singular(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    db = tmp_path / "lab.db"
    assert main(["notebook", "init", "--db", str(db)]) == 0
    add = [
        "trials",
        "add",
        "--id",
        "R1",
        "--campaign",
        "c",
        "--create-campaign",
        "--terrain",
        "tile",
    ]
    add += ["--kind", "rotation", "--angle-pi", "2", "--predicted-heading", "6.3"]
    assert main([*add, "--initial", "0", "--final", "30", "--turns", "0", "--db", str(db)]) == 0
    capsys.readouterr()
    assert main(["trials", "list", "--db", str(db)]) == 0
    assert "1 trial in" in capsys.readouterr().out
    assert main(["analyze", "--db", str(db)]) == 1
    err = capsys.readouterr().err
    assert "from 1 measured trial:" in err and "1 measured trials" not in err
    assert "odolab sim run rotation" in err  # and how to get enough quickly


def test_terrain_override_names_the_campaign(tmp_path: Path) -> None:
    out = tmp_path / "grass.csv"
    assert main(["sim", "run", "translation", "--terrain", "grass", "-o", str(out)]) == 0
    rows = list(csv.DictReader(out.open()))
    assert {r["campaign"] for r in rows} == {"translation-grass"}
    assert rows[0]["trial_id"] == "translation-grass-000"
    assert {r["terrain"] for r in rows} == {"grass"}


def test_turn_hint_follows_what_odometry_saw() -> None:
    from odolab.core.errors import StoreError
    from odolab.store import rotation_measurement_from_compass

    # commanded 20 pi, but odometry stopped at 12 pi (6 turns): 1 turn + 90 deg was counted,
    # (39.199 - 90 deg) / 2 pi = 6 turns fit what odometry saw (the command would say 9)
    with pytest.raises(StoreError, match=r"about 6 would fit the 39\.199 rad odometry saw"):
        rotation_measurement_from_compass(
            90.0, 0.0, 1, commanded_angle=20 * math.pi, predicted_angle=12 * math.pi + 1.5
        )


def test_help_shows_flags_as_flags(capsys: pytest.CaptureFixture[str], monkeypatch) -> None:  # type: ignore[no-untyped-def]
    monkeypatch.setenv("COLUMNS", "200")
    assert main(["calibrate", "lsq", "--help"]) == 0
    text = capsys.readouterr().out
    assert "--no-gt-yaw-offset" in text and "--no-no-" not in text
    assert not re.search(r"--help\s+<bool>", text)
    assert "<bool>" not in text


def test_evaluate_prints_the_mean_rows_the_docs_quote(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    optiodom_dir: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """docs/real-logs.md quotes means per folder: the table ends with them, never cut."""
    import json

    monkeypatch.delenv("COLUMNS", raising=False)  # not a terminal: as wide as the table

    out = tmp_path / "ev.json"
    folder = optiodom_dir / "circular" / "250620202251"
    assert main(["evaluate", str(folder), "--format", "optiodom", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    runs = json.loads(out.read_text())["runs"]
    drift = [r["drift"]["translation_pct"] for r in runs]
    end = [r["drift"]["endpoint_error"] for r in runs]
    group = runs[0]["name"].split("/")[0]
    row = next(line for line in text.splitlines() if f"mean, {group} ({len(runs)} runs)" in line)
    assert f"{sum(drift) / len(drift):.2f}" in row and f"{sum(end) / len(end):.4f}" in row
    assert "…" not in text


def _commands() -> list[tuple[list[str], object]]:
    """Every (path, click command) of the odolab CLI."""
    import typer.main

    from odolab.cli import app

    out: list[tuple[list[str], object]] = []

    def walk(cmd: object, path: list[str]) -> None:
        subs = getattr(cmd, "commands", None)
        if subs:
            for name, sub in subs.items():
                walk(sub, [*path, name])
        else:
            out.append((path, cmd))

    walk(typer.main.get_command(app), [])
    return out


def test_help_keeps_every_bracketed_word(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """rich reads "[noise]" in a help text as markup and drops it ("Fit the  table")."""
    monkeypatch.setenv("COLUMNS", "400")
    checked = 0
    for path, cmd in _commands():
        texts = [getattr(cmd, "help", None) or ""]
        texts += [getattr(p, "help", None) or "" for p in getattr(cmd, "params", [])]
        words = {w for t in texts for w in re.findall(r"\\?\[([a-z_]+)\]", t)}
        if not words:
            continue
        assert main([*path, "--help"]) == 0
        shown = capsys.readouterr().out
        for w in words:
            assert f"[{w}]" in shown, f"odolab {' '.join(path)} --help lost [{w}]"
            checked += 1
    assert checked >= 3
