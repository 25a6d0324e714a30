"""The notebook's SQLite schema, its migrations (``PRAGMA user_version``) and connection setup.

Schema history:

- **v1** (never released; kept as a fixture): ``campaigns``, ``params_sets`` (an autoincrement id
  per parameter set, no provenance), ``trials`` (pointing at ``params_sets.id``), no encoder logs.
- **v2**: ``robots``; ``params_versions`` numbered per robot with provenance (method,
  source trials, date, notes), never updated; ``campaigns``; ``trials`` pointing at
  ``(robot, params_version)`` with created/updated stamps; ``encoder_logs`` (compressed arrays);
  ``measurement_history`` (every measurement that was replaced, with when).
- **v3** (current): ``params_versions`` also holds the kinematic model (``model_kind``, and its
  ``[model]`` keys as a JSON object in ``model_params``) and the random error (``noise_k_left``,
  ``noise_k_right``, ``noise_k_scrub``; NULL when the set has no ``[noise]`` table). A v2 set
  becomes ``diff`` without noise, which is what it meant.

A migration is a function run inside one ``BEGIN IMMEDIATE`` transaction with foreign keys off;
``PRAGMA foreign_key_check`` must come back empty before it commits.
"""

from __future__ import annotations

import sqlite3
from collections.abc import Callable
from contextlib import suppress
from pathlib import Path

from odolab.core.errors import StoreError
from odolab.store.health import NotebookFileError, not_a_database, store_error

__all__ = ["APPLICATION_ID", "SCHEMA_V1", "SCHEMA_VERSION", "SQLValue", "connect", "migrate"]

#: A value SQLite stores in a cell, and a query's parameter.
SQLValue = str | int | float | bytes | None

#: The schema version this code writes.
SCHEMA_VERSION = 3
#: ``PRAGMA application_id`` of an odolab notebook ("odol" in ASCII), set when one is created
#: or migrated; notebooks made before have 0 and are recognised by their tables.
APPLICATION_ID = 0x6F646F6C
#: The tables each schema version has (a SQLite file without them is not a notebook).
_TABLES = {
    1: frozenset({"campaigns", "params_sets", "trials"}),
    2: frozenset(
        {"robots", "params_versions", "campaigns", "trials", "encoder_logs", "measurement_history"}
    ),
}

_KINDS = "('rotation','translation','pivot','square','free')"
_STATUSES = "('awaiting','measured','excluded')"
#: The campaigns table, the same in every version.
_CAMPAIGNS = """CREATE TABLE campaigns (
    name TEXT PRIMARY KEY,
    kind TEXT NOT NULL CHECK (kind IN ('rotation','translation','square','free')),
    terrain TEXT NOT NULL,
    date TEXT,
    operator TEXT NOT NULL DEFAULT '',
    notes TEXT NOT NULL DEFAULT ''
)"""
#: The columns of a trial row that every version has: what was asked and predicted (before the
#: parameters it was predicted with), then what was measured, the true pose and the status.
_TRIAL_HEAD = f"""    trial_id TEXT PRIMARY KEY,
    campaign TEXT NOT NULL REFERENCES campaigns(name),
    terrain TEXT NOT NULL,
    kind TEXT NOT NULL CHECK (kind IN {_KINDS}),
    angle REAL, distance REAL, side REAL, direction TEXT, speed REAL,
    predicted_t REAL NOT NULL, predicted_x REAL NOT NULL, predicted_y REAL NOT NULL,
    predicted_theta REAL NOT NULL, predicted_heading REAL NOT NULL,"""
_TRIAL_OUTCOME = f"""    instrument TEXT,
    measured_rotation REAL, measured_x REAL, measured_y REAL,
    sigma_rotation REAL, sigma_xy REAL,
    raw TEXT NOT NULL DEFAULT '{{}}',
    true_t REAL, true_x REAL, true_y REAL, true_theta REAL, true_heading REAL,
    status TEXT NOT NULL CHECK (status IN {_STATUSES}),
    exclusion_reason TEXT,"""

#: Version 1, kept so that tests can write a v1 notebook and migrate it.
SCHEMA_V1 = f"""
{_CAMPAIGNS};
CREATE TABLE params_sets (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    robot TEXT NOT NULL,
    left_wheel_radius REAL NOT NULL,
    right_wheel_radius REAL NOT NULL,
    track_width REAL NOT NULL,
    ticks_per_rev REAL NOT NULL,
    encoder_modulus INTEGER,
    created TEXT NOT NULL
);
CREATE TABLE trials (
{_TRIAL_HEAD}
    params_id INTEGER NOT NULL REFERENCES params_sets(id),
{_TRIAL_OUTCOME}
    notes TEXT NOT NULL DEFAULT ''
);
"""

