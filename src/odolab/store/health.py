"""Is a file an odolab notebook, and is it sound? Every SQLite failure as one sentence.

- :func:`check_notebook_file`, before SQLite opens anything: a folder, an empty file, or a file
  that is not a SQLite database (a text file, a CSV given as ``--db``) is refused with one
  sentence and left as it was. (SQLite would silently turn an empty file into a database.)
- :func:`create_notebook_file`: a new notebook is built in a temporary file beside ``path`` and
  linked into place whole, so that no process ever sees a half-made (or empty) notebook.
- :func:`store_error`: any ``sqlite3`` error as a :class:`~odolab.core.errors.StoreError`. A damaged
  file (SQLite's "database disk image is malformed", "file is not a database") becomes a
  :class:`NotebookDamagedError` quoting SQLite's integrity check and saying how to recover;
  a busy, read-only or full disk says so.
"""

from __future__ import annotations

import errno
import os
import sqlite3
import tempfile
from collections.abc import Callable
from pathlib import Path

from odolab.core.errors import StoreError, opt
from odolab.core.text import shorten
from odolab.core.writing import NEW_FILE_MODE

__all__ = [
    "SMALLEST_DATABASE",
    "SQLITE_MAGIC",
    "NotebookDamagedError",
    "NotebookFileError",
    "check_notebook_file",
    "check_sound",
    "create_notebook_file",
    "integrity_words",
    "not_a_database",
    "recovery_hint",
    "store_error",
]

#: The first 16 bytes of every SQLite 3 database file.
SQLITE_MAGIC = b"SQLite format 3\x00"
#: The smallest SQLite database file: one page of the smallest page size.
SMALLEST_DATABASE = 512
#: SQLite's primary result codes that mean the file itself is damaged: CORRUPT, NOTADB.
_DAMAGED_CODES = frozenset({11, 26})
_BUSY_CODES = frozenset({5, 6})  # BUSY, LOCKED
#: os.link's errors on a file system without hard links (FAT, some network and FUSE mounts).
_NO_LINKS = frozenset({errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV, errno.EMLINK})
_WORDS = {
    8: "the notebook or its folder is read-only",  # READONLY
    13: "the disk is full",  # FULL
    14: "SQLite cannot open the file",  # CANTOPEN
    10: "a disk input/output error",  # IOERR
}


class NotebookFileError(StoreError):
    """The file given as a notebook is not one (a folder, an empty file, another format)."""


class NotebookDamagedError(StoreError):
    """The notebook's SQLite file is damaged (corrupt pages, truncated)."""


def check_notebook_file(path: Path) -> bool:
    """Refuse what cannot be a notebook; return whether ``path`` exists (False: to be created).

    Nothing is written. The file is *opened* only when it is smaller than any SQLite database
    (:data:`SMALLEST_DATABASE`): closing a descriptor of a database file drops every POSIX lock
    this process holds on it, so reading a live notebook's header while another thread has a
    connection open lets two writers in at once and loses commits (SQLite's "How To Corrupt",
    2.2). A larger file that is not a database is refused by :func:`not_a_database` when SQLite
    first reads it.

    Raises:
        NotebookFileError: the path is a folder, an empty file, not a SQLite database, or
            unreadable.
        NotebookDamagedError: the file is cut off.
    """
    if path.is_dir():
        raise NotebookFileError(f"{path}: is a folder; expected a notebook file")
    try:
        size = path.stat().st_size
    except FileNotFoundError:
        if not path.parent.is_dir():
            raise NotebookFileError(f"{path}: the folder {path.parent} does not exist") from None
        return False
    except OSError as err:
        raise NotebookFileError(
            f"{path}: cannot read the notebook ({err.strerror or err})"
        ) from err
    if size == 0:
        raise NotebookFileError(
            f"{path}: is an empty file, not an odolab notebook; remove it, or give a new file "
            "name to create a notebook there"
        )
    if size >= SMALLEST_DATABASE:
        return True
    try:  # no connection can hold a lock on a file this small: reading it is safe
        with path.open("rb") as fh:
            head = fh.read(100)
    except OSError as err:
        raise NotebookFileError(
            f"{path}: cannot read the notebook ({err.strerror or err})"
        ) from err
    if not head.startswith(SQLITE_MAGIC):
        raise NotebookFileError(
            f"{path}: is not an odolab notebook (not a SQLite database; it starts with "
            f"{shorten(repr(head[:16]), 40)}); expected a notebook file made by odolab"
        )
    raise NotebookDamagedError(
        f"{path}: the notebook is damaged (cut off after {size} bytes, "
        f"{'inside its header' if size < 100 else 'inside its first page'}); "
        f"{recovery_hint(path)}"
    )


def not_a_database(path: str | Path, err: sqlite3.Error) -> NotebookFileError | None:
    """SQLite's "file is not a database" on first reading ``path``, as one sentence (None for
    any other error)."""
    code = getattr(err, "sqlite_errorcode", None)
    if (code is not None and code & 0xFF == 26) or "not a database" in str(err).lower():
        return NotebookFileError(
            f"{path}: is not an odolab notebook (not a SQLite database, or one whose header is "
            "damaged); expected a notebook file made by odolab; if it was a notebook, "
            f"{recovery_hint(path)}"
        )
    return None


