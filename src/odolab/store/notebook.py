"""The lab notebook: one SQLite file of robots, parameter versions, campaigns and trials.

Every write runs in one ``BEGIN IMMEDIATE ... COMMIT`` transaction, so a crash leaves either
all of it or none of it; the database is in WAL mode with a busy timeout, so a robot run being
saved and a person typing measurements can write at the same time (one waits for the other's
short transaction). Parameter versions are append-only (triggers refuse UPDATE and DELETE).
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import functools
import inspect
import json
import sqlite3
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager, suppress
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from odolab.core.closing import Closing
from odolab.core.errors import StoreError, opt
from odolab.core.params import RobotParams
from odolab.core.progress import Progress, no_progress
from odolab.core.trajectory import Pose
from odolab.core.trials import (
    EncoderLog,
    Measurement,
    Trial,
    TrialStatus,
    check_no_nul,
    signed_command,
)
from odolab.core.writing import strict_json
from odolab.store.codec import EncodedLog, decode_log, encode_log
from odolab.store.health import (
    check_notebook_file,
    check_sound,
    create_notebook_file,
    integrity_words,
    store_error,
)
from odolab.store.records import (
    CAMPAIGN_KINDS,
    HISTORY_KEYS,
    PARAMS_EXTRA_COLUMNS,
    PARAMS_FIELDS,
    TRIAL_COLUMNS,
    campaign_kind_for,
    params_columns,
    params_from_columns,
    record_from_trial,
    trial_from_record,
    validate_trial,
)
from odolab.store.schema import SCHEMA_VERSION, SQLValue, connect, migrate

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["Campaign", "Notebook", "NotebookInfo", "ParamsVersion", "Progress"]


def _now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


@dataclass(frozen=True)
class ParamsVersion:
    """One version of a robot's parameters and where it came from."""

    robot: str
    version: int
    params: RobotParams
    method: str  #: e.g. "preset", "ratios", "umbmark", "least-squares", "recorded with a trial"
    source_trials: tuple[str, ...]
    created: str  #: ISO 8601, UTC
    notes: str


@dataclass(frozen=True)
class Campaign:
    """A series of trials of one kind on one terrain."""

    name: str
    kind: str  #: rotation / translation / square / free
    terrain: str
    date: str | None
    operator: str
    notes: str


@dataclass(frozen=True)
class NotebookInfo:
    """What a notebook holds."""

    path: Path
    schema_version: int
    migrated_from: int
    robots: int
    params_versions: int
    campaigns: int
    trials: int
    by_status: dict[str, int]
    encoder_logs: int


_TRIAL_INSERT = (
    f"INSERT INTO trials ({', '.join(TRIAL_COLUMNS)}, created, updated) "
    f"VALUES ({', '.join(':' + c for c in TRIAL_COLUMNS)}, :created, :updated)"
)
_LOG_INSERT = (
    "INSERT INTO encoder_logs (trial_id, n, modulus, codec, t, left_ticks, right_ticks) "
    "VALUES (?, ?, ?, ?, ?, ?, ?)"
)


def _build(path: Path, timeout: float) -> None:
    """A new, empty notebook of the current schema in the file ``path``."""
    conn = connect(path, timeout=timeout, new=True)
    try:
        migrate(conn, str(path))
    finally:
        conn.close()


def _measurement_from_row(r: sqlite3.Row) -> Measurement:
    return Measurement(
        instrument=r["instrument"],
        rotation=r["measured_rotation"],
        x=r["measured_x"],
        y=r["measured_y"],
        sigma_rotation=r["sigma_rotation"],
        sigma_xy=r["sigma_xy"],
        raw={str(k): float(v) for k, v in json.loads(r["raw"]).items()},
    )


