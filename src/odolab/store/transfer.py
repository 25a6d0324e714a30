"""Import and export of a notebook: trials as CSV (a spreadsheet) and everything as JSON.

The notebook (:class:`odolab.store.Notebook`) only stores; this module turns files into checked
trials and back. Every trial that comes in passes :func:`odolab.core.trials.validate_trial`, the same
check as a robot run or ``odolab trials add``; an error names the file, the line (CSV) or the
``trials[i]`` entry (JSON) and the column or key, and nothing is written.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from odolab.core.errors import InvalidTrialError, StoreError
from odolab.core.params import RobotParams
from odolab.core.progress import Progress
from odolab.core.text import quote_input
from odolab.core.trials import Trial, validate_trial
from odolab.store.csvio import read_trials_csv, write_trials_csv
from odolab.store.jsonio import (
    NotebookDocument,
    params_of_version,
    read_notebook_json,
    write_notebook_json,
)
from odolab.store.records import HISTORY_KEYS, NUMERIC_COLUMNS, trial_from_record
from odolab.store.schema import SQLValue

if TYPE_CHECKING:
    from odolab.store.notebook import Notebook

__all__ = ["export_csv", "export_json", "import_csv", "import_json"]


#: A ``WHERE`` clause on the trials (``t``) and its arguments, as built by the notebook.
Selection = tuple[str, Sequence[SQLValue]]


def export_csv(nb: Notebook, path: str | Path, selection: Selection = ("", ())) -> int:
    """Write the selected trials of ``nb`` as CSV (:mod:`odolab.store.csvio`); return the count."""
    where, args = selection
    rows = nb._trial_rows(where, args)
    pairs = [(nb._trial_from_row(r, with_log=False), int(r["params_version"])) for r in rows]
    write_trials_csv(path, pairs)
    return len(pairs)


def import_csv(
    nb: Notebook,
    path: str | Path,
    *,
    create_campaigns: bool = False,
    batch_size: int = 1000,
    progress: Progress | None = None,
) -> int:
    """Import trials from a CSV into ``nb``; see :meth:`odolab.store.Notebook.import_csv`.

    Raises:
        StoreError: the batch size is below 1, or a row is refused (its line is named).
    """
    if batch_size < 1:
        raise StoreError(f"batch_size must be >= 1, got {batch_size}")
    parsed = read_trials_csv(
        path,
        known_campaigns=None if create_campaigns else nb.campaign_names(),
        known_trial_ids=nb.trial_ids(),
        lookup_params=nb._lookup_params,
    )
    trials = [p.trial for p in parsed]
    versions = [p.params_version for p in parsed]
    nb._write_batches(
        trials,
        versions,
        None,
        batch_size,
        progress,
        create_campaigns,
        new_params_method=f"imported from {Path(path).name}",
    )
    return len(trials)


def export_json(nb: Notebook, path: str | Path, selection: Selection = ("", ())) -> int:
    """Write everything needed to rebuild the selected trials as JSON; return the count."""
    conn = nb._conn
    where, args = selection
    rows = conn.execute(
        "SELECT t.*, e.n AS log_n, e.modulus AS log_modulus, e.codec AS log_codec, "
        "e.t AS log_t, e.left_ticks AS log_left, e.right_ticks AS log_right "
        "FROM trials AS t LEFT JOIN encoder_logs AS e ON e.trial_id = t.trial_id "
        f"{where} ORDER BY t.rowid",
        args,
    ).fetchall()
    robots = {r["robot"] for r in rows}
    versions = [
        dict(r)
        for r in conn.execute("SELECT * FROM params_versions ORDER BY robot, version")
        if r["robot"] in robots
    ]
    used_campaigns = {r["campaign"] for r in rows}
    campaigns = [
        dict(r)
        for r in conn.execute("SELECT * FROM campaigns ORDER BY rowid")
        if r["name"] in used_campaigns or not where
    ]
    history: dict[str, list[dict[str, object]]] = {}
    for h in conn.execute("SELECT * FROM measurement_history ORDER BY id"):
        entry = {k: h[k] for k in HISTORY_KEYS}
        entry["raw"] = json.loads(h["raw"])
        history.setdefault(h["trial_id"], []).append(entry)
    write_notebook_json(path, versions, campaigns, [dict(r) for r in rows], history)
    return len(rows)


@dataclass
class _Incoming:
    """Checked trials of a JSON file, ready to be written."""

    trials: list[Trial] = field(default_factory=list)
    versions: list[int | None] = field(default_factory=list)
    stamps: list[tuple[str, str] | None] = field(default_factory=list)
    histories: list[list[dict[str, object]]] = field(default_factory=list)


def _new_params_versions(
    nb: Notebook, doc: NotebookDocument, source: str
) -> tuple[list[dict[str, Any]], dict[tuple[str, int], int]]:
    """The file's parameter versions the notebook lacks, and the versions the file's trials are
    to be recorded with where the notebook numbers the same parameters otherwise.

    A version is the same when its numbers are (wheel radii, track width, ticks, modulus, model,
    noise): its method and notes are words about it, and two notebooks that each recorded preset
    jaguar-lite as version 1 (one "nominal preset", one "recorded with a trial") hold the same
    version. The file's version goes to the notebook's version with the same numbers when there
    is one; else it is added under its own number; a number the notebook already uses for other
    numbers is refused, naming what differs."""
    new: list[dict[str, object]] = []
    remap: dict[tuple[str, int], int] = {}
    for pv in doc.params_versions:
        theirs = params_of_version(pv, f"{source}: parameter version {pv['version']}")
        same = nb.find_params_version(theirs)
        if same is not None:
            remap[(pv["robot"], int(pv["version"]))] = same
            continue
        row = nb._one(
            "SELECT * FROM params_versions WHERE robot = ? AND version = ?",
            (pv["robot"], pv["version"]),
        )
        if row is None:
            new.append(pv)
            continue
        ours = nb._params_from_row(row).to_dict()
        differ = [
            f"{k} {ours.get(k)!r} here, {v!r} in the file"
            for k, v in theirs.to_dict().items()
            if ours.get(k) != v and k != "name"
        ]
        raise StoreError(
            f"{source}: parameter version {pv['version']} of {quote_input(pv['robot'])} differs "
            f"from the notebook's version {pv['version']} ({'; '.join(differ) or 'its tables'}); "
            "nothing was imported (import into a notebook without that robot, or rename the "
            "robot in the file)"
        )
    return new, remap


def _new_campaigns(nb: Notebook, doc: NotebookDocument, source: str) -> list[dict[str, Any]]:
    """The file's campaigns the notebook lacks; refuse ones that differ."""
    new: list[dict[str, object]] = []
    for i, c in enumerate(doc.campaigns):
        row = nb._one("SELECT * FROM campaigns WHERE name = ?", (c["name"],))
        if row is None:
            try:
                nb._check_campaign(c["name"], c["kind"], c["terrain"])
            except StoreError as err:
                raise StoreError(f"{source}: campaigns[{i}]: {err}") from err
            new.append(c)
        elif (row["kind"], row["terrain"]) != (c["kind"], c["terrain"]):
            raise StoreError(
                f"{source}: campaign {c['name']!r} differs from the one in the notebook "
                f"(kind/terrain {row['kind']}/{row['terrain']} vs {c['kind']}/{c['terrain']})"
            )
    return new


