"""``odolab notebook rescue``: the readable records of a damaged notebook, in a new notebook.

A zeroed page of the trials table makes ``trials export`` (and every command that reads all the
trials) stop with "the notebook is damaged"; the rescue skips the unreadable stretch and keeps
every other trial exactly as it was.
"""

from __future__ import annotations

import random
import shutil
import sqlite3
from pathlib import Path

import pytest

from odolab.cli import main
from odolab.core.errors import StoreError
from odolab.core.trials import MotionKind
from odolab.store import Notebook
from odolab.store.rescue import rescue_notebook

from .conftest import fingerprint, make_trials

PAGE = 4096


@pytest.fixture(scope="module")
def original(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, object]]:
    """A checkpointed notebook of 150 trials (encoder logs, a replaced measurement) and the
    fingerprint of each trial."""
    from odolab.store.measure import translation_measurement

    db = tmp_path_factory.mktemp("nb") / "lab.db"
    with Notebook(db) as nb:
        nb.add_campaign("rot-lab", "rotation", "lab")
        nb.add_campaign("fwd-lab", "translation", "lab")
        nb.add_trials(make_trials(100, seed=1, with_logs=True))
        fwd = make_trials(50, seed=2, kind=MotionKind.TRANSLATION, campaign="fwd-lab", prefix="F")
        nb.add_trials(fwd)
        nb.set_measurement(fwd[0].trial_id, translation_measurement(1.0, 0.02), replace=True)
        prints = {t.trial_id: fingerprint(t) for t in nb.load_trials()}
    conn = sqlite3.connect(db)
    conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    conn.close()
    return db, prints


def _leaf_pages(db: Path, table: str) -> list[int]:
    conn = sqlite3.connect(db)
    try:
        rows = conn.execute(
            "SELECT pageno FROM dbstat WHERE name = ? AND pagetype = 'leaf'", (table,)
        ).fetchall()
    except sqlite3.OperationalError:
        pytest.skip("this SQLite has no dbstat table")
    finally:
        conn.close()
    return sorted(int(r[0]) for r in rows)


def _zero_page(src: Path, dst: Path, page_no: int) -> None:
    data = bytearray(src.read_bytes())
    data[(page_no - 1) * PAGE : page_no * PAGE] = bytes(PAGE)
    dst.write_bytes(bytes(data))


def test_a_zeroed_trials_page_loses_only_its_trials(
    original: tuple[Path, dict[str, object]], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    db, prints = original
    leaves = _leaf_pages(db, "trials")
    assert len(leaves) >= 4
    bad = tmp_path / "bad.db"
    _zero_page(db, bad, leaves[len(leaves) // 2])  # a page in the middle of the table
    # the plain export meets the damage and says so
    assert main(["trials", "export", str(tmp_path / "all.json"), "--db", str(bad)]) == 1
    assert "the notebook is damaged" in capsys.readouterr().err
    assert main(["notebook", "rescue", str(tmp_path / "new.db"), "--db", str(bad)]) == 0
    said = capsys.readouterr().out
    with Notebook(tmp_path / "new.db") as nb:
        assert nb.integrity_check() == "ok"
        rescued = {t.trial_id: fingerprint(t) for t in nb.load_trials()}
    lost = set(prints) - set(rescued)
    assert 0 < len(lost) <= 20  # one page of trial rows
    assert all(rescued[t] == prints[t] for t in rescued)  # the others exactly as they were
    assert f"{len(rescued)} trials" in said and "1 unreadable stretch" in said


def test_random_damage_rescues_exact_records(
    original: tuple[Path, dict[str, object]], tmp_path: Path
) -> None:
    db, prints = original
    rng = random.Random(5)
    total = 0
    for case in range(6):
        bad, new = tmp_path / f"b{case}.db", tmp_path / f"n{case}.db"
        shutil.copyfile(db, bad)
        data = bytearray(bad.read_bytes())
        for _ in range(3):  # zeroed pages anywhere but the schema's first page
            page = rng.randrange(1, len(data) // PAGE)
            data[page * PAGE : (page + 1) * PAGE] = bytes(PAGE)
        bad.write_bytes(bytes(data))
        try:
            report = rescue_notebook(bad, new)
        except StoreError as err:  # the schema itself unreadable: one sentence
            assert "nothing can be rescued" in str(err)
            continue
        with Notebook(new) as nb:
            assert nb.integrity_check() == "ok"
            rescued = {t.trial_id: fingerprint(t) for t in nb.load_trials()}
        assert report.trials == len(rescued)
        # a trial whose encoder log sat on a lost page is kept without it; the rest is exact
        assert all(rescued[t] == prints[t] or rescued[t][8] is None for t in rescued)
        assert all(
            rescued[t][:8] + rescued[t][9:] == prints[t][:8] + prints[t][9:] for t in rescued
        )
        total += len(rescued)
    assert total >= 300  # most trials of the six copies survive


def test_the_rescue_refuses_an_existing_target_and_leaves_the_source(
    original: tuple[Path, dict[str, object]], tmp_path: Path
) -> None:
    db, _ = original
    (tmp_path / "there.db").write_bytes(b"mine")
    before = db.read_bytes()
    with pytest.raises(StoreError, match=r"there\.db: already exists; expected a new file name"):
        rescue_notebook(db, tmp_path / "there.db")
    report = rescue_notebook(db, tmp_path / "copy.db")  # a sound notebook: everything
    assert report.trials == 150 and report.unreadable_stretches == {}
    assert db.read_bytes() == before and (tmp_path / "there.db").read_bytes() == b"mine"