class Notebook(Closing):
    """The lab notebook in the SQLite file ``path`` (created and migrated on open).

    Use as a context manager, or call :meth:`close`. One ``Notebook`` per thread.

    An existing file is checked first (``check``, SQLite's quick check: every page read once),
    and a damaged one refused (:class:`~odolab.store.health.NotebookDamagedError`) before
    anything reads or writes its records; ``check=False`` where the file was just checked (the
    web server checks it when it starts, then opens one connection per request).
    """

    def __init__(
        self, path: str | Path = "odolab.db", *, timeout: float = 30.0, check: bool = True
    ) -> None:
        self.path = Path(path)
        # an empty file, a folder, a text file: refused before SQLite touches it
        created = False
        if not check_notebook_file(self.path):
            created = create_notebook_file(self.path, lambda tmp: _build(tmp, timeout))
        self._conn = connect(self.path, timeout=timeout)
        self._conn.row_factory = sqlite3.Row
        self._params_cache: dict[tuple[str, int], RobotParams] = {}
        try:
            if check and not created:
                check_sound(self._conn, self.path)
            self.migrated_from = 0 if created else migrate(self._conn, str(self.path))
        except BaseException:
            self._conn.close()
            raise

    # -- plumbing -------------------------------------------------------------------------------

    def close(self) -> None:
        """Close the connection (committed data is safe whatever happens next)."""
        self._conn.close()

    def _error(self, err: sqlite3.Error, doing: str) -> StoreError:
        """``err`` as one sentence (a damaged file: with the integrity check and recovery)."""
        return store_error(self.path, err, self._conn, doing)

    @contextmanager
    def _write(self) -> Iterator[sqlite3.Connection]:
        """One write transaction; database errors become :class:`StoreError`."""
        conn = self._conn
        try:
            conn.execute("BEGIN IMMEDIATE")
        except sqlite3.Error as err:
            raise self._error(err, "starting a write") from err
        try:
            yield conn
        except BaseException as err:
            if conn.in_transaction:
                with suppress(sqlite3.Error):  # a damaged file: err says so
                    conn.execute("ROLLBACK")
            if isinstance(err, sqlite3.IntegrityError):
                raise StoreError(f"{self.path}: write refused ({err}); nothing changed") from err
            if isinstance(err, sqlite3.Error):
                raise self._error(err, "writing; nothing changed") from err
            raise
        else:
            try:
                conn.execute("COMMIT")
            except sqlite3.Error as err:
                if conn.in_transaction:
                    with suppress(sqlite3.Error):
                        conn.execute("ROLLBACK")
                raise self._error(err, "committing a write; nothing changed") from err

    def _one(self, sql: str, args: Sequence[SQLValue] = ()) -> sqlite3.Row | None:
        row: sqlite3.Row | None = self._conn.execute(sql, args).fetchone()
        return row

    def integrity_check(self) -> str:
        """SQLite's ``PRAGMA integrity_check`` answer: "ok" when sound, else its first problem
        and how many more (:func:`odolab.store.health.integrity_words`)."""
        return integrity_words(self._conn, limit=400)

    def info(self) -> NotebookInfo:
        """Counts of what the notebook holds."""

        def count(table: str) -> int:
            return int(self._conn.execute(f"SELECT COUNT(*) FROM {table}").fetchone()[0])

        by_status = {
            str(r[0]): int(r[1])
            for r in self._conn.execute("SELECT status, COUNT(*) FROM trials GROUP BY status")
        }
        return NotebookInfo(
            path=self.path,
            schema_version=SCHEMA_VERSION,
            migrated_from=self.migrated_from,
            robots=count("robots"),
            params_versions=count("params_versions"),
            campaigns=count("campaigns"),
            trials=count("trials"),
            by_status=by_status,
            encoder_logs=count("encoder_logs"),
        )

    # -- robots and parameter versions ----------------------------------------------------------

    def _params_from_row(self, row: sqlite3.Row) -> RobotParams:
        """The parameter set of a ``params_versions`` row (or a trial row joined with one)."""
        values = dict(row)
        version = values.get("params_version", values.get("version"))
        source = f"{self.path}: parameter version {version} of {values['robot']!r}"
        return params_from_columns(values, source)

    def _insert_params_version(
        self,
        conn: sqlite3.Connection,
        params: RobotParams,
        *,
        version: int | None,
        method: str,
        source_trials: Sequence[str],
        created: str | None,
        notes: str,
    ) -> int:
        robot = params.name
        now = _now()
        conn.execute("INSERT OR IGNORE INTO robots (name, created) VALUES (?, ?)", (robot, now))
        if version is None:
            last = conn.execute(
                "SELECT MAX(version) FROM params_versions WHERE robot = ?", (robot,)
            ).fetchone()[0]
            version = 1 if last is None else int(last) + 1
        extra = params_columns(params)
        conn.execute(
            "INSERT INTO params_versions (robot, version, left_wheel_radius, right_wheel_radius, "
            "track_width, ticks_per_rev, encoder_modulus, method, source_trials, created, notes, "
            f"{', '.join(PARAMS_EXTRA_COLUMNS)}) "
            f"VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?{', ?' * len(PARAMS_EXTRA_COLUMNS)})",
            (
                robot,
                version,
                params.left_wheel_radius,
                params.right_wheel_radius,
                params.track_width,
                params.ticks_per_rev,
                params.encoder_modulus,
                method,
                strict_json(list(source_trials), indent=None),
                created or now,
                notes,
                *(extra[c] for c in PARAMS_EXTRA_COLUMNS),
            ),
        )
        return version

    def add_params_version(
        self,
        params: RobotParams,
        *,
        method: str,
        source_trials: Sequence[str] = (),
        notes: str = "",
    ) -> int:
        """Add a new version of ``params.name``'s parameters; return its number (1, 2, ...).

        ``method`` says how they were obtained (e.g. "preset", "ratios", "umbmark") and
        ``source_trials`` which trials they were computed from; both are kept with the version.

        Raises:
            StoreError: the method is empty, or a source trial is not in the notebook.
        """
        if not isinstance(method, str) or not method.strip():
            raise StoreError("a parameter version needs a method (how it was obtained)")
        sources = [str(s) for s in source_trials]
        with self._write() as conn:
            if sources:
                known = {
                    r[0]
                    for r in conn.execute(
                        f"SELECT trial_id FROM trials WHERE trial_id IN "
                        f"({','.join('?' * len(sources))})",
                        sources,
                    )
                }
                missing = [s for s in sources if s not in known]
                if missing:
                    raise StoreError(
                        f"source trial {missing[0]!r} of the new {params.name} parameters is not "
                        "in the notebook"
                    )
            return self._insert_params_version(
                conn,
                params,
                version=None,
                method=method.strip(),
                source_trials=sources,
                created=None,
                notes=notes,
            )

    def robots(self) -> list[str]:
        """Names of the robots that have parameters in the notebook."""
        return [r[0] for r in self._conn.execute("SELECT name FROM robots ORDER BY name")]

    def params_versions(self, robot: str) -> list[ParamsVersion]:
        """All versions of ``robot``'s parameters, oldest first (empty if none)."""
        rows = self._conn.execute(
            "SELECT * FROM params_versions WHERE robot = ? ORDER BY version", (robot,)
        ).fetchall()
        return [
            ParamsVersion(
                robot=r["robot"],
                version=int(r["version"]),
                params=self._params_from_row(r),
                method=r["method"],
                source_trials=tuple(json.loads(r["source_trials"])),
                created=r["created"],
                notes=r["notes"],
            )
            for r in rows
        ]

    def get_params(self, robot: str, version: int) -> RobotParams:
        """Version ``version`` of ``robot``'s parameters.

        Raises:
            StoreError: the notebook has no such version of the robot's parameters.
        """
        row = self._one(
            "SELECT * FROM params_versions WHERE robot = ? AND version = ?", (robot, int(version))
        )
        if row is None:
            raise StoreError(f"no parameter version {version} of robot {robot!r} in {self.path}")
        return self._params_from_row(row)

    def latest_params(self, robot: str) -> RobotParams:
        """The newest version of ``robot``'s parameters.

        Raises:
            StoreError: the notebook has no parameters of the robot.
        """
        row = self._one(
            "SELECT * FROM params_versions WHERE robot = ? ORDER BY version DESC LIMIT 1", (robot,)
        )
        if row is None:
            raise StoreError(f"no parameters of robot {robot!r} in {self.path}")
        return self._params_from_row(row)

    def latest_params_version(self, robot: str) -> int | None:
        """The newest version number of ``robot``'s parameters, or None."""
        row = self._one("SELECT MAX(version) FROM params_versions WHERE robot = ?", (robot,))
        return None if row is None or row[0] is None else int(row[0])

    def find_params_version(self, params: RobotParams) -> int | None:
        """The newest version of ``params.name`` with exactly these values (kinematic model and
        noise included), or None."""
        extra = params_columns(params)
        row = self._conn.execute(
            "SELECT MAX(version) FROM params_versions WHERE robot = ? AND left_wheel_radius = ? "
            "AND right_wheel_radius = ? AND track_width = ? AND ticks_per_rev = ? "
            "AND encoder_modulus IS ? " + "".join(f"AND {c} IS ? " for c in PARAMS_EXTRA_COLUMNS),
            (
                params.name,
                params.left_wheel_radius,
                params.right_wheel_radius,
                params.track_width,
                params.ticks_per_rev,
                params.encoder_modulus,
                *(extra[c] for c in PARAMS_EXTRA_COLUMNS),
            ),
        ).fetchone()
        return None if row[0] is None else int(row[0])

    # -- campaigns ------------------------------------------------------------------------------

    @staticmethod
    def _check_campaign(name: str, kind: str, terrain: str) -> None:
        if not isinstance(name, str) or not name.strip() or name != name.strip():
            raise StoreError(f"campaign name {name!r} must be non-empty text without spaces around")
        if kind not in CAMPAIGN_KINDS:
            raise StoreError(
                f"campaign {name}: kind {kind!r} is not one of {', '.join(CAMPAIGN_KINDS)}"
            )
        if not isinstance(terrain, str) or not terrain.strip():
            raise StoreError(f"campaign {name}: terrain must be non-empty text")

    def add_campaign(
        self,
        name: str,
        kind: str,
        terrain: str,
        *,
        date: str | _dt.date | None = None,
        operator: str = "",
        notes: str = "",
    ) -> None:
        """Add a campaign; a name already used is refused (nothing changes).

        Raises:
            StoreError: the date is not YYYY-MM-DD, or the campaign is already in the notebook.
        """
        kind = str(kind)
        for what, text in (("name", name), ("terrain", terrain), ("operator", operator),
                           ("notes", notes)):  # fmt: skip
            check_no_nul(text, what, "campaign", StoreError)
        self._check_campaign(name, kind, terrain)
        day = date.isoformat() if isinstance(date, _dt.date) else date
        if day is None:
            day = _dt.datetime.now(_dt.UTC).date().isoformat()
        try:
            _dt.date.fromisoformat(day)
        except (TypeError, ValueError):
            raise StoreError(
                f"campaign {name}: date {day!r} is not a date; expected YYYY-MM-DD"
            ) from None
        with self._write() as conn:
            if conn.execute("SELECT 1 FROM campaigns WHERE name = ?", (name,)).fetchone():
                raise StoreError(f"campaign {name!r} is already in {self.path}")
            conn.execute(
                "INSERT INTO campaigns (name, kind, terrain, date, operator, notes) "
                "VALUES (?, ?, ?, ?, ?, ?)",
                (name, kind, terrain, day, operator, notes),
            )

    def campaigns(self) -> list[Campaign]:
        """All campaigns, by date then name."""
        return [
            Campaign(r["name"], r["kind"], r["terrain"], r["date"], r["operator"], r["notes"])
            for r in self._conn.execute("SELECT * FROM campaigns ORDER BY date, name")
        ]

    def get_campaign(self, name: str) -> Campaign:
        """The campaign called ``name``.

        Raises:
            StoreError: the notebook has no such campaign.
        """
        r = self._one("SELECT * FROM campaigns WHERE name = ?", (name,))
        if r is None:
            raise StoreError(f"no campaign {name!r} in {self.path}")
        return Campaign(r["name"], r["kind"], r["terrain"], r["date"], r["operator"], r["notes"])

    def campaign_names(self) -> set[str]:
        """Names of all campaigns."""
        return {r[0] for r in self._conn.execute("SELECT name FROM campaigns")}

    def trial_ids(self) -> set[str]:
        """Ids of all trials."""
        return {r[0] for r in self._conn.execute("SELECT trial_id FROM trials")}

    # -- trials ---------------------------------------------------------------------------------

    def _insert_trials(
        self,
        conn: sqlite3.Connection,
        trials: Sequence[Trial],
        versions: Sequence[int | None],
        *,
        create_campaigns: bool,
        stamps: Sequence[tuple[str, str] | None] | None = None,
        histories: Sequence[Sequence[dict[str, object]]] | None = None,
        new_params_method: str = "recorded with a trial",
    ) -> None:
        """Insert validated trials inside the caller's transaction."""
        now = _now()
        campaigns = {r[0] for r in conn.execute("SELECT name FROM campaigns")}
        resolved: dict[RobotParams, int] = {}
        for i, (trial, version) in enumerate(zip(trials, versions, strict=True)):
            if trial.campaign not in campaigns:
                if not create_campaigns:
                    raise StoreError(
                        f"trial {trial.trial_id}: unknown campaign {trial.campaign!r}; add it "
                        "first (odolab trials campaign-add)"
                    )
                conn.execute(
                    "INSERT INTO campaigns (name, kind, terrain, date, operator, notes) "
                    "VALUES (?, ?, ?, ?, '', 'created with its first trial')",
                    (
                        trial.campaign,
                        campaign_kind_for(trial.command.kind),
                        trial.terrain,
                        now[:10],
                    ),
                )
                campaigns.add(trial.campaign)
            if version is None:
                version = resolved.get(trial.params)
                if version is None:
                    version = self.find_params_version(trial.params)
                if version is None:
                    version = self._insert_params_version(
                        conn,
                        trial.params,
                        version=None,
                        method=new_params_method,
                        source_trials=(),
                        created=None,
                        notes=f"first used by trial {trial.trial_id}",
                    )
                resolved[trial.params] = version
            rec = record_from_trial(trial, version)
            stamp = stamps[i] if stamps is not None else None
            rec["created"], rec["updated"] = stamp if stamp is not None else (now, now)
            try:
                conn.execute(_TRIAL_INSERT, rec)
            except sqlite3.IntegrityError as err:
                if "trials.trial_id" in str(err):
                    raise StoreError(
                        f"trial {trial.trial_id!r} is already in {self.path}; trial ids are unique"
                    ) from err
                raise StoreError(f"trial {trial.trial_id}: refused ({err})") from err
            if trial.encoder_log is not None:
                enc = encode_log(trial.encoder_log)
                conn.execute(_LOG_INSERT, (trial.trial_id, *enc))
            for h in histories[i] if histories is not None else ():
                conn.execute(
                    "INSERT INTO measurement_history (trial_id, replaced, instrument, "
                    "measured_rotation, measured_x, measured_y, sigma_rotation, sigma_xy, raw) "
                    "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                    (
                        trial.trial_id,
                        *(h[k] for k in HISTORY_KEYS[:-1]),
                        strict_json(h["raw"], indent=None),
                    ),
                )

    def add_trial(self, trial: Trial, *, create_campaign: bool = True) -> None:
        """Record one trial (see :meth:`add_trials`)."""
        self.add_trials([trial], create_campaigns=create_campaign)

    def add_trials(
        self,
        trials: Sequence[Trial],
        progress: Progress | None = None,
        *,
        create_campaigns: bool = True,
    ) -> None:
        """Record ``trials`` in ONE transaction: all of them or, on any error, none.

        A campaign the notebook does not know is created from the first trial that names it
        (kind from the command: rotation/translation/square, else free; the trial's terrain),
        unless ``create_campaigns`` is False, in which case it is an error. The parameter set of
        each trial is matched by value to the newest identical version of its robot; when there
        is none, a new version is added with method "recorded with a trial".

        Raises:
            StoreError: a trial id appears twice, is already stored, or a trial is invalid.
        """
        trials = list(trials)
        seen: set[str] = set()
        for t in trials:
            validate_trial(t)
            if t.trial_id in seen:
                raise StoreError(f"trial id {t.trial_id!r} appears twice in the batch")
            seen.add(t.trial_id)
        # stored as every read gives them back: a reverse run's distance negative
        trials = [dataclasses.replace(t, command=signed_command(t.command)) for t in trials]
        with self._write() as conn:
            self._insert_trials(
                conn, trials, [None] * len(trials), create_campaigns=create_campaigns
            )
        (progress or no_progress)(len(trials), len(trials), "trials")

    def _trial_rows(self, where: str, args: Sequence[SQLValue]) -> list[sqlite3.Row]:
        return self._conn.execute(
            "SELECT t.*, p.left_wheel_radius, p.right_wheel_radius, p.track_width, "
            "p.ticks_per_rev, p.encoder_modulus, "
            + "".join(f"p.{c}, " for c in PARAMS_EXTRA_COLUMNS)
            + "e.n AS log_n, e.modulus AS log_modulus, "
            "e.codec AS log_codec, e.t AS log_t, e.left_ticks AS log_left, "
            "e.right_ticks AS log_right "
            "FROM trials AS t "
            "JOIN params_versions AS p ON p.robot = t.robot AND p.version = t.params_version "
            f"LEFT JOIN encoder_logs AS e ON e.trial_id = t.trial_id {where} ORDER BY t.rowid",
            args,
        ).fetchall()

    def _trial_from_row(self, row: sqlite3.Row, *, with_log: bool = True) -> Trial:
        cache_key = (row["robot"], row["params_version"])
        params = self._params_cache.get(cache_key)
        if params is None:  # versions never change, so caching them is safe
            params = self._params_from_row(row)
            self._params_cache[cache_key] = params
        log = None
        if with_log and row["log_codec"] is not None:
            log = decode_log(
                EncodedLog(
                    row["log_n"],
                    row["log_modulus"],
                    row["log_codec"],
                    row["log_t"],
                    row["log_left"],
                    row["log_right"],
                )
            )
        return trial_from_record(dict(row), params, log)

    def get_trial(self, trial_id: str) -> Trial:
        """The trial ``trial_id`` with its measurement and encoder log.

        Raises:
            StoreError: the notebook has no such trial.
        """
        rows = self._trial_rows("WHERE t.trial_id = ?", (trial_id,))
        if not rows:
            raise StoreError(f"no trial {trial_id!r} in {self.path}")
        return self._trial_from_row(rows[0])

    def trial_params_version(self, trial_id: str) -> tuple[str, int]:
        """``(robot, params_version)`` that produced ``trial_id``'s prediction.

        Raises:
            StoreError: the notebook has no such trial.
        """
        row = self._one("SELECT robot, params_version FROM trials WHERE trial_id = ?", (trial_id,))
        if row is None:
            raise StoreError(f"no trial {trial_id!r} in {self.path}")
        return str(row[0]), int(row[1])

    def encoder_log(self, trial_id: str) -> EncoderLog | None:
        """The encoder log of ``trial_id`` (None if it was not recorded)."""
        self.trial_params_version(trial_id)  # raises for an unknown trial
        row = self._one(
            "SELECT n, modulus, codec, t, left_ticks, right_ticks FROM encoder_logs "
            "WHERE trial_id = ?",
            (trial_id,),
        )
        return None if row is None else decode_log(EncodedLog(*row))

    @staticmethod
    def _filters(
        campaign: str | None,
        terrain: str | None,
        kind: str | None,
        status: str | Sequence[str] | None,
    ) -> tuple[str, list[SQLValue]]:
        clauses: list[str] = []
        args: list[SQLValue] = []
        for col, value in (("campaign", campaign), ("terrain", terrain), ("kind", kind)):
            if value is not None:
                clauses.append(f"t.{col} = ?")
                args.append(str(value))
        if status is not None:
            statuses = [str(status)] if isinstance(status, str) else [str(s) for s in status]
            clauses.append(f"t.status IN ({','.join('?' * len(statuses))})")
            args.extend(statuses)
        return ("WHERE " + " AND ".join(clauses) if clauses else ""), args

    def load_trials(
        self,
        campaign: str | None = None,
        terrain: str | None = None,
        kind: str | None = None,
        status: str | Sequence[str] | None = None,
        *,
        with_logs: bool = True,
    ) -> list[Trial]:
        """Trials matching every filter given, in the order they were recorded."""
        where, args = self._filters(campaign, terrain, kind, status)
        return [self._trial_from_row(r, with_log=with_logs) for r in self._trial_rows(where, args)]

    def set_measurement(self, trial_id: str, m: Measurement, *, replace: bool = False) -> None:
        """Record what was measured for ``trial_id``; its status becomes measured.

        A trial already measured keeps its measurement unless ``replace`` is True; the replaced
        one is kept in the trial's :meth:`measurement_history`. An excluded trial stays excluded.

        Raises:
            StoreError: the notebook has no such trial, or it is already measured and ``replace`` is
                false.
        """
        with self._write() as conn:
            row = conn.execute("SELECT * FROM trials WHERE trial_id = ?", (trial_id,)).fetchone()
            if row is None:
                raise StoreError(f"no trial {trial_id!r} in {self.path}")
            if row["instrument"] is not None and not replace:
                raise StoreError(
                    f"trial {trial_id} is already measured; pass replace=True ({opt('replace')}) "
                    "to overwrite its measurement"
                )
            rec = dict(row)
            if row["instrument"] is not None:  # keep what is replaced
                conn.execute(
                    "INSERT INTO measurement_history (trial_id, replaced, instrument, "
                    "measured_rotation, measured_x, measured_y, sigma_rotation, sigma_xy, raw) "
                    "SELECT trial_id, ?, instrument, measured_rotation, measured_x, measured_y, "
                    "sigma_rotation, sigma_xy, raw FROM trials WHERE trial_id = ?",
                    (_now(), trial_id),
                )
            params = self.get_params(rec["robot"], rec["params_version"])
            trial = trial_from_record(rec, params)
            status = trial.status if trial.status is TrialStatus.EXCLUDED else TrialStatus.MEASURED
            new = dataclasses.replace(trial, measured=m, status=status)
            validate_trial(new)
            upd = record_from_trial(new, rec["params_version"])
            conn.execute(
                "UPDATE trials SET instrument = ?, measured_rotation = ?, measured_x = ?, "
                "measured_y = ?, sigma_rotation = ?, sigma_xy = ?, raw = ?, status = ?, "
                "updated = ? WHERE trial_id = ?",
                (
                    upd["instrument"],
                    upd["measured_rotation"],
                    upd["measured_x"],
                    upd["measured_y"],
                    upd["sigma_rotation"],
                    upd["sigma_xy"],
                    upd["raw"],
                    upd["status"],
                    _now(),
                    trial_id,
                ),
            )

    def exclude_trial(self, trial_id: str, reason: str) -> None:
        """Leave ``trial_id`` out of the analysis, keeping it and saying why.

        Raises:
            StoreError: the reason is empty, or the notebook has no such trial.
        """
        if not isinstance(reason, str) or not reason.strip():
            raise StoreError(f"excluding trial {trial_id} needs a reason")
        check_no_nul(reason, "the reason", f"excluding trial {trial_id}", StoreError)
        with self._write() as conn:
            # excluded again: the earlier reason is kept after the new one (it was replaced)
            cur = conn.execute(
                "UPDATE trials SET status = 'excluded', exclusion_reason = CASE "
                "WHEN status = 'excluded' AND exclusion_reason IS NOT NULL "
                "AND exclusion_reason != ? THEN ? || '; earlier: ' || exclusion_reason "
                "ELSE ? END, updated = ? WHERE trial_id = ?",
                (reason.strip(), reason.strip(), reason.strip(), _now(), trial_id),
            )
            if cur.rowcount == 0:
                raise StoreError(f"no trial {trial_id!r} in {self.path}")

    def include_trial(self, trial_id: str) -> None:
        """Undo :meth:`exclude_trial`: the status goes back to measured or awaiting; the
        reason it was excluded for is kept in the trial's notes (``excluded until <time>:
        <reason>``), not dropped.

        Raises:
            StoreError: the notebook has no such trial.
        """
        now = _now()
        with self._write() as conn:
            cur = conn.execute(
                "UPDATE trials SET status = CASE WHEN instrument IS NULL THEN 'awaiting' "
                "ELSE 'measured' END, notes = CASE WHEN status = 'excluded' AND "
                "exclusion_reason IS NOT NULL THEN notes || CASE WHEN notes = '' THEN '' "
                "ELSE '; ' END || 'excluded until ' || ? || ': ' || exclusion_reason "
                "ELSE notes END, "
                "exclusion_reason = NULL, updated = ? WHERE trial_id = ?",
                (now, now, trial_id),
            )
            if cur.rowcount == 0:
                raise StoreError(f"no trial {trial_id!r} in {self.path}")

    def measurement_history(self, trial_id: str) -> list[tuple[str, Measurement]]:
        """Measurements of ``trial_id`` that were replaced, oldest first, with when (ISO, UTC)."""
        self.trial_params_version(trial_id)  # raises for an unknown trial
        rows = self._conn.execute(
            "SELECT * FROM measurement_history WHERE trial_id = ? ORDER BY id", (trial_id,)
        ).fetchall()
        return [(r["replaced"], _measurement_from_row(r)) for r in rows]

    def repredict(self, trial_id: str, params: RobotParams, method: str = "midpoint") -> Pose:
        """Final pose of ``trial_id``'s stored encoder log integrated with ``params``.

        The integration is :func:`odolab.core.prediction.final_pose_from_log`; the notebook only
        supplies the stored log.

        Raises:
            StoreError: the trial has no encoder log, or an empty one.
        """
        from odolab.core.prediction import final_pose_from_log

        log = self.encoder_log(trial_id)
        if log is None:
            raise StoreError(f"trial {trial_id} has no encoder log to re-predict from")
        if len(log) == 0:
            raise StoreError(f"trial {trial_id}: its encoder log is empty")
        return final_pose_from_log(log, params, method, source=f"trial {trial_id}")

    # -- analysis -------------------------------------------------------------------------------

    def trials_frame(
        self,
        campaign: str | None = None,
        terrain: str | None = None,
        kind: str | None = None,
        include_excluded: bool = False,
    ) -> pd.DataFrame:
        """One row per trial, flat columns (SI units), in recording order.

        Columns: ``trial_id campaign terrain kind angle distance side direction speed
        predicted_t predicted_x predicted_y predicted_theta predicted_heading robot
        params_version left_wheel_radius right_wheel_radius track_width ticks_per_rev
        encoder_modulus instrument measured_rotation measured_x measured_y sigma_rotation
        sigma_xy raw true_t true_x true_y true_theta true_heading status exclusion_reason notes
        has_encoder_log campaign_date operator``. Missing values are NaN / None. Needs the
        pandas extra (``pip install 'odolab[pandas]'``); the commands never call it.
        """
        from odolab.core.extras import require

        require("pandas", "Notebook.trials_frame")
        import pandas as pd

        status = None if include_excluded else ("awaiting", "measured")
        where, args = self._filters(campaign, terrain, kind, status)
        cols = ", ".join(f"t.{c}" for c in TRIAL_COLUMNS)
        params_cols = ", ".join(f"p.{c}" for c in PARAMS_FIELDS)
        sql = (
            f"SELECT {cols}, {params_cols}, e.trial_id IS NOT NULL AS has_encoder_log, "
            "c.date AS campaign_date, c.operator AS operator "
            "FROM trials AS t "
            "JOIN params_versions AS p ON p.robot = t.robot AND p.version = t.params_version "
            "JOIN campaigns AS c ON c.name = t.campaign "
            f"LEFT JOIN encoder_logs AS e ON e.trial_id = t.trial_id {where} ORDER BY t.rowid"
        )
        try:
            frame = pd.read_sql_query(sql, self._conn, params=args)
        except pd.errors.DatabaseError as err:  # pandas wraps the sqlite3 error
            if isinstance(err.__cause__, sqlite3.Error):
                raise err.__cause__ from err
            raise sqlite3.DatabaseError(str(err)) from err
        order = [*TRIAL_COLUMNS[:16], *PARAMS_FIELDS, *TRIAL_COLUMNS[16:]]
        order += ["has_encoder_log", "campaign_date", "operator"]
        frame = frame[order]
        frame["has_encoder_log"] = frame["has_encoder_log"].astype(bool)
        frame["params_version"] = frame["params_version"].astype("Int64")
        frame["encoder_modulus"] = frame["encoder_modulus"].astype("Int64")
        for c in ("angle", "distance", "side", "speed", "measured_rotation", "measured_x",
                  "measured_y", "sigma_rotation", "sigma_xy", "true_t", "true_x", "true_y",
                  "true_theta", "true_heading"):  # fmt: skip
            frame[c] = frame[c].astype("float64")
        return frame

    # -- import and export (see odolab.store.transfer) ------------------------------------------

    def export_csv(
        self,
        path: str | Path,
        campaign: str | None = None,
        terrain: str | None = None,
        kind: str | None = None,
        status: str | Sequence[str] | None = None,
    ) -> int:
        """Write the matching trials as CSV (see :mod:`odolab.store.csvio`); return the count."""
        from odolab.store.transfer import export_csv

        return export_csv(self, path, self._filters(campaign, terrain, kind, status))

    def import_csv(
        self,
        path: str | Path,
        *,
        create_campaigns: bool = False,
        batch_size: int = 1000,
        progress: Progress | None = None,
    ) -> int:
        """Import trials from a CSV; return how many.

        The whole file is checked first (any error names the line and column and nothing is
        written); then trials are written in transactions of ``batch_size``, ``progress(done,
        total, "trials")`` being called after each commit. Campaigns must exist unless
        ``create_campaigns``.
        """
        from odolab.store.transfer import import_csv

        return import_csv(
            self, path, create_campaigns=create_campaigns, batch_size=batch_size, progress=progress
        )

    def export_json(
        self,
        path: str | Path,
        campaign: str | None = None,
        terrain: str | None = None,
        kind: str | None = None,
        status: str | Sequence[str] | None = None,
    ) -> int:
        """Write everything needed to rebuild the matching trials as JSON; return the count.

        The file holds the parameter versions (with provenance) and campaigns those trials use,
        the trials (every column, time stamps included) and their encoder logs (base64 of the
        stored compressed arrays).
        """
        from odolab.store.transfer import export_json

        return export_json(self, path, self._filters(campaign, terrain, kind, status))

    def import_json(
        self, path: str | Path, *, batch_size: int = 1000, progress: Progress | None = None
    ) -> int:
        """Import what :meth:`export_json` wrote; return the number of trials.

        Parameter versions and campaigns already in the notebook must be identical to the file's
        (else nothing is written); trial ids must be new. Everything is checked before writing.
        """
        from odolab.store.transfer import import_json

        return import_json(self, path, batch_size=batch_size, progress=progress)

    # -- used by odolab.store.transfer ------------------------------------------------------------

    def _lookup_params(self, robot: str, version: int) -> RobotParams | None:
        row = self._one(
            "SELECT * FROM params_versions WHERE robot = ? AND version = ?", (robot, version)
        )
        return None if row is None else self._params_from_row(row)

    def _write_batches(
        self,
        trials: Sequence[Trial],
        versions: Sequence[int | None],
        stamps: Sequence[tuple[str, str] | None] | None,
        batch_size: int,
        progress: Progress | None,
        create_campaigns: bool,
        histories: Sequence[Sequence[dict[str, object]]] | None = None,
        *,
        new_params_method: str = "recorded with a trial",
    ) -> None:
        report = progress or no_progress
        total = len(trials)
        for start in range(0, total, batch_size):
            stop = min(start + batch_size, total)
            with self._write() as conn:
                self._insert_trials(
                    conn,
                    trials[start:stop],
                    versions[start:stop],
                    create_campaigns=create_campaigns,
                    stamps=None if stamps is None else stamps[start:stop],
                    histories=None if histories is None else histories[start:stop],
                    new_params_method=new_params_method,
                )
            report(stop, total, "trials")


