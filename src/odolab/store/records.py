"""Trials as flat records (one key per ``trials`` column) and back.

The fields, their units and plausible ranges are defined once, in :data:`odolab.core.trials.TRIAL_FIELDS`;
:func:`validate_trial` (re-exported here) lives beside the type.

A *record* is a ``dict`` whose keys are :data:`TRIAL_COLUMNS` (the ``trials`` table without its
time stamps); ``raw`` is a JSON text. The parameter set is named by ``robot`` and
``params_version``; the values themselves live in ``params_versions``.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from odolab.core.errors import StoreError
from odolab.core.params import RobotParams, params_from_mapping
from odolab.core.trajectory import Pose
from odolab.core.trials import (
    TRIAL_FIELDS,
    Command,
    EncoderLog,
    Measurement,
    MotionKind,
    Trial,
    TrialStatus,
    signed_command,
    validate_trial,
)
from odolab.core.writing import strict_json

if TYPE_CHECKING:
    from odolab.store.schema import SQLValue

__all__ = [
    "CAMPAIGN_KINDS",
    "HISTORY_KEYS",
    "MEASUREMENT_COLUMNS",
    "NUMERIC_COLUMNS",
    "PARAMS_EXTRA_COLUMNS",
    "PARAMS_FIELDS",
    "TRIAL_COLUMNS",
    "campaign_kind_for",
    "params_columns",
    "params_from_columns",
    "params_tables",
    "record_from_trial",
    "trial_from_record",
    "validate_trial",
]

#: The columns of ``trials`` that describe a trial (time stamps left out), in table order:
#: the names of :data:`odolab.core.trials.TRIAL_FIELDS`.
TRIAL_COLUMNS: tuple[str, ...] = tuple(f.name for f in TRIAL_FIELDS)
#: The columns that hold a measurement (kept in ``measurement_history`` when one is replaced).
MEASUREMENT_COLUMNS: tuple[str, ...] = (
    "instrument",
    "measured_rotation",
    "measured_x",
    "measured_y",
    "sigma_rotation",
    "sigma_xy",
    "raw",
)
#: A replaced measurement as kept in ``measurement_history`` (and in the JSON export).
HISTORY_KEYS: tuple[str, ...] = ("replaced", *MEASUREMENT_COLUMNS)
#: The numeric columns (the rest is text).
NUMERIC_COLUMNS: tuple[str, ...] = tuple(f.name for f in TRIAL_FIELDS if f.numeric)

#: The numeric fields of a parameter set, as stored in ``params_versions``.
PARAMS_FIELDS: tuple[str, ...] = (
    "left_wheel_radius",
    "right_wheel_radius",
    "track_width",
    "ticks_per_rev",
    "encoder_modulus",
)

#: The kinematic model and the random error of a parameter set, as stored in ``params_versions``
#: (schema v3): the model's kind, its ``[model]`` keys as a JSON object, and the ``[noise]`` terms
#: (NULL when the set has no noise).
PARAMS_EXTRA_COLUMNS: tuple[str, ...] = (
    "model_kind",
    "model_params",
    "noise_k_left",
    "noise_k_right",
    "noise_k_scrub",
)


def params_columns(params: RobotParams) -> dict[str, SQLValue]:
    """The :data:`PARAMS_EXTRA_COLUMNS` of ``params``.

    ``model_params`` is canonical (the model's keys in file order, shortest round-trip floats,
    ``-0.0`` written as ``0.0``), so equal models give equal text and a lookup by value works."""
    coefficients = {k: float(v) + 0.0 for k, v in params.model.to_dict().items()}
    noise = params.noise
    return {
        "model_kind": params.model.kind,
        "model_params": strict_json(coefficients, indent=None),
        "noise_k_left": None if noise is None else noise.k_left,
        "noise_k_right": None if noise is None else noise.k_right,
        "noise_k_scrub": None if noise is None else noise.k_scrub,
    }


def params_tables(
    row: Mapping[str, Any], source: str
) -> tuple[dict[str, object], dict[str, object] | None]:
    """The ``[model]`` and ``[noise]`` tables (noise None when absent) stored in ``row``'s
    :data:`PARAMS_EXTRA_COLUMNS`; a row without them (schema v2) is the plain differential drive.

    Raises:
        StoreError: the stored model or noise table is not a JSON object.
    """
    kind = row.get("model_kind") or "diff"
    text = row.get("model_params") or "{}"
    try:
        keys = json.loads(text)
    except (TypeError, ValueError) as err:
        raise StoreError(f"{source}: model_params is not a JSON object ({err})") from err
    if not isinstance(keys, dict):
        raise StoreError(f"{source}: model_params is not a JSON object, got {text!r}")
    noise = None
    if row.get("noise_k_left") is not None or row.get("noise_k_right") is not None:
        noise = {"k_left": row.get("noise_k_left"), "k_right": row.get("noise_k_right")}
        if row.get("noise_k_scrub") is not None:
            noise["k_scrub"] = row["noise_k_scrub"]
    return {"kind": kind, **keys}, noise


def params_from_columns(row: Mapping[str, object], source: str) -> RobotParams:
    """The parameter set stored in ``row``: ``robot``, :data:`PARAMS_FIELDS` and (schema v3)
    :data:`PARAMS_EXTRA_COLUMNS`; ``source`` names it in any error."""
    model, noise = params_tables(row, source)
    fields = {k: row[k] for k in PARAMS_FIELDS}
    return params_from_mapping(
        {"name": row["robot"], **fields}, source=source, model=model, noise=noise
    )


#: What a campaign may be: the kinds of the lab's experiments.
CAMPAIGN_KINDS: tuple[str, ...] = ("rotation", "translation", "square", "free")


def campaign_kind_for(kind: MotionKind) -> str:
    """The campaign kind a trial of ``kind`` implies (pivots and free runs: ``free``)."""
    return kind.value if kind.value in CAMPAIGN_KINDS else "free"


def record_from_trial(trial: Trial, params_version: int | None) -> dict[str, object]:
    """The ``trials`` row of ``trial`` (validate it first with :func:`validate_trial`)."""
    c, p, m, tr = trial.command, trial.predicted, trial.measured, trial.true
    return {
        "trial_id": trial.trial_id,
        "campaign": trial.campaign,
        "terrain": trial.terrain,
        **c.to_dict(),
        "predicted_t": float(p.t),
        "predicted_x": float(p.x),
        "predicted_y": float(p.y),
        "predicted_theta": float(p.theta),
        "predicted_heading": float(p.heading),
        "robot": trial.params.name,
        "params_version": params_version,
        "instrument": m.instrument if m else None,
        "measured_rotation": m.rotation if m else None,
        "measured_x": m.x if m else None,
        "measured_y": m.y if m else None,
        "sigma_rotation": m.sigma_rotation if m else None,
        "sigma_xy": m.sigma_xy if m else None,
        "raw": strict_json(
            {k: float(v) for k, v in m.raw.items()} if m else {}, indent=None, sort_keys=True
        ),
        "true_t": float(tr.t) if tr else None,
        "true_x": float(tr.x) if tr else None,
        "true_y": float(tr.y) if tr else None,
        "true_theta": float(tr.theta) if tr else None,
        "true_heading": float(tr.heading) if tr else None,
        "status": TrialStatus(trial.status).value,
        "exclusion_reason": trial.exclusion_reason,
        "notes": trial.notes,
    }


def _opt(v: float | str | None) -> float | None:
    return None if v is None else float(v)


def _pose(rec: Mapping[str, float], prefix: str) -> Pose:
    """The pose stored in the ``{prefix}_t``, ``_x``, ``_y``, ``_theta``, ``_heading`` columns."""
    return Pose(*(float(rec[f"{prefix}_{k}"]) for k in ("t", "x", "y", "theta", "heading")))


def trial_from_record(
    rec: dict[str, Any], params: RobotParams, log: EncoderLog | None = None
) -> Trial:
    """The :class:`Trial` of a ``trials`` row (``raw`` as JSON text or a mapping)."""
    raw = rec.get("raw") or {}
    if isinstance(raw, str):
        raw = json.loads(raw)
    measured = None
    if rec.get("instrument") is not None:
        measured = Measurement(
            instrument=rec["instrument"],
            rotation=_opt(rec.get("measured_rotation")),
            x=_opt(rec.get("measured_x")),
            y=_opt(rec.get("measured_y")),
            sigma_rotation=_opt(rec.get("sigma_rotation")),
            sigma_xy=_opt(rec.get("sigma_xy")),
            raw={str(k): float(v) for k, v in raw.items()},
        )
    true = _pose(rec, "true") if rec.get("true_x") is not None else None
    return Trial(
        trial_id=rec["trial_id"],
        campaign=rec["campaign"],
        terrain=rec["terrain"],
        command=signed_command(
            Command(
                kind=MotionKind(rec["kind"]),
                angle=_opt(rec.get("angle")),
                distance=_opt(rec.get("distance")),
                side=_opt(rec.get("side")),
                direction=rec.get("direction"),
                speed=_opt(rec.get("speed")),
            )
        ),
        predicted=_pose(rec, "predicted"),
        params=params,
        measured=measured,
        true=true,
        encoder_log=log,
        status=TrialStatus(rec["status"]),
        exclusion_reason=rec.get("exclusion_reason"),
        notes=rec.get("notes") or "",
    )
