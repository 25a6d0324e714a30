"""The notebook as one JSON document (everything, encoder logs included).

Layout::

    {"format": "odolab-notebook", "schema": 3,
     "params_versions": [{"robot", "version", "left_wheel_radius", ..., "method",
                          "source_trials": [...], "created", "notes",
                          "model": null | {"kind", <the model's keys>},
                          "noise": null | {"k_left", "k_right", "k_scrub"}}, ...],
     "campaigns": [{"name", "kind", "terrain", "date", "operator", "notes"}, ...],
     "trials": [{<every trials column>, "raw": {...}, "created", "updated",
                 "encoder_log": null | {"n", "modulus", "codec", "t", "left_ticks",
                                        "right_ticks"},
                 "measurement_history": [{"replaced", "instrument", "measured_rotation", ...,
                                          "raw": {...}}, ...]}, ...]}

``model`` and ``noise`` are the parameter set's ``[model]`` and ``[noise]`` tables (null: the
plain differential drive, no noise); files written before schema 3 have neither and mean that.
Numbers are written with Python's shortest round-tripping repr; encoder-log arrays are the stored
compressed BLOBs in base64 (see :mod:`odolab.store.codec`).
"""

from __future__ import annotations

import base64
import binascii
import datetime as _dt
import json
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from odolab.core.errors import ParamsError, StoreError
from odolab.core.params import RobotParams, params_from_mapping
from odolab.core.text import quote_input
from odolab.core.trials import (
    TRIAL_FIELDS,
    EncoderLog,
    FieldType,
    MotionKind,
    TrialStatus,
    check_no_nul,
)
from odolab.core.writing import strict_json, write_text_file
from odolab.store.codec import EncodedLog, decode_log
from odolab.store.records import HISTORY_KEYS, PARAMS_FIELDS, TRIAL_COLUMNS, params_tables

__all__ = [
    "FORMAT",
    "NotebookDocument",
    "params_of_version",
    "read_notebook_json",
    "write_notebook_json",
]

FORMAT = "odolab-notebook"
_PV_KEYS = ("robot", "version", *PARAMS_FIELDS, "method", "source_trials", "created", "notes")
_CAMPAIGN_KEYS = ("name", "kind", "terrain", "date", "operator", "notes")
_LOG_KEYS = ("n", "modulus", "codec", "t", "left_ticks", "right_ticks")


@dataclass
class NotebookDocument:
    """What a notebook JSON file holds, checked for shape."""

    params_versions: list[dict[str, Any]] = field(default_factory=list)
    campaigns: list[dict[str, Any]] = field(default_factory=list)
    trials: list[dict[str, Any]] = field(default_factory=list)
    logs: dict[str, EncoderLog] = field(default_factory=dict)


def write_notebook_json(
    path: str | Path,
    params_versions: Sequence[dict[str, object]],
    campaigns: Sequence[dict[str, object]],
    trial_rows: Sequence[dict[str, Any]],
    history: Mapping[str, Sequence[dict[str, object]]] | None = None,
) -> Path:
    """Write rows as read from the database (trial rows joined with ``log_*`` columns)."""
    trials = []
    for r in trial_rows:
        rec: dict[str, object] = {k: r[k] for k in TRIAL_COLUMNS}
        rec["raw"] = json.loads(r["raw"]) if isinstance(r["raw"], str) else r["raw"]
        rec["created"], rec["updated"] = r["created"], r["updated"]
        log = None
        if r.get("log_codec") is not None:
            log = {
                "n": r["log_n"],
                "modulus": r["log_modulus"],
                "codec": r["log_codec"],
                "t": base64.b64encode(r["log_t"]).decode("ascii"),
                "left_ticks": base64.b64encode(r["log_left"]).decode("ascii"),
                "right_ticks": base64.b64encode(r["log_right"]).decode("ascii"),
            }
        rec["encoder_log"] = log
        rec["measurement_history"] = list((history or {}).get(r["trial_id"], []))
        trials.append(rec)
    versions = []
    for pv in params_versions:
        d = {k: pv[k] for k in _PV_KEYS}
        if isinstance(d["source_trials"], str):
            d["source_trials"] = json.loads(d["source_trials"])
        model, noise = params_tables(pv, f"parameter version {pv['version']} of {pv['robot']!r}")
        d["model"] = None if model == {"kind": "diff"} else model
        d["noise"] = noise
        versions.append(d)
    doc = {
        "format": FORMAT,
        "schema": 3,
        "params_versions": versions,
        "campaigns": [{k: c[k] for k in _CAMPAIGN_KEYS} for c in campaigns],
        "trials": trials,
    }
    text = strict_json(doc, indent=1)
    return write_text_file(path, text, what="notebook JSON", error=StoreError)


