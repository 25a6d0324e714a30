"""A notebook file that is not one, or is damaged: one sentence and exit 1, never a traceback.

Before odolab.store.health, ``--db`` given an empty file silently became a notebook (SQLite
writes its schema into any empty file), a text file or another program's SQLite file gave
SQLite's own words, and a damaged notebook (corrupt pages, a cut-off file) raised
``sqlite3.DatabaseError`` through the CLI: 45 of 70 damaged notebooks in the red-team pass gave a
traceback. The damage here is made with a seeded RNG on a real notebook: bytes overwritten inside
pages, whole pages zeroed, the file cut short.
"""

from __future__ import annotations

import random
import shutil
import sqlite3
from pathlib import Path

import pytest

from odolab.cli import main
from odolab.cli.wording import worded
from odolab.core.errors import StoreError
from odolab.core.trials import MotionKind
from odolab.store import Notebook
from odolab.store.health import NotebookDamagedError, NotebookFileError
from odolab.store.schema import APPLICATION_ID

from .conftest import make_trials

PAGE = 4096


def _commands(db: Path, out: Path, *, analyze: bool) -> list[list[str]]:
    d = str(db)
    return [
        ["trials", "list", "--db", d],
        ["trials", "show", "T3", "--db", d],
        ["trials", "campaigns", "--db", d],
        ["trials", "params-versions", "jaguar-lite", "--db", d],
        ["notebook", "info", "--db", d],
        ["trials", "export", str(out / "t.json"), "--db", d],
        ["trials", "export", str(out / "t.csv"), "--db", d],
        ["trials", "exclude", "T4", "--reason", "slipped", "--db", d],
        *([["analyze", "--db", d]] if analyze else []),
    ]


