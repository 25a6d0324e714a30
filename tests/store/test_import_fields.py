"""Every field of a JSON or CSV trial import is checked: one sentence naming the file, the entry
(``trials[i]``, line) and the key or column, never a traceback.

Before, a JSON trial without ``updated`` raised ``KeyError: 'updated'`` and ``params_version``
``1e20`` (or 10**20) reached SQLite; a trial id that is a list raised ``TypeError: unhashable``.
"""

from __future__ import annotations

import copy
import json
import random
import re
import shutil
from pathlib import Path
from typing import Any

import pytest

from odolab.cli import main
from odolab.core.errors import OdolabError
from odolab.store import Notebook, write_trials_csv
from odolab.store.measure import translation_measurement

from .conftest import make_trials

#: Values that are wrong for most keys (and right for a few: those imports must succeed).
HOSTILE: list[Any] = [None, 1e20, 10**20, -1, "x", "", [], {}, True, float("nan"), 3.5, "1e20"]
_DROP = object()


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, Any], Path]:
    """A notebook export with a measured, a re-measured (history) and an excluded trial with an
    encoder log, and an empty notebook to import into."""
    from odolab.core.trials import MotionKind

    folder = tmp_path_factory.mktemp("src")
    with Notebook(folder / "a.db") as nb:
        nb.add_campaign("fwd-lab", "translation", "lab")
        trials = make_trials(
            3, seed=5, kind=MotionKind.TRANSLATION, campaign="fwd-lab", with_logs=True
        )
        nb.add_trials(trials)
        nb.set_measurement(trials[0].trial_id, translation_measurement(1.0, 0.01), replace=True)
        nb.exclude_trial(trials[2].trial_id, "=slipped")
        nb.export_json(folder / "a.json")
    Notebook(folder / "empty.db").close()
    return json.loads((folder / "a.json").read_text()), folder / "empty.db"


def _import(doc: dict[str, Any], empty: Path, tmp: Path, name: str) -> str | None:
    """The error sentence of importing ``doc`` into a fresh empty notebook, or None."""
    path = tmp / f"{name}.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    db = tmp / f"{name}.db"
    shutil.copyfile(empty, db)
    try:
        with Notebook(db) as nb:
            nb.import_json(path)
    except OdolabError as err:
        text = str(err)
        assert text.startswith(f"{path}: "), text
        assert "\n" not in text
        return text
    return None


def test_the_two_reported_inputs(exported: tuple[dict[str, Any], Path], tmp_path: Path) -> None:
    doc, empty = exported
    no_updated = copy.deepcopy(doc)
    del no_updated["trials"][0]["updated"]
    assert _import(no_updated, empty, tmp_path, "a") is None  # "created" stands for both
    for bad in (1e20, 10**20):
        huge = copy.deepcopy(doc)
        huge["trials"][1]["params_version"] = bad
        text = _import(huge, empty, tmp_path, "b")
        assert text is not None
        assert "trials[1], key 'params_version': " in text
        assert "expected a whole number from 1 to 4611686018427387904" in text


def _cases() -> list[tuple[str, int, str, Any]]:
    rng = random.Random(24)
    keys = {
        "trials": [
            "trial_id", "campaign", "terrain", "kind", "angle", "distance", "side", "direction",
            "speed", "predicted_t", "predicted_x", "predicted_y", "predicted_theta",
            "predicted_heading", "robot", "params_version", "instrument", "measured_rotation",
            "measured_x", "measured_y", "sigma_rotation", "sigma_xy", "raw", "true_t", "true_x",
            "status", "exclusion_reason", "notes", "created", "updated", "encoder_log",
            "measurement_history",
        ],
        "params_versions": ["robot", "version", "track_width", "encoder_modulus", "method",
                            "source_trials", "created", "notes", "model", "noise"],
        "campaigns": ["name", "kind", "terrain", "date", "operator", "notes"],
    }  # fmt: skip
    cases = []
    for section, names in keys.items():
        for key in names:
            for value in [_DROP, *rng.sample(HOSTILE, 4)]:
                cases.append((section, 0 if section != "trials" else 2, key, value))
    return cases


def test_every_key_with_a_hostile_value_is_one_sentence(
    exported: tuple[dict[str, Any], Path], tmp_path: Path
) -> None:
    doc, empty = exported
    refused = 0
    for n, (section, i, key, value) in enumerate(_cases()):
        bad = copy.deepcopy(doc)
        if value is _DROP:
            del bad[section][i][key]
        else:
            bad[section][i][key] = value
        text = _import(bad, empty, tmp_path, f"c{n}")
        if text is None:
            continue
        refused += 1
        if section == "trials":  # the entry and the key are named (a log or history: its part)
            assert f"trials[{i}]" in text, (key, value, text)
            assert key in text or f"trials[{i}]." in text, (key, value, text)
    assert refused >= 150, refused


def test_a_huge_integer_in_a_csv_is_one_sentence(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write_trials_csv(tmp_path / "t.csv", [(t, 1) for t in make_trials(2, seed=8)])
    text = path.read_text(encoding="utf-8").replace(",1,", ",100000000000000000000,", 1)
    path.write_text(text, encoding="utf-8")
    code = main(["trials", "import", str(path), "--db", str(tmp_path / "n.db"),
                 "--create-campaigns"])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 1
    assert re.match(
        rf"odolab: error: {re.escape(str(path))}: line \d, column 'params_version': ", err
    )
    assert "expected a whole number from 1 to" in err and err.count("\n") == 1
