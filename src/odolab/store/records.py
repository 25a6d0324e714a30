"""Trials as flat records (one key per ``trials`` column) and back, with validation.

A *record* is a ``dict`` whose keys are :data:`TRIAL_COLUMNS` (the ``trials`` table without its
time stamps); ``raw`` is a JSON text. The parameter set is named by ``robot`` and
``params_version``; the values themselves live in ``params_versions``.
"""

from __future__ import annotations

import json
import math
from typing import Any

from odolab.errors import StoreError
from odolab.params import RobotParams
from odolab.trajectory import Pose
from odolab.trials import Command, EncoderLog, Measurement, MotionKind, Trial, TrialStatus

__all__ = [
    "CAMPAIGN_KINDS",
    "PARAMS_FIELDS",
    "TRIAL_COLUMNS",
    "campaign_kind_for",
    "record_from_trial",
    "trial_from_record",
    "validate_trial",
]

#: The columns of ``trials`` that describe a trial (time stamps left out), in table order.
TRIAL_COLUMNS: tuple[str, ...] = (
    "trial_id",
    "campaign",
    "terrain",
    "kind",
    "angle",
    "distance",
    "side",
    "direction",
    "speed",
    "predicted_t",
    "predicted_x",
    "predicted_y",
    "predicted_theta",
    "predicted_heading",
    "robot",
    "params_version",
    "instrument",
    "measured_rotation",
    "measured_x",
    "measured_y",
    "sigma_rotation",
    "sigma_xy",
    "raw",
    "true_t",
    "true_x",
    "true_y",
    "true_theta",
    "true_heading",
    "status",
    "exclusion_reason",
    "notes",
)

#: The numeric fields of a parameter set, as stored in ``params_versions``.
PARAMS_FIELDS: tuple[str, ...] = (
    "left_wheel_radius",
    "right_wheel_radius",
    "track_width",
    "ticks_per_rev",
    "encoder_modulus",
)

#: What a campaign may be: the kinds of the lab's experiments.
CAMPAIGN_KINDS: tuple[str, ...] = ("rotation", "translation", "square", "free")


def campaign_kind_for(kind: MotionKind) -> str:
    """The campaign kind a trial of ``kind`` implies (pivots and free runs: ``free``)."""
    return kind.value if kind.value in CAMPAIGN_KINDS else "free"


def _finite(value: float | None, what: str, *, required: bool = False) -> None:
    if value is None:
        if required:
            raise StoreError(f"{what} is missing")
        return
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise StoreError(f"{what} must be a finite number, got {value!r}")


def validate_trial(trial: Trial) -> None:
    """Raise :class:`StoreError` (naming the trial and the field) if ``trial`` cannot be stored."""
    tid = trial.trial_id
    if not isinstance(tid, str) or not tid.strip() or tid != tid.strip():
        raise StoreError(f"trial id {tid!r} must be non-empty text without surrounding spaces")
    where = f"trial {tid}"
    for name in ("campaign", "terrain"):
        value = getattr(trial, name)
        if not isinstance(value, str) or not value.strip():
            raise StoreError(f"{where}: {name} must be non-empty text, got {value!r}")
    if not isinstance(trial.command.kind, MotionKind):
        raise StoreError(f"{where}: command kind {trial.command.kind!r} is not a MotionKind")
    c = trial.command
    for name in ("angle", "distance", "side", "speed"):
        _finite(getattr(c, name), f"{where}: command {name}")
    for label, pose in (("predicted", trial.predicted), ("true", trial.true)):
        if pose is None:
            if label == "predicted":
                raise StoreError(f"{where}: predicted pose is missing")
            continue
        for name in Pose._fields:
            _finite(getattr(pose, name), f"{where}: {label} {name}", required=True)
    m = trial.measured
    if m is not None:
        if not isinstance(m.instrument, str) or not m.instrument.strip():
            raise StoreError(f"{where}: measurement instrument must be non-empty text")
        for name in ("rotation", "x", "y", "sigma_rotation", "sigma_xy"):
            _finite(getattr(m, name), f"{where}: measured {name}")
        for name in ("sigma_rotation", "sigma_xy"):
            v = getattr(m, name)
            if v is not None and v < 0:
                raise StoreError(f"{where}: {name} must be >= 0, got {v!r}")
        if m.rotation is None and m.x is None and m.y is None:
            raise StoreError(f"{where}: a measurement needs a rotation or x and y")
        for key, v in m.raw.items():
            _finite(v, f"{where}: raw reading {key!r}", required=True)
    status = TrialStatus(trial.status)
    if status is TrialStatus.MEASURED and m is None:
        raise StoreError(f"{where}: status 'measured' but no measurement")
    if status is TrialStatus.AWAITING and m is not None:
        raise StoreError(f"{where}: status 'awaiting' but it has a measurement")
    if status is TrialStatus.EXCLUDED and not (trial.exclusion_reason or "").strip():
        raise StoreError(f"{where}: an excluded trial needs a reason")
    log = trial.encoder_log
    if log is not None and not (log.t.size == log.left_ticks.size == log.right_ticks.size):
        raise StoreError(f"{where}: encoder log arrays differ in length")


def record_from_trial(trial: Trial, params_version: int) -> dict[str, Any]:
    """The ``trials`` row of ``trial`` (validate it first with :func:`validate_trial`)."""
    c, p, m, tr = trial.command, trial.predicted, trial.measured, trial.true
    return {
        "trial_id": trial.trial_id,
        "campaign": trial.campaign,
        "terrain": trial.terrain,
        "kind": c.kind.value,
        "angle": c.angle,
        "distance": c.distance,
        "side": c.side,
        "direction": c.direction,
        "speed": c.speed,
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
        "raw": json.dumps({k: float(v) for k, v in m.raw.items()} if m else {}, sort_keys=True),
        "true_t": float(tr.t) if tr else None,
        "true_x": float(tr.x) if tr else None,
        "true_y": float(tr.y) if tr else None,
        "true_theta": float(tr.theta) if tr else None,
        "true_heading": float(tr.heading) if tr else None,
        "status": TrialStatus(trial.status).value,
        "exclusion_reason": trial.exclusion_reason,
        "notes": trial.notes,
    }


def _opt(v: Any) -> float | None:
    return None if v is None else float(v)


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
    true = None
    if rec.get("true_x") is not None:
        true = Pose(
            float(rec["true_t"]),
            float(rec["true_x"]),
            float(rec["true_y"]),
            float(rec["true_theta"]),
            float(rec["true_heading"]),
        )
    return Trial(
        trial_id=rec["trial_id"],
        campaign=rec["campaign"],
        terrain=rec["terrain"],
        command=Command(
            kind=MotionKind(rec["kind"]),
            angle=_opt(rec.get("angle")),
            distance=_opt(rec.get("distance")),
            side=_opt(rec.get("side")),
            direction=rec.get("direction"),
            speed=_opt(rec.get("speed")),
        ),
        predicted=Pose(
            float(rec["predicted_t"]),
            float(rec["predicted_x"]),
            float(rec["predicted_y"]),
            float(rec["predicted_theta"]),
            float(rec["predicted_heading"]),
        ),
        params=params,
        measured=measured,
        true=true,
        encoder_log=log,
        status=TrialStatus(rec["status"]),
        exclusion_reason=rec.get("exclusion_reason"),
        notes=rec.get("notes") or "",
    )