_V2_TABLES = f"""
CREATE TABLE robots (
    name TEXT PRIMARY KEY,
    created TEXT NOT NULL
);
CREATE TABLE params_versions (
    robot TEXT NOT NULL REFERENCES robots(name),
    version INTEGER NOT NULL CHECK (version >= 1),
    left_wheel_radius REAL NOT NULL CHECK (left_wheel_radius > 0),
    right_wheel_radius REAL NOT NULL CHECK (right_wheel_radius > 0),
    track_width REAL NOT NULL CHECK (track_width > 0),
    ticks_per_rev REAL NOT NULL CHECK (ticks_per_rev > 0),
    encoder_modulus INTEGER,
    method TEXT NOT NULL,
    source_trials TEXT NOT NULL DEFAULT '[]',
    created TEXT NOT NULL,
    notes TEXT NOT NULL DEFAULT '',
    PRIMARY KEY (robot, version)
);
CREATE TRIGGER params_versions_no_update BEFORE UPDATE ON params_versions
BEGIN SELECT RAISE(ABORT, 'parameter versions are never changed; add a new version'); END;
CREATE TRIGGER params_versions_no_delete BEFORE DELETE ON params_versions
BEGIN SELECT RAISE(ABORT, 'parameter versions are never deleted'); END;
CREATE TABLE trials_v2 (
{_TRIAL_HEAD}
    robot TEXT NOT NULL,
    params_version INTEGER NOT NULL,
{_TRIAL_OUTCOME}
    notes TEXT NOT NULL DEFAULT '',
    created TEXT NOT NULL,
    updated TEXT NOT NULL,
    FOREIGN KEY (robot, params_version) REFERENCES params_versions(robot, version),
    CHECK (status <> 'excluded' OR exclusion_reason IS NOT NULL),
    CHECK (status <> 'measured' OR instrument IS NOT NULL)
);
CREATE TABLE measurement_history (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    trial_id TEXT NOT NULL REFERENCES trials(trial_id) ON DELETE CASCADE,
    replaced TEXT NOT NULL,
    instrument TEXT NOT NULL,
    measured_rotation REAL, measured_x REAL, measured_y REAL,
    sigma_rotation REAL, sigma_xy REAL,
    raw TEXT NOT NULL DEFAULT '{{}}'
);
CREATE TABLE encoder_logs (
    trial_id TEXT PRIMARY KEY REFERENCES trials(trial_id) ON DELETE CASCADE,
    n INTEGER NOT NULL,
    modulus INTEGER,
    codec TEXT NOT NULL,
    t BLOB NOT NULL,
    left_ticks BLOB NOT NULL,
    right_ticks BLOB NOT NULL
);
"""

_V2_INDEXES = """
CREATE INDEX trials_campaign ON trials(campaign);
CREATE INDEX trials_terrain_kind ON trials(terrain, kind);
CREATE INDEX trials_params ON trials(robot, params_version);
CREATE INDEX measurement_history_trial ON measurement_history(trial_id);
"""


def _create_v2(conn: sqlite3.Connection) -> None:
    conn.execute(_CAMPAIGNS)
    _run_script(conn, _V2_TABLES)
    conn.execute("ALTER TABLE trials_v2 RENAME TO trials")
    _run_script(conn, _V2_INDEXES)


