"""The registry of model kinds: every kind registers its class here by its ``kind`` (the
``[model]`` table's ``kind``), and :func:`model_from_mapping` builds a model from a table.

A kind registers with the :func:`register` decorator in its own module; :mod:`odolab.core.models`
imports that module (one line), which is the whole registration.

This module imports neither numpy nor numba (``odolab --help`` stays instant).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, TypeVar

from odolab.core.errors import ParamsError, check_table_keys
from odolab.core.models.base import KinematicModel

__all__ = ["MODELS", "model_from_mapping", "neutral_values", "register", "unregister"]

#: Every model by its ``kind`` in the TOML, filled by :func:`register` (in import order).
MODELS: dict[str, type[Any]] = {}

_T = TypeVar("_T", bound=type[Any])


def register(cls: _T) -> _T:
    """Register a model class by its ``kind`` (a class decorator); a kind is registered once."""
    kind = cls.kind
    if kind in MODELS and MODELS[kind] is not cls:
        raise ValueError(f"model kind {kind!r} is registered twice")
    MODELS[kind] = cls
    return cls


def unregister(kind: str) -> None:
    """Remove a kind from the registry (a test's own model, after the test)."""
    MODELS.pop(kind, None)


def neutral_values(model: KinematicModel, track_width: float) -> dict[str, float]:
    """The keys of every registered kind with their values: ``model``'s own for its kind, each
    other kind's neutral ones (the model that is the differential drive of ``track_width``, a
    kind's ``neutral(track_width)``, else its defaults). What a fit that can start from any
    kind reads (:mod:`odolab.calibration.lsq`), without asking which kind ``model`` is."""
    out: dict[str, float] = {}
    for cls in MODELS.values():
        if type(model) is cls:
            out.update(model.to_dict())
        elif hasattr(cls, "neutral"):
            out.update(cls.neutral(track_width).to_dict())
        else:
            out.update(cls().to_dict())
    return out


def model_from_mapping(data: dict[str, Any], *, source: str = "parameters") -> KinematicModel:
    """Build a model from a ``[model]`` table (``kind`` and the model's keys), naming ``source``."""
    if not isinstance(data, dict):
        raise ParamsError(f"{source}: [model] must be a table, got {type(data).__name__}")
    kind = data.get("kind", "diff")
    if not isinstance(kind, str) or kind not in MODELS:
        raise ParamsError(
            f"{source}: unknown model kind {kind!r} in [model]; expected one of "
            f"{', '.join(sorted(MODELS))}"
        )
    cls = MODELS[kind]
    keys = {k: v for k, v in data.items() if k not in ("kind", "posterior")}
    extra: dict[str, object] = {}
    if "posterior" in data:
        extra["posterior"] = _posterior(data["posterior"], cls, kind, source)
    allowed = tuple(getattr(cls, "KEYS", ()))
    check_table_keys(
        keys, allowed, [k for k in allowed if k not in _defaults(cls)], source,
        f"[model] of kind {kind!r}", expected=", ".join(allowed) if allowed else "no other keys",
    )  # fmt: skip
    for key, value in keys.items():
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise ParamsError(f"{source}: [model] {key} must be a finite number, got {value!r}")
    try:
        model: KinematicModel = cls(**{k: float(v) for k, v in keys.items()}, **extra)
    except ParamsError as err:
        raise ParamsError(f"{source}: [model] {err}") from err
    except TypeError as err:
        raise ParamsError(f"{source}: [model] of kind {kind!r}: {err}") from err
    return model


def _posterior(value: object, cls: type[Any], kind: str, source: str) -> tuple[float, ...]:
    """A ``[model]`` ``posterior`` (the slip model's coefficient covariance, row-major):
    checked to be a list of finite numbers of the model's size."""
    size = len(getattr(cls, "COEF_KEYS", ())) ** 2
    if not size:
        raise ParamsError(f"{source}: unknown key 'posterior' in [model] of kind {kind!r}")
    if not isinstance(value, list) or len(value) != size:
        got = f"{len(value)} values" if isinstance(value, list) else type(value).__name__
        raise ParamsError(
            f"{source}: [model] posterior has {got}; expected a list of {size} numbers"
        )
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise ParamsError(
                f"{source}: [model] posterior[{i}] must be a finite number, got {v!r}"
            )
    return tuple(float(v) for v in value)


def _defaults(cls: type[Any]) -> set[str]:
    """The fields of a model class that have a default value (may be left out of the table)."""
    return {
        f.name
        for f in dataclasses.fields(cls)
        if f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING
    }
