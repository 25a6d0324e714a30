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
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from odolab.errors import ParamsError, StoreError
from odolab.params import RobotParams, params_from_mapping
from odolab.store.codec import EncodedLog, decode_log
from odolab.store.records import PARAMS_FIELDS, TRIAL_COLUMNS, params_tables
from odolab.trials import EncoderLog
from odolab.writing import write_text_file

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
    params_versions: Sequence[dict[str, Any]],
    campaigns: Sequence[dict[str, Any]],
    trial_rows: Sequence[dict[str, Any]],
    history: Mapping[str, Sequence[dict[str, Any]]] | None = None,
) -> Path:
    """Write rows as read from the database (trial rows joined with ``log_*`` columns)."""
    trials = []
    for r in trial_rows:
        rec: dict[str, Any] = {k: r[k] for k in TRIAL_COLUMNS}
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
    text = json.dumps(doc, indent=1, allow_nan=False)
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


def _need(obj: Any, keys: Sequence[str], where: str) -> dict[str, Any]:
    if not isinstance(obj, dict):
        raise StoreError(f"{where}: expected an object")
    missing = [k for k in keys if k not in obj]
    if missing:
        raise StoreError(f"{where}: missing key {missing[0]!r}")
    return obj


def _check_ranges(doc: NotebookDocument, source: str) -> None:
    """The range checks every other entry path applies: parameters, measured positions, and a
    translation's commanded distance (``odolab trials add`` and CSV import refuse the same)."""
    from odolab.measurement import check_position
    from odolab.params import check_param

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


def read_notebook_json(path: str | Path) -> NotebookDocument:
    """Read and shape-check a notebook JSON file (values are checked on import)."""
    p = Path(path)
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except OSError as err:
        raise StoreError(f"{p}: cannot read ({err.strerror or err})") from err
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise StoreError(f"{p}: not valid JSON ({err})") from err
    except RecursionError as err:
        raise StoreError(
            f"{p}: JSON nested too deeply to read; expected a notebook export (a few levels)"
        ) from err
    _need(doc, ("format", "params_versions", "campaigns", "trials"), str(p))
    if doc["format"] != FORMAT:
        raise StoreError(f"{p}: format is {doc['format']!r}; expected {FORMAT!r}")
    out = NotebookDocument()
    for key, keys, dest in (
        ("params_versions", _PV_KEYS, out.params_versions),
        ("campaigns", _CAMPAIGN_KEYS, out.campaigns),
        ("trials", (*TRIAL_COLUMNS, "encoder_log"), out.trials),
    ):
        items = doc[key]
        if not isinstance(items, list):
            raise StoreError(f"{p}: {key!r} must be a list")
        for i, item in enumerate(items):
            dest.append(_need(item, keys, f"{p}: {key}[{i}]"))
    _check_ranges(out, str(p))
    for i, rec in enumerate(out.trials):
        log = rec["encoder_log"]
        if log is None:
            continue
        where = f"{p}: trials[{i}].encoder_log"
        _need(log, _LOG_KEYS, where)
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