def _migrate_1_to_2(conn: sqlite3.Connection) -> None:
    """v1 -> v2: number parameter sets per robot, add provenance, encoder logs, time stamps."""
    conn.execute("ALTER TABLE params_sets RENAME TO params_sets_v1")
    _run_script(conn, _V2_TABLES)
    conn.execute(
        "INSERT INTO robots (name, created) "
        "SELECT robot, MIN(created) FROM params_sets_v1 GROUP BY robot"
    )
    conn.execute(
        """INSERT INTO params_versions (robot, version, left_wheel_radius, right_wheel_radius,
               track_width, ticks_per_rev, encoder_modulus, method, source_trials, created, notes)
           SELECT robot, ROW_NUMBER() OVER (PARTITION BY robot ORDER BY id),
               left_wheel_radius, right_wheel_radius, track_width, ticks_per_rev,
               encoder_modulus, 'unknown (from schema v1)', '[]', created, ''
           FROM params_sets_v1"""
    )
    conn.execute(
        """INSERT INTO trials_v2
           SELECT t.trial_id, t.campaign, t.terrain, t.kind, t.angle, t.distance, t.side,
               t.direction, t.speed, t.predicted_t, t.predicted_x, t.predicted_y,
               t.predicted_theta, t.predicted_heading, p.robot, p.version, t.instrument,
               t.measured_rotation, t.measured_x, t.measured_y, t.sigma_rotation, t.sigma_xy,
               t.raw, t.true_t, t.true_x, t.true_y, t.true_theta, t.true_heading, t.status,
               COALESCE(t.exclusion_reason, CASE WHEN t.status = 'excluded'
                   THEN 'excluded (no reason recorded in schema v1)' END),
               t.notes, s.created, s.created
           FROM trials AS t
           JOIN params_sets_v1 AS s ON s.id = t.params_id
           JOIN (SELECT id, robot, ROW_NUMBER() OVER (PARTITION BY robot ORDER BY id) AS version
                 FROM params_sets_v1) AS p ON p.id = t.params_id
           ORDER BY t.rowid"""
    )
    conn.execute("DROP TABLE trials")
    conn.execute("DROP TABLE params_sets_v1")
    conn.execute("ALTER TABLE trials_v2 RENAME TO trials")
    _run_script(conn, _V2_INDEXES)


_V3_PARAMS_COLUMNS = """
ALTER TABLE params_versions ADD COLUMN model_kind TEXT NOT NULL DEFAULT 'diff';
ALTER TABLE params_versions ADD COLUMN model_params TEXT NOT NULL DEFAULT '{}';
ALTER TABLE params_versions ADD COLUMN noise_k_left REAL CHECK (noise_k_left >= 0);
ALTER TABLE params_versions ADD COLUMN noise_k_right REAL CHECK (noise_k_right >= 0);
ALTER TABLE params_versions ADD COLUMN noise_k_scrub REAL CHECK (noise_k_scrub >= 0);
"""


def _migrate_2_to_3(conn: sqlite3.Connection) -> None:
    """v2 -> v3: the kinematic model and the noise of each parameter set (v2 sets: plain
    differential drive, no noise; ADD COLUMN changes no row, so the no-update trigger holds)."""
    _run_script(conn, _V3_PARAMS_COLUMNS)


#: MIGRATIONS[v] turns a version-v notebook into version v+1.
MIGRATIONS: dict[int, Callable[[sqlite3.Connection], None]] = {
    1: _migrate_1_to_2,
    2: _migrate_2_to_3,
}


def _run_script(conn: sqlite3.Connection, script: str) -> None:
    """Run ``;``-separated statements one by one (executescript would commit)."""
    buf = ""
    for line in script.splitlines(keepends=True):
        buf += line
        if sqlite3.complete_statement(buf):
            conn.execute(buf)
            buf = ""
    if buf.strip():  # pragma: no cover - our scripts end with ';'
        conn.execute(buf)


def connect(path: str | Path, *, timeout: float = 30.0, new: bool = False) -> sqlite3.Connection:
    """Open ``path`` with WAL, foreign keys on and a busy timeout; autocommit mode.

    ``new``: ``path`` is a notebook being built (an empty file); otherwise an empty SQLite
    database (no schema, no tables) is refused as the empty file is, before anything is written.

    Writes are then wrapped in explicit ``BEGIN IMMEDIATE ... COMMIT`` by the caller, so that a
    writer waits for the lock up front (and the busy timeout applies) instead of failing on a
    lock upgrade half way.

    Raises:
        StoreError: the notebook cannot be opened or switched to WAL mode.
    """
    conn: sqlite3.Connection | None = None
    try:
        conn = sqlite3.connect(str(path), timeout=timeout, isolation_level=None)
        conn.execute(f"PRAGMA busy_timeout = {int(timeout * 1000)}")
        # another program's database is refused before anything (WAL mode) is written to it
        try:  # SQLite's first read of the file: its header
            version = int(conn.execute("PRAGMA user_version").fetchone()[0])
        except sqlite3.DatabaseError as err:
            refusal = not_a_database(path, err)
            if refusal is None:
                raise
            raise refusal from err
        _check_odolab(conn, version, str(path))
        _check_not_newer(version, str(path))
        if not new and version == 0:
            _check_not_empty(conn, str(path))
        mode = conn.execute("PRAGMA journal_mode = WAL").fetchone()[0]
        if str(mode).lower() != "wal":
            raise StoreError(f"{path}: cannot switch the notebook to WAL mode (got {mode!r})")
        conn.execute("PRAGMA synchronous = NORMAL")
        conn.execute("PRAGMA foreign_keys = ON")
    except StoreError:
        if conn is not None:
            conn.close()
        raise
    except sqlite3.Error as err:
        error = store_error(path, err, conn, "opening it")
        if conn is not None:
            conn.close()
        raise error from err
    return conn


