"""Opening a notebook never drops the locks another connection of the same process holds.

Closing any descriptor of a SQLite file releases every POSIX lock the process holds on it
(SQLite's "How To Corrupt An SQLite Database File", 2.2). The notebook's file check once read
the header with ``open()``: a second ``Notebook(path)`` (the web server opens one per request)
released the shared lock of the connections already open, another process closing the notebook
then took it for the last user, checkpointed and removed the write-ahead log under them, and
their later commits, answered 200, were lost (tests/serve/test_concurrency.py: 2 of 36 writes).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from odolab.store import Notebook

_OTHER_PROCESS = """
import sys
from odolab.store import Notebook
with Notebook(sys.argv[1]) as nb:
    nb.add_campaign("theirs", "rotation", "tile")
"""


def test_a_second_notebook_keeps_the_first_ones_commits(tmp_path: Path) -> None:
    db = tmp_path / "lab.db"
    Notebook(db).close()
    with Notebook(db) as first:
        first.add_campaign("mine-1", "rotation", "tile")
        Notebook(db).close()  # a second connection in this process (its file check)
        subprocess.run([sys.executable, "-c", _OTHER_PROCESS, str(db)], check=True, timeout=120)
        # the other process did not take itself for the last user: the log it would have
        # checkpointed and removed under our connection is still there
        assert Path(f"{db}-wal").exists()
        first.add_campaign("mine-2", "translation", "tile")
        assert {c.name for c in first.campaigns()} >= {"mine-1", "mine-2", "theirs"}
    with Notebook(db) as again:
        assert {c.name for c in again.campaigns()} == {"mine-1", "mine-2", "theirs"}


def test_a_wrong_call_is_not_taken_for_a_damaged_file(tmp_path: Path) -> None:
    """The store's error guard turns an unreadable stored value into a sentence, but a call
    with a wrong argument stays the programming error it is."""
    import pytest

    with Notebook(tmp_path / "lab.db") as nb, pytest.raises(TypeError, match="unexpected"):
        nb.add_trials([], create_campaign=True)  # type: ignore[call-arg]