def params_of_version(pv: Mapping[str, Any], source: str) -> RobotParams:
    """The parameter set of one ``params_versions`` entry of a notebook JSON file (its optional
    ``model`` and ``noise`` tables included); ``source`` names it in any error."""
    model, noise = pv.get("model"), pv.get("noise")
    return params_from_mapping(
        {"name": pv["robot"], **{k: pv[k] for k in PARAMS_FIELDS}},
        source=source,
        model=None if model is None else model,
        noise=None if noise is None else noise,
    )


def _need(obj: object, keys: Sequence[str], where: str) -> dict[str, object]:
    if not isinstance(obj, dict):
        raise StoreError(f"{where}: expected an object")
    missing = [k for k in keys if k not in obj]
    if missing:
        raise StoreError(f"{where}: missing key {missing[0]!r}")
    return obj


#: The largest integer SQLite stores (a parameter version, an encoder modulus, a count).
_MAX_INT = 2**63 - 1


def _bad(where: str, key: str, value: object, expected: str) -> StoreError:
    return StoreError(f"{where}, key {key!r}: {quote_input(value)}; expected {expected}")


def _text(item: dict[str, object], key: str, where: str, *, null: bool = False) -> None:
    v = item[key]
    if not (isinstance(v, str) or (null and v is None)):
        raise _bad(where, key, v, "text" + (" or null" if null else ""))
    check_no_nul(v, f"key {key!r}", where, StoreError)  # (as the CSV import refuses it)


def _integer(item: dict[str, object], key: str, where: str, low: int, high: int = _MAX_INT) -> None:
    """An integer from ``low`` to ``high`` (an integral float such as 3.0 is taken as 3)."""
    v = item[key]
    if isinstance(v, float) and v.is_integer() and low <= v <= high:
        v = item[key] = int(v)
    if isinstance(v, bool) or not isinstance(v, int) or not low <= v <= high:
        raise _bad(where, key, v, f"a whole number from {low} to {high}")


def _number(item: dict[str, object], key: str, where: str, *, null: bool = True) -> None:
    v = item[key]
    if v is None and null:
        return
    if isinstance(v, bool) or not isinstance(v, int | float) or not _finite(v):
        raise _bad(where, key, v, "a finite number" + (" or null" if null else ""))


def _finite(v: float) -> bool:
    try:
        return math.isfinite(v)
    except OverflowError:  # an integer past a float's range (1e400 written out)
        return False


def _stamp(item: dict[str, object], key: str, where: str) -> None:
    v = item[key]
    try:
        if not isinstance(v, str):
            raise TypeError(key)
        _dt.datetime.fromisoformat(v)
    except (TypeError, ValueError):
        raise _bad(where, key, v, "a date and time (ISO 8601, as exported)") from None


def _readings(item: dict[str, object], key: str, where: str) -> None:
    v = item[key]
    if v is None:
        item[key] = {}
        return
    if not isinstance(v, dict):
        raise _bad(where, key, v, "an object of readings (name: number)")
    for name, reading in v.items():
        if isinstance(reading, bool) or not isinstance(reading, int | float):
            raise StoreError(
                f"{where}, key {key!r}: reading {quote_input(name)} is {quote_input(reading)}; "
                "expected a number"
            )