def _params_for(
    nb: Notebook, doc: NotebookDocument, key: tuple[str, int], where: str
) -> RobotParams:
    for pv in doc.params_versions:
        if (pv["robot"], pv["version"]) == key:
            return params_of_version(pv, where)
    params = nb._lookup_params(*key)
    if params is None:
        raise StoreError(
            f"{where}, key 'params_version': no parameter version {key[1]} of robot "
            f"{quote_input(key[0])} in the file or the notebook"
        )
    return params


def _check_types(rec: Mapping[str, object], where: str) -> None:
    for k in NUMERIC_COLUMNS:
        v = rec[k]
        if v is not None and (isinstance(v, bool) or not isinstance(v, int | float)):
            raise StoreError(f"{where}: key {k!r} is {v!r}; expected a number or null")


def _trial_of(
    nb: Notebook, doc: NotebookDocument, rec: dict[str, Any], where: str
) -> tuple[Trial, int]:
    """The checked trial of one JSON record and its parameter version."""
    _check_types(rec, where)
    key = (rec["robot"], rec["params_version"])
    params = _params_for(nb, doc, key, where)
    try:
        trial = trial_from_record(rec, params, doc.logs.get(rec["trial_id"]))
        validate_trial(trial)  # its direction word against its numbers too
    except (KeyError, ValueError, TypeError) as err:
        raise StoreError(f"{where}: malformed trial record ({err})") from err
    except InvalidTrialError as err:
        key_text = f", key {err.field!r}" if err.field else ""
        raise InvalidTrialError(f"{where}{key_text}: {err}", err.field) from err
    for j, h in enumerate(rec.get("measurement_history") or []):
        if not isinstance(h, dict) or any(k not in h for k in HISTORY_KEYS):
            raise StoreError(f"{where}.measurement_history[{j}]: malformed entry")
    return trial, int(key[1])