# -- every method: a SQLite error (or a stored value that cannot be read) is one sentence ---------

#: What reading a damaged record raises besides sqlite3 errors (json.loads, enum values, int()).
_DECODE_ERRORS = (ValueError, TypeError, KeyError, UnicodeDecodeError, OverflowError)
#: Methods that read files given by the user: a ValueError there is about the file, not a
#: damaged notebook (their own checks name the file and the line).
_FROM_FILES = frozenset({"import_csv", "import_json"})
#: Plumbing that converts errors itself.
_UNGUARDED = frozenset({"close", "_error", "_unreadable", "_write"})


def _unreadable(nb: Notebook, err: Exception, name: str) -> StoreError:
    """A stored value that cannot be read: damage when SQLite's check finds any, else one
    sentence saying which operation met it."""
    from odolab.store.health import NotebookDamagedError, recovery_hint

    words = integrity_words(nb._conn)
    if words != "ok":
        return NotebookDamagedError(
            f"{nb.path}: the notebook is damaged (a stored value cannot be read: "
            f"{type(err).__name__}: {err}; integrity check: {words}) while running {name}; "
            f"{recovery_hint(nb.path)}"
        )
    return StoreError(
        f"{nb.path}: holds a value odolab cannot read ({type(err).__name__}: {err}) while "
        f"running {name}, although SQLite finds the file sound (was it changed outside "
        f"odolab?); {recovery_hint(nb.path)}"
    )


def _guard(name: str, method: Callable[..., object]) -> Callable[..., object]:
    decode = name not in _FROM_FILES

    @functools.wraps(method)
    def guarded(self: Notebook, *args: object, **kwargs: object) -> object:
        try:
            return method(self, *args, **kwargs)
        except sqlite3.Error as err:
            raise self._error(err, f"running {name.lstrip('_')}") from err
        except _DECODE_ERRORS as err:
            tb = err.__traceback__
            if not decode or tb is None or tb.tb_next is None:
                raise  # a call with the wrong arguments, not a stored value
            raise _unreadable(self, err, name.lstrip("_")) from err

    return guarded


for _name, _attr in list(vars(Notebook).items()):
    if inspect.isfunction(_attr) and not _name.startswith("__") and _name not in _UNGUARDED:
        setattr(Notebook, _name, _guard(_name, _attr))