def _check_trial_keys(rec: dict[str, object], where: str) -> None:
    """Every key of one ``trials[i]`` entry has its type (values are range-checked on import by
    :func:`odolab.core.trials.validate_trial`). ``created`` and ``updated`` may be left out (the
    import's time), or one given for both."""
    _number(rec, "true_x", where)  # first: it decides whether the true pose is there
    for f in TRIAL_FIELDS:
        if f.name == "params_version":
            _integer(rec, f.name, where, 1, int(f.high or _MAX_INT))
        elif f.type is FieldType.TEXT:
            if rec[f.name] is None and f.name == "notes":
                rec[f.name] = ""
            _text(rec, f.name, where, null=not f.required)
        elif f.type is FieldType.JSON:
            _readings(rec, f.name, where)
        else:  # the predicted pose is stored whole (NOT NULL), the true pose whole or not at all
            true = f.name.startswith("true_") and rec.get("true_x") is not None
            whole = f.name.startswith("predicted_") or true
            if true and rec[f.name] is None:
                raise _bad(where, f.name, None, "a finite number (true_x is given: the whole pose)")
            _number(rec, f.name, where, null=not (f.required or whole))
    for key, enum in (("kind", MotionKind), ("status", TrialStatus)):
        if rec[key] not in {e.value for e in enum}:
            raise _bad(where, key, rec[key], "one of " + ", ".join(e.value for e in enum))
    stamps = [k for k in ("created", "updated") if rec.get(k) is not None]
    for k in stamps:
        _stamp(rec, k, where)
    if len(stamps) == 1:  # one given: it stands for both
        rec["created"] = rec["updated"] = rec[stamps[0]]
    history = rec.get("measurement_history")
    if history is None:
        history = rec["measurement_history"] = []
    elif not isinstance(history, list):
        raise _bad(where, "measurement_history", history, "a list (or null)")
    for j, entry in enumerate(history):
        at = f"{where}.measurement_history[{j}]"
        h = _need(entry, HISTORY_KEYS, at)
        _stamp(h, "replaced", at)
        _text(h, "instrument", at)
        for k in HISTORY_KEYS:
            if k not in ("replaced", "instrument", "raw"):
                _number(h, k, at)
        _readings(h, "raw", at)


def _check_version_keys(pv: dict[str, object], where: str) -> None:
    _text(pv, "robot", where)
    _integer(pv, "version", where, 1)
    _text(pv, "method", where)
    _stamp(pv, "created", where)
    if pv["notes"] is None:
        pv["notes"] = ""
    _text(pv, "notes", where)
    src = pv["source_trials"]
    if not isinstance(src, list) or not all(isinstance(t, str) for t in src):
        raise _bad(where, "source_trials", src, "a list of trial ids")
    for key in ("model", "noise"):
        if not isinstance(pv.get(key), dict | None):
            raise _bad(where, key, pv[key], "an object or null")


def _check_campaign_keys(c: dict[str, object], where: str) -> None:
    for key in ("name", "kind", "terrain"):
        _text(c, key, where)
    for key in ("operator", "notes"):
        if c[key] is None:
            c[key] = ""
        _text(c, key, where)
    if c["date"] is not None:
        try:
            if not isinstance(c["date"], str):
                raise TypeError("date")
            _dt.date.fromisoformat(c["date"])
        except (TypeError, ValueError):
            raise _bad(where, "date", c["date"], "a date YYYY-MM-DD or null") from None


def _check_ranges(doc: NotebookDocument, source: str) -> None:
    """The range checks every other entry path applies: parameters, measured positions, and a
    translation's commanded distance (``odolab trials add`` and CSV import refuse the same)."""
    from odolab.core.measurement import check_position
    from odolab.core.params import check_param

    for i, pv in enumerate(doc.params_versions):
        for key in PARAMS_FIELDS:
            if pv[key] is not None or key != "encoder_modulus":
                try:
                    check_param(key, pv[key])
                except ParamsError as err:
                    raise StoreError(f"{source}: params_versions[{i}]: {err}") from err
        try:
            params_of_version(pv, f"{source}: params_versions[{i}]")
        except ParamsError as err:
            raise StoreError(str(err)) from err
    for i, rec in enumerate(doc.trials):
        if rec["kind"] == "translation" and rec["distance"] is None:
            raise StoreError(
                f"{source}: trials[{i}]: key 'distance' is null; a translation needs its "
                "commanded distance (m)"
            )
        for key in ("measured_x", "measured_y"):
            if rec[key] is not None:
                try:
                    check_position(rec[key], key)
                except StoreError as err:
                    raise StoreError(f"{source}: trials[{i}]: {err}") from err