def _incoming_trials(
    nb: Notebook, doc: NotebookDocument, source: str, campaign_names: set[str]
) -> _Incoming:
    out = _Incoming()
    known_ids = nb.trial_ids()
    first_in_file: dict[str, int] = {}
    for i, rec in enumerate(doc.trials):
        where = f"{source}: trials[{i}]"
        tid = rec["trial_id"]
        if tid in first_in_file:
            raise StoreError(
                f"{where}, key 'trial_id': {quote_input(tid)} is a duplicate of "
                f"trials[{first_in_file[tid]}]"
            )
        if tid in known_ids:
            raise StoreError(
                f"{where}, key 'trial_id': {quote_input(tid)} is already in the notebook"
            )
        first_in_file[tid] = i
        if rec["campaign"] not in campaign_names:
            raise StoreError(
                f"{where}, key 'campaign': unknown campaign {quote_input(rec['campaign'])}"
            )
        trial, version = _trial_of(nb, doc, rec, where)
        out.trials.append(trial)
        out.versions.append(version)
        out.stamps.append((rec["created"], rec["updated"]) if rec.get("created") else None)
        out.histories.append(list(rec.get("measurement_history") or []))
    return out


def import_json(
    nb: Notebook, path: str | Path, *, batch_size: int = 1000, progress: Progress | None = None
) -> int:
    """Import what :func:`export_json` wrote; see :meth:`odolab.store.Notebook.import_json`."""
    doc = read_notebook_json(path)
    source = str(path)
    new_versions, remap = _new_params_versions(nb, doc, source)
    new_campaigns = _new_campaigns(nb, doc, source)
    names = nb.campaign_names() | {c["name"] for c in new_campaigns}
    incoming = _incoming_trials(nb, doc, source, names)
    incoming.versions = [
        v if v is None else remap.get((t.params.name, v), v)
        for t, v in zip(incoming.trials, incoming.versions, strict=True)
    ]
    with nb._write() as conn:
        for pv in new_versions:
            nb._insert_params_version(
                conn,
                params_of_version(pv, f"{source}: parameter version {pv['version']}"),
                version=int(pv["version"]),
                method=pv["method"],
                source_trials=pv["source_trials"],
                created=pv["created"],
                notes=pv["notes"],
            )
        for c in new_campaigns:
            conn.execute(
                "INSERT INTO campaigns (name, kind, terrain, date, operator, notes) "
                "VALUES (?, ?, ?, ?, ?, ?)",
                (c["name"], c["kind"], c["terrain"], c["date"], c["operator"], c["notes"]),
            )
    nb._write_batches(
        incoming.trials,
        incoming.versions,
        incoming.stamps,
        batch_size,
        progress,
        False,
        incoming.histories,
    )
    return len(incoming.trials)