@pytest.fixture(scope="module")
def template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A notebook of 24 rotations with encoder logs and 12 translations, checkpointed (one
    file, no WAL)."""
    db = tmp_path_factory.mktemp("nb") / "lab.db"
    with Notebook(db) as nb:
        nb.add_campaign("rot-lab", "rotation", "lab")
        nb.add_campaign("fwd-lab", "translation", "lab")
        nb.add_trials(make_trials(24, seed=1, with_logs=True))
        nb.add_trials(
            make_trials(12, seed=2, kind=MotionKind.TRANSLATION, campaign="fwd-lab", prefix="F")
        )
    conn = sqlite3.connect(db)
    conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    conn.close()
    return db


def _damage(src: Path, dst: Path, rng: random.Random) -> str:
    """A copy of ``src`` at ``dst`` with one kind of damage; returns what was done."""
    shutil.copyfile(src, dst)
    data = bytearray(dst.read_bytes())
    pages = len(data) // PAGE
    kind = rng.choice(["bytes", "page", "truncate"])
    if kind == "bytes":  # a few runs of random bytes anywhere after the 100-byte file header
        for _ in range(rng.randint(1, 4)):
            at = rng.randrange(100, len(data) - 64)
            data[at : at + rng.randint(1, 64)] = rng.randbytes(rng.randint(1, 64))
    elif kind == "page":  # a whole page of zeros or noise (a lost disk sector, a bad copy)
        page = rng.randrange(1, pages)
        data[page * PAGE : (page + 1) * PAGE] = (
            bytes(PAGE) if rng.random() < 0.5 else rng.randbytes(PAGE)
        )
    else:  # the file cut short (a full disk, a copy interrupted)
        del data[rng.randrange(100, len(data) - PAGE) :]
    dst.write_bytes(bytes(data))
    return kind


def test_damaged_notebooks_give_one_sentence_never_a_traceback(
    template: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rng = random.Random(20240524)
    damaged_said = 0
    failures = 0
    for case in range(18):
        db = tmp_path / f"d{case}.db"
        kind = _damage(template, db, rng)
        out = tmp_path / f"out{case}"
        for args in _commands(db, out, analyze=case % 3 == 0):
            capsys.readouterr()
            # an exception other than the CLI's own exit would escape main() and fail the test
            code = main(args)
            err = capsys.readouterr().err
            where = f"case {case} ({kind}): odolab {' '.join(args[:2])}"
            assert code in (0, 1), where
            if code == 1:
                failures += 1
                lines = err.strip().splitlines()
                assert len(lines) == 1 and lines[0].startswith("odolab: error: "), (where, err)
                assert "Traceback" not in err, where
                if "the notebook is damaged" in err:
                    damaged_said += 1
                    assert "integrity check:" in err and "odolab notebook rescue NEW.db" in err
    # the damage is real: many commands met it and said so (126 and 110 of 150 runs; the
    # others read only sound pages, or a zeroed index page hid a trial: "no trial 'T3'")
    assert failures >= 60 and damaged_said >= 50, (failures, damaged_said)


def test_a_damaged_notebook_names_sqlites_words_and_the_way_back(
    template: Path, tmp_path: Path
) -> None:
    db = tmp_path / "bad.db"
    shutil.copyfile(template, db)
    data = bytearray(db.read_bytes())
    rng = random.Random(7)
    for page in range(2, len(data) // PAGE):  # every page but the schema's: noise in each
        at = page * PAGE + rng.randrange(0, 64)
        data[at : at + 32] = rng.randbytes(32)
    db.write_bytes(bytes(data))
    with pytest.raises(NotebookDamagedError) as caught, Notebook(db) as nb:
        nb.load_trials()
    text = worded(caught.value)  # as the CLI prints it
    assert text.startswith(f"{db}: the notebook is damaged (SQLite: ")
    assert "integrity check: " in text and "integrity check: ok" not in text
    assert f"`odolab notebook rescue NEW.db --db {db}`" in text


@pytest.mark.parametrize("size", [1, 16, 99])
def test_a_notebook_cut_inside_its_header_is_damaged(
    template: Path, tmp_path: Path, size: int
) -> None:
    db = tmp_path / "cut.db"
    db.write_bytes(template.read_bytes()[:size])
    with pytest.raises(StoreError, match=r"cut\.db: "):
        Notebook(db)
    if size >= 16:  # it still starts like a SQLite file
        with pytest.raises(NotebookDamagedError, match=f"cut off after {size} bytes"):
            Notebook(db)


# -- not a notebook --------------------------------------------------------------------------------


def test_an_empty_file_is_refused_and_left_empty(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    db = tmp_path / "e.db"
    db.write_bytes(b"")
    for args in (["analyze", "--db", str(db)], ["trials", "import", "x.csv", "--db", str(db)],
                 ["notebook", "init", "--db", str(db)]):  # fmt: skip
        assert main(args) == 1
        err = capsys.readouterr().err
        assert err == (
            f"odolab: error: {db}: is an empty file, not an odolab notebook; remove it, or "
            "give a new file name to create a notebook there\n"
        ), args
    assert db.read_bytes() == b""
    assert not Path(f"{db}-wal").exists()


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        (b"trial_id,campaign\nR1,rot\n", r"is not an odolab notebook \(not a SQLite database"),
        (b"\x00" * 5000, r"is not an odolab notebook \(not a SQLite database"),
    ],
)
def test_a_file_of_another_kind_is_refused_unchanged(
    tmp_path: Path, content: bytes, expected: str
) -> None:
    db = tmp_path / "x.db"
    db.write_bytes(content)
    with pytest.raises(NotebookFileError, match=expected):
        Notebook(db)
    assert db.read_bytes() == content


@pytest.mark.parametrize(
    ("setup", "expected"),
    [
        (["CREATE TABLE photos (id INTEGER)"], r"it holds 1 table but no odolab schema"),
        (["PRAGMA user_version = 3", "CREATE TABLE trials (a)"], r"it has no table 'campaigns'"),
        (["PRAGMA application_id = 1234"], r"its application id is 0x4d2"),
    ],
)
def test_a_sqlite_file_of_another_program_is_refused_unchanged(
    tmp_path: Path, setup: list[str], expected: str
) -> None:
    db = tmp_path / "other.db"
    conn = sqlite3.connect(db)
    for sql in setup:
        conn.execute(sql)
    conn.commit()
    conn.close()
    before = db.read_bytes()
    with pytest.raises(
        NotebookFileError,
        match=f"other.db: a SQLite database of another program, not an odolab notebook \\({expected}",
    ):
        Notebook(db)
    assert db.read_bytes() == before


def test_a_new_notebook_is_made_whole_with_odolabs_id(tmp_path: Path) -> None:
    db = tmp_path / "new.db"
    with Notebook(db) as nb:
        assert nb.migrated_from == 0 and nb.integrity_check() == "ok"
    conn = sqlite3.connect(db)
    assert conn.execute("PRAGMA application_id").fetchone()[0] == APPLICATION_ID
    conn.close()
    assert sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith("new.db")) == []
    with Notebook(db) as nb:  # opened again: not created again
        assert nb.migrated_from == 3


def test_a_newer_notebook_is_refused_before_anything_is_written(tmp_path: Path) -> None:
    db = tmp_path / "future.db"
    conn = sqlite3.connect(db)
    conn.execute(f"PRAGMA application_id = {APPLICATION_ID}")
    conn.execute("PRAGMA user_version = 9")
    conn.execute("CREATE TABLE trials_v9 (a)")
    conn.commit()
    conn.close()
    before = db.read_bytes()
    with pytest.raises(StoreError, match=r"written by a newer odolab \(schema 9\)"):
        Notebook(db)
    assert db.read_bytes() == before  # not even switched to WAL


def test_a_file_system_without_hard_links_still_gets_a_notebook(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import errno
    import os

    def no_link(src: object, dst: object) -> None:
        raise OSError(errno.EPERM, "Operation not permitted")

    monkeypatch.setattr(os, "link", no_link)
    with Notebook(tmp_path / "fat.db") as nb:
        assert nb.migrated_from == 0 and nb.integrity_check() == "ok"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fat.db"]


def test_report_and_analysis_of_a_notebook_with_a_lost_trials_page(
    template: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    conn = sqlite3.connect(template)
    try:
        leaves = [
            int(r[0])
            for r in conn.execute(
                "SELECT pageno FROM dbstat WHERE name = 'trials' AND pagetype = 'leaf'"
            )
        ]
    except sqlite3.OperationalError:
        pytest.skip("this SQLite has no dbstat table")
    finally:
        conn.close()
    db = tmp_path / "lost.db"
    data = bytearray(template.read_bytes())
    page = leaves[len(leaves) // 2]
    data[(page - 1) * PAGE : page * PAGE] = bytes(PAGE)
    db.write_bytes(bytes(data))
    for args in (["report", "--db", str(db), "--out", str(tmp_path / "rep")],
                 ["analyze", "--db", str(db)], ["trials", "list", "--db", str(db)],
                 ["trials", "export", str(tmp_path / "all.csv"), "--db", str(db)]):  # fmt: skip
        assert main(args) == 1, args
        err = capsys.readouterr().err
        assert err.startswith(f"odolab: error: {db}: the notebook is damaged (SQLite: "), err
        assert err.count("\n") == 1 and "odolab notebook rescue NEW.db" in err
    assert not (tmp_path / "rep" / "report.html").exists()
