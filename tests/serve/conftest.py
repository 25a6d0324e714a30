"""A small lab notebook for the server tests, written with the CLI (the store's own writers).

Rotations in ``rot-lab`` (tile): R1..R4 measured (compass readings and turns chosen so that the
actual rotation is about 0.9 of the command), R20 (20 pi) and ``../../`` (2 pi) awaiting.
Translations in ``fwd-lab`` (tile): F1 (2.5 m) and F2 (1 m) awaiting. Hostile names: the
campaign ``<script>alert("c")</script>`` on terrain ``../../`` holds the awaiting translation
``"><img src=x onerror=alert(1)>``; ``<script>alert(1)</script>`` is an excluded rotation whose
reason is markup too.
"""

from __future__ import annotations

import math
import sqlite3
from pathlib import Path

import pytest

from odolab.cli import main

HOSTILE_TRIAL = '"><img src=x onerror=alert(1)>'
SCRIPT_TRIAL = "<script>alert(1)</script>"
PATH_TRIAL = "../../"
HOSTILE_CAMPAIGN = '<script>alert("c")</script>'
HOSTILE_TERRAIN = "../../"
HOSTILE_REASON = '<b>bold</b> "><img src=y onerror=alert(2)>'

#: (trial id, commanded multiples of pi, predicted heading, compass initial, final, turns)
MEASURED_ROTATIONS = [
    ("R1", 2, 2 * math.pi + 0.010, 324.0, 0.0, 0),
    ("R2", 4, 4 * math.pi + 0.020, 290.0, 0.0, 1),
    ("R3", 6, 6 * math.pi - 0.015, 250.0, 0.0, 2),
    ("R4", 8, 8 * math.pi + 0.030, 220.0, 0.0, 3),
]


def compass_rotation(initial: float, final: float, turns: int) -> float:
    """Counter-clockwise rotation from compass readings (clockwise degrees) and whole turns."""
    return turns * 2 * math.pi + math.radians((initial - final) % 360.0)


def cli(*args: str) -> None:
    code = main(list(args))
    assert code == 0, args


def build_notebook(db: Path) -> Path:
    d = str(db)
    cli("notebook", "init", "--db", d)
    cli("trials", "campaign-add", "rot-lab", "--kind", "rotation", "--terrain", "tile", "--db", d)
    cli("trials", "campaign-add", "fwd-lab", "--kind", "translation", "--terrain", "tile",
        "--db", d)  # fmt: skip
    cli("trials", "campaign-add", HOSTILE_CAMPAIGN, "--kind", "translation", "--terrain",
        HOSTILE_TERRAIN, "--operator", "<i>op</i>", "--db", d)  # fmt: skip
    for tid, n_pi, heading, initial, final, turns in MEASURED_ROTATIONS:
        cli("trials", "add", "--id", tid, "--campaign", "rot-lab", "--kind", "rotation",
            "--angle-pi", str(n_pi), "--predicted-heading", repr(heading),
            "--initial", str(initial), "--final", str(final), "--turns", str(turns),
            "--db", d)  # fmt: skip
    cli("trials", "add", "--id", "R20", "--campaign", "rot-lab", "--kind", "rotation",
        "--angle-pi", "20", "--predicted-heading", "62.85", "--db", d)  # fmt: skip
    cli("trials", "add", "--id", PATH_TRIAL, "--campaign", "rot-lab", "--kind", "rotation",
        "--angle-pi", "2", "--predicted-heading", "6.3", "--db", d)  # fmt: skip
    cli("trials", "add", "--id", SCRIPT_TRIAL, "--campaign", "rot-lab", "--kind", "rotation",
        "--angle-pi", "2", "--predicted-heading", "6.29", "--initial", "330", "--final", "0",
        "--turns", "0", "--db", d)  # fmt: skip
    cli("trials", "exclude", SCRIPT_TRIAL, "--reason", HOSTILE_REASON, "--db", d)
    cli("trials", "add", "--id", "F1", "--campaign", "fwd-lab", "--kind", "translation",
        "--distance", "2.5", "--predicted-x", "2.5", "--predicted-y", "0.01", "--db", d)  # fmt: skip
    cli("trials", "add", "--id", "F2", "--campaign", "fwd-lab", "--kind", "translation",
        "--distance", "1", "--predicted-x", "1.0", "--db", d)  # fmt: skip
    cli("trials", "add", "--id", HOSTILE_TRIAL, "--campaign", HOSTILE_CAMPAIGN, "--kind",
        "translation", "--distance", "1", "--predicted-x", "1.0", "--db", d)  # fmt: skip
    return db


@pytest.fixture(scope="session")
def _lab_db_template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build_notebook(tmp_path_factory.mktemp("template") / "lab.db")


@pytest.fixture
def lab_db(tmp_path: Path, _lab_db_template: Path) -> Path:
    """A fresh copy of the notebook for each test (built once per session)."""
    db = tmp_path / "lab.db"
    with sqlite3.connect(_lab_db_template) as src, sqlite3.connect(db) as dst:
        src.backup(dst)
    return db


def rotation_ratio(pairs: list[tuple[float, float]]) -> float:
    """Table I's rotation ratio by hand: least squares through the origin, sum(xy)/sum(xx)."""
    return sum(p * a for p, a in pairs) / sum(p * p for p, _ in pairs)


def measured_pairs() -> list[tuple[float, float]]:
    return [(h, compass_rotation(i, f, n)) for _, _, h, i, f, n in MEASURED_ROTATIONS]