_CHECKS: dict[str, Callable[[dict[str, object], str], None]] = {
    "params_versions": _check_version_keys,
    "campaigns": _check_campaign_keys,
    "trials": _check_trial_keys,
}


# long: a shape check of each entry of the file, one sentence each, in the file's own order
def read_notebook_json(path: str | Path) -> NotebookDocument:
    """Read and shape-check a notebook JSON file (values are checked on import).

    Raises:
        StoreError: the file is unreadable, not JSON, of another format or schema, or an entry has
            the wrong shape (the entry and key are named).
    """
    p = Path(path)
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except OSError as err:
        raise StoreError(f"{p}: cannot read ({err.strerror or err})") from err
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise StoreError(f"{p}: not valid JSON ({err})") from err
    except ValueError as err:  # Python's limit on an integer's digits (4300)
        raise StoreError(
            f"{p}: a number in it has more digits than can be read ({err}); expected a "
            "notebook export (its numbers have at most 17 significant digits)"
        ) from err
    except RecursionError as err:
        raise StoreError(
            f"{p}: JSON nested too deeply to read; expected a notebook export (a few levels)"
        ) from err
    _need(doc, ("format",), str(p))
    if doc["format"] != FORMAT:
        raise StoreError(f"{p}: format is {doc['format']!r}; expected {FORMAT!r}")
    if doc.get("schema") is None:  # every odolab has written it: a file without it is not ours
        raise StoreError(
            f"{p}: "
            + ("schema is null" if "schema" in doc else "no key 'schema'")
            + "; expected the schema number (1 to 3) that every odolab notebook export carries"
        )
    schema = doc["schema"]
    if isinstance(schema, bool) or not isinstance(schema, int) or not 1 <= schema <= 3:
        # it was refused as "missing key 'params_versions'" when other keys were missing too
        raise StoreError(
            f"{p}: schema is {schema!r}; expected 1 to 3 (a file written by a newer odolab "
            "needs that odolab to import it)"
        )
    _need(doc, ("params_versions", "campaigns", "trials"), str(p))
    out = NotebookDocument()
    for key, keys, dest in (
        ("params_versions", _PV_KEYS, out.params_versions),
        ("campaigns", _CAMPAIGN_KEYS, out.campaigns),
        ("trials", (*TRIAL_COLUMNS, "encoder_log"), out.trials),
    ):
        items = doc[key]
        if not isinstance(items, list):
            raise StoreError(f"{p}: {key!r} must be a list")
        check = _CHECKS[key]
        for i, item in enumerate(items):
            where = f"{p}: {key}[{i}]"
            check(_need(item, keys, where), where)
            dest.append(item)
    _check_ranges(out, str(p))
    for i, rec in enumerate(out.trials):
        log = rec["encoder_log"]
        if log is None:
            continue
        where = f"{p}: trials[{i}].encoder_log"
        _need(log, _LOG_KEYS, where)
        _integer(log, "n", where, 0)
        if log["modulus"] is not None:
            _integer(log, "modulus", where, 2)
        for key in ("codec", "t", "left_ticks", "right_ticks"):
            _text(log, key, where)
        try:
            enc = EncodedLog(
                int(log["n"]),
                None if log["modulus"] is None else int(log["modulus"]),
                str(log["codec"]),
                base64.b64decode(log["t"], validate=True),
                base64.b64decode(log["left_ticks"], validate=True),
                base64.b64decode(log["right_ticks"], validate=True),
            )
        except (binascii.Error, TypeError, ValueError) as err:
            raise StoreError(f"{where}: malformed ({err})") from err
        try:
            out.logs[str(rec["trial_id"])] = decode_log(enc)
        except StoreError as err:
            raise StoreError(f"{where}: {err}") from err
    return out