def _check_odolab(conn: sqlite3.Connection, version: int, source: str) -> None:
    """Refuse a SQLite database of another program: another application id, or (for one
    without odolab's id, as notebooks made before it was set are) tables other than odolab's."""
    app_id = int(conn.execute("PRAGMA application_id").fetchone()[0])
    if app_id == APPLICATION_ID:
        return
    tables = {
        str(r[0]) for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")
    }
    missing = sorted((_TABLES[1] if version == 1 else _TABLES[2]) - tables)
    if app_id != 0:
        what = f"its application id is {app_id:#x}"
    elif version == 0 and tables:
        n = len(tables)
        what = f"it holds {n} table{'s' if n > 1 else ''} but no odolab schema"
    elif 0 < version <= SCHEMA_VERSION and missing:
        what = f"it has no table {missing[0]!r}"
    else:
        return
    raise NotebookFileError(
        f"{source}: a SQLite database of another program, not an odolab notebook ({what}); "
        "expected a notebook file made by odolab"
    )


def _check_not_empty(conn: sqlite3.Connection, source: str) -> None:
    """Refuse an empty SQLite database (no schema version, no tables): odolab builds a new
    notebook whole in a file of its own, so this was never one of its notebooks, and reading it
    must not write odolab's tables into it."""
    if conn.execute("SELECT COUNT(*) FROM sqlite_master").fetchone()[0] == 0:
        raise NotebookFileError(
            f"{source}: is an empty SQLite database, not an odolab notebook; remove it, or give "
            "a new file name to create a notebook there"
        )


def _check_not_newer(version: int, source: str) -> None:
    if version > SCHEMA_VERSION:
        raise StoreError(
            f"{source}: written by a newer odolab (schema {version}); "
            f"this one reads up to schema {SCHEMA_VERSION}"
        )


def migrate(conn: sqlite3.Connection, source: str = "notebook") -> int:
    """Bring the database to :data:`SCHEMA_VERSION`; return the version it had before.

    A new (empty) database gets the current schema. Each step runs in its own transaction.

    Raises:
        StoreError: the migration fails or leaves a broken reference.
    """
    try:
        before = int(conn.execute("PRAGMA user_version").fetchone()[0])
        _check_odolab(conn, before, source)
        _check_not_newer(before, source)
        if before == SCHEMA_VERSION:
            return before
        conn.execute("PRAGMA foreign_keys = OFF")
        try:
            conn.execute("BEGIN IMMEDIATE")
            try:
                # Read again under the write lock: another process may have migrated meanwhile.
                version = int(conn.execute("PRAGMA user_version").fetchone()[0])
                if version == 0:
                    has_tables = conn.execute(
                        "SELECT COUNT(*) FROM sqlite_master WHERE type = 'table'"
                    ).fetchone()[0]
                    if has_tables:  # made meanwhile by another program
                        _check_odolab(conn, 0, source)
                    _create_v2(conn)  # then the migrations from v2 on
                    version = 2
                while version < SCHEMA_VERSION:
                    MIGRATIONS[version](conn)
                    version += 1
                bad = conn.execute("PRAGMA foreign_key_check").fetchall()
                if bad:
                    raise StoreError(
                        f"{source}: migration to schema {SCHEMA_VERSION} left a broken reference "
                        f"in table {bad[0][0]!r}; the notebook was not changed"
                    )
                conn.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
                conn.execute(f"PRAGMA application_id = {APPLICATION_ID}")
                conn.execute("COMMIT")
            except BaseException:
                if conn.in_transaction:
                    with suppress(sqlite3.Error):  # a damaged file: the error says so
                        conn.execute("ROLLBACK")
                raise
        finally:
            conn.execute("PRAGMA foreign_keys = ON")
    except sqlite3.Error as err:
        raise store_error(source, err, conn, "opening or migrating it") from err
    return before