def create_notebook_file(path: Path, build: Callable[[Path], None]) -> bool:
    """Make a new notebook at ``path`` whole: ``build(tmp)`` fills a temporary file beside it,
    which is then linked into place. Returns False when another process made ``path`` meanwhile
    (theirs is kept).

    Raises:
        StoreError: the file cannot be created.
    """
    try:
        fd, name = tempfile.mkstemp(prefix=f".{path.name[:100]}.", suffix=".new", dir=path.parent)
        try:
            os.fchmod(fd, NEW_FILE_MODE)  # mkstemp's 0o600 would hide the notebook from others
        finally:
            os.close(fd)
    except OSError as err:
        raise StoreError(f"{path}: cannot create the notebook ({err.strerror or err})") from err
    tmp = Path(name)
    try:
        build(tmp)  # SQLite takes the empty temporary file as a new database
        try:
            os.link(tmp, path)  # fails if path exists: never replaces another's notebook
        except FileExistsError:
            return False
        except OSError as err:
            if err.errno not in _NO_LINKS or path.exists():
                raise
            tmp.replace(path)  # a file system without hard links: a rename, checked before
        return True
    except OSError as err:
        raise StoreError(f"{path}: cannot create the notebook ({err.strerror or err})") from err
    finally:
        for extra in ("", "-wal", "-shm", "-journal"):
            Path(f"{tmp}{extra}").unlink(missing_ok=True)


def recovery_hint(path: str | Path) -> str:
    """How to get a damaged notebook's trials back, in odolab's own commands."""
    return (
        "copy every record it still holds into a new notebook with `odolab notebook rescue "
        f"NEW.db {opt('db')} {path}` (the damaged file is only read), or go back to your last copy "
        "of it (docs/notebook.md, 'Not a notebook, or a damaged one')"
    )


def integrity_words(conn: sqlite3.Connection | None, limit: int = 120) -> str:
    """What SQLite's ``PRAGMA integrity_check`` says (or ``quick_check``, when the full check
    stops on the damage): "ok" for a sound file, else its first problem and how many more it
    found (or why it could not run)."""
    if conn is None:
        return "not run"
    rows: list[str] = []
    failed = ""
    # integrity_check itself can stop on a damaged page; quick_check skips the index checks
    for pragma in ("integrity_check(50)", "quick_check(50)"):
        try:
            for r in conn.execute(f"PRAGMA {pragma}"):
                rows.append(str(r[0]))
        except sqlite3.Error as err:
            failed = failed or str(err)
        if rows:
            break
    if not rows:
        return f"could not run ({failed})"
    problems = [
        line.strip()
        for row in rows
        for line in row.splitlines()
        if line.strip() and not line.strip().startswith("***")
    ]
    if problems == ["ok"]:
        return "ok"
    if not problems:
        return "no answer"
    more = len(problems) - 1
    tail = f" (and {more}{'+' if len(rows) >= 50 else ''} more)" if more else ""
    return repr(shorten(problems[0], limit)) + tail


def check_sound(conn: sqlite3.Connection, path: str | Path) -> None:
    """Refuse a notebook that fails SQLite's ``PRAGMA quick_check`` (a damaged page, zeroed
    bytes): its records could be read wrong without a word. The check reads every page once
    (0.11 s for 13 MB, 10,000 trials with their encoder logs, on a loaded 2-core machine);
    nothing is written. Raises :class:`NotebookDamagedError` with the integrity
    check's words and how to recover."""
    try:
        rows = [str(r[0]) for r in conn.execute("PRAGMA quick_check(1)")]
    except sqlite3.Error as err:
        if not _is_damage(err):
            raise store_error(path, err, conn, "checking it") from err
        rows = [str(err)]
    if rows == ["ok"]:
        return
    lines = [x.strip() for r in rows for x in r.splitlines() if x.strip()]
    said = [x for x in lines if not x.startswith("***")] or ["no answer"]
    first = shorten(said[0], 120)
    raise NotebookDamagedError(
        f"{path}: the notebook is damaged (SQLite: {first}; integrity check: "
        f"{integrity_words(conn)}) while opening it; {recovery_hint(path)}"
    )


def _is_damage(err: sqlite3.Error) -> bool:
    code = getattr(err, "sqlite_errorcode", None)
    if code is not None and code & 0xFF in _DAMAGED_CODES:
        return True
    text = str(err).lower()
    return "malformed" in text or "not a database" in text or "corrupt" in text


def store_error(
    path: str | Path, err: sqlite3.Error, conn: sqlite3.Connection | None, doing: str
) -> StoreError:
    """``err`` (raised while ``doing``, e.g. "reading the trials") as one sentence naming
    ``path``; a damaged file becomes :class:`NotebookDamagedError` with the integrity check's
    words and how to recover."""
    if _is_damage(err):
        return NotebookDamagedError(
            f"{path}: the notebook is damaged (SQLite: {err}; integrity check: "
            f"{integrity_words(conn)}) while {doing}; {recovery_hint(path)}"
        )
    code = getattr(err, "sqlite_errorcode", None)
    primary = None if code is None else code & 0xFF
    if primary in _BUSY_CODES:
        return StoreError(
            f"{path}: the notebook is busy (another program holds its lock) while {doing}; "
            "try again when it is done"
        )
    words = _WORDS.get(primary or -1)
    detail = f"{words}: {err}" if words else str(err)
    return StoreError(f"{path}: SQLite failed while {doing} ({detail})")
