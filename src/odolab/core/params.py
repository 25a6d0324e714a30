"""Robot parameters: the kinematic constants odometry needs, validated, with TOML load/save.

File format (TOML)::

    [robot]
    name = "jaguar-lite"
    left_wheel_radius = 0.0835   # m, effective
    right_wheel_radius = 0.0835  # m, effective
    track_width = 0.56           # m, effective (2 * L_robot of the lab report)
    ticks_per_rev = 380          # encoder counts per wheel revolution
    encoder_modulus = 32768      # counter wraps to 0 after modulus-1; omit if it never wraps

Every value must lie in a plausible physical range (:data:`RANGES`): a wheel radius from 2 mm to
2 m, a track width from 1 cm to 20 m, 1 to 10^8 counts per revolution, a modulus from 2 to 2^63.
Whatever builds parameters (a TOML file, a notebook CSV or JSON import, a calibration) gets the
same check; a value that looks like centimetres or millimetres is refused with the metres it
probably meant ("a radius of 8.35 m looks like centimetres: 0.0835 m?").

Optional tables::

    [model]                      # optional: the kinematic model (odolab.core.models); default "diff"
    kind = "diff"

    [noise]                      # optional: random error, var(ds) = k * |ds| per wheel
    k_left = 1e-4                # m
    k_right = 1e-4               # m
    k_scrub = 0.0                # rad: heading variance per radian of commanded turning
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, overload

from odolab.core.defaults import DEFAULT_ROBOT
from odolab.core.errors import ParamsError, check_table_keys
from odolab.core.models import (
    DIFF_DRIVE,
    MODELS,
    KinematicModel,
    ModelCoefficients,
    is_kinematic_model,
    model_from_mapping,
    model_words,
    own_covariance,
)
from odolab.core.text import quote_input
from odolab.core.writing import path_first

__all__ = [
    "DEFAULT_ROBOT",
    "PRESETS",
    "RANGES",
    "NoiseParams",
    "RobotParams",
    "check_param",
    "covariance_source",
    "load_params",
    "params_from_mapping",
    "plausible_range",
    "save_params",
]

_FIELDS = (
    "name",
    "left_wheel_radius",
    "right_wheel_radius",
    "track_width",
    "ticks_per_rev",
    "encoder_modulus",
)
#: Top-level tables of a parameters file (other developers' tables are added here).
_TABLES = ("robot", "model", "noise", "provenance")
_NOISE_KEYS = ("k_left", "k_right", "k_scrub")
#: Above this a per-metre slip variance means metres of error per metre driven: not odometry.
_NOISE_MAX = 1.0


@dataclass(frozen=True)
class NoiseParams:
    """Random error of odometry: per-wheel slip ``var(ds) = k * |ds|`` (Chong & Kleeman).

    ``k_left``, ``k_right`` in metres (as :mod:`odolab.analysis.noise` estimates them);
    ``k_scrub`` in radians: extra heading variance per radian of commanded turning
    ``|ds_r - ds_l| / track_width`` (track scrub of skid-steer robots; 0 for wheels)."""

    k_left: float
    k_right: float
    k_scrub: float = 0.0

    def __post_init__(self) -> None:
        for key in _NOISE_KEYS:
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ParamsError(f"[noise] {key} must be a number, got {value!r}")
            if not _finite(value) or value < 0 or value > _NOISE_MAX:
                raise ParamsError(
                    f"[noise] {key} must be a number from 0 to {_NOISE_MAX:g}, got {value!r}"
                )
            object.__setattr__(self, key, float(value))

    def to_dict(self) -> dict[str, float]:
        """The ``[noise]`` table (``k_scrub`` only when not zero)."""
        out = {"k_left": self.k_left, "k_right": self.k_right}
        if self.k_scrub:
            out["k_scrub"] = self.k_scrub
        return out


def noise_from_mapping(data: object, *, source: str = "parameters") -> NoiseParams:
    """Build :class:`NoiseParams` from a ``[noise]`` table, naming ``source`` in any error."""
    if not isinstance(data, dict):
        raise ParamsError(f"{source}: [noise] must be a table, got {type(data).__name__}")
    check_table_keys(
        data, _NOISE_KEYS, _NOISE_KEYS[:2], source, "[noise]", expected=", ".join(_NOISE_KEYS)
    )
    try:
        return NoiseParams(**data)
    except ParamsError as err:
        raise ParamsError(f"{source}: {err}") from err


_REQUIRED = ("left_wheel_radius", "right_wheel_radius", "track_width", "ticks_per_rev")

#: Largest parameters file read (bytes): it is read whole, so a wrong file is refused first.
MAX_TOML_BYTES = 1_000_000

#: Plausible physical range (inclusive) of each parameter, its unit and the word used in hints.
#: Radii: a 2 mm micro-robot wheel to a 2 m mining-truck tyre. Track: 1 cm to 20 m. Counts per
#: revolution: 1 (a reed switch) to 10^8 (a fine encoder behind a gearbox). Modulus: 2 to 2^63
#: (a signed 64-bit counter).
RANGES: dict[str, tuple[float, float, str, str]] = {
    "left_wheel_radius": (0.002, 2.0, "m", "radius"),
    "right_wheel_radius": (0.002, 2.0, "m", "radius"),
    "track_width": (0.01, 20.0, "m", "track width"),
    "ticks_per_rev": (1.0, 1e8, "counts per revolution", "count"),
    "encoder_modulus": (2, 2**63, "", "modulus"),
}


def plausible_range(key: str) -> tuple[float, float]:
    """The plausible (low, high) of a ``[robot]`` key or of a ``[model]`` key of any model."""
    if key in RANGES:
        lo, hi, _, _ = RANGES[key]
        return float(lo), float(hi)
    for cls in MODELS.values():
        ranges: dict[str, tuple[float, float]] = getattr(cls, "RANGES", {})
        if key in ranges:
            return ranges[key]
    raise KeyError(key)


def _hint(key: str, value: float) -> str:
    """``"; a radius of 8.35 m looks like centimetres: 0.0835 m?"`` when a unit slip explains it."""
    lo, hi, unit, word = RANGES[key]
    if unit != "m":
        return ""
    for name, div in (("centimetres", 100.0), ("millimetres", 1000.0)):
        if lo <= value / div <= hi:
            return f"; a {word} of {value:.6g} m looks like {name}: {value / div:.6g} m?"
    return ""


def _finite(value: float) -> bool:
    """``math.isfinite`` that is False, not an OverflowError, for an int past float's range
    (a TOML or JSON integer of 400 digits)."""
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


def check_param(key: str, value: object) -> float | int:
    """``value`` of parameter ``key`` if it is a number in its plausible range, else refuse.

    Every path that builds :class:`RobotParams` (TOML, CSV, JSON, CLI) applies this same check,
    through the constructor. The message names the key, the range and a likely unit slip.
    """
    lo, hi, unit, _ = RANGES[key]
    if key == "encoder_modulus":
        if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
            raise ParamsError(
                f"encoder_modulus must be an integer >= 2 (at most 2^63) or left out, got "
                f"{quote_input(value)}"
            )
        return value
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ParamsError(f"{key} must be a number, got {quote_input(value)}")
    if not _finite(value) or value <= 0:
        raise ParamsError(f"{key} must be a positive finite number, got {quote_input(value)}")
    if not lo <= value <= hi:
        raise ParamsError(
            f"{key} = {value:.6g} {unit} is outside the plausible {lo:g} to {hi:g} {unit}"
            + _hint(key, float(value))
        )
    return float(value)


@dataclass(frozen=True)
class RobotParams:
    """Kinematic parameters of a differential-drive or skid-steer robot (SI units).

    ``track_width`` is the distance between the effective left and right contact lines, i.e.
    ``2 * L_robot`` in the lab report. Radii are *effective* radii (what odometry should use),
    which for tracks differ from what a ruler gives.
    """

    left_wheel_radius: float
    right_wheel_radius: float
    track_width: float
    ticks_per_rev: float
    encoder_modulus: int | None = None
    name: str = "robot"
    model: KinematicModel = DIFF_DRIVE
    noise: NoiseParams | None = None

    def __post_init__(self) -> None:
        for key in ("left_wheel_radius", "right_wheel_radius", "track_width", "ticks_per_rev"):
            object.__setattr__(self, key, check_param(key, getattr(self, key)))
        if self.encoder_modulus is not None:
            check_param("encoder_modulus", self.encoder_modulus)
        if not isinstance(self.name, str) or not self.name:
            raise ParamsError(f"name must be a non-empty string, got {quote_input(self.name)}")
        if not is_kinematic_model(self.model):
            raise ParamsError(f"model must be a kinematic model, got {self.model!r}")
        if self.noise is not None and not isinstance(self.noise, NoiseParams):
            raise ParamsError(f"noise must be NoiseParams or None, got {self.noise!r}")

    @property
    def coefficients(self) -> ModelCoefficients:
        """The kinematic model's wheel-to-body coefficients for this robot (odolab.core.models)."""
        return self.model.coefficients(self.track_width)

    @property
    def left_metres_per_tick(self) -> float:
        """Distance the left wheel rolls per encoder count (m), eq. (3.2) without the count."""
        return 2.0 * math.pi * self.left_wheel_radius / self.ticks_per_rev

    @property
    def right_metres_per_tick(self) -> float:
        """Distance the right wheel rolls per encoder count (m), eq. (3.1) without the count."""
        return 2.0 * math.pi * self.right_wheel_radius / self.ticks_per_rev

    def with_(self, **changes: Any) -> RobotParams:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    def to_dict(self) -> dict[str, object]:
        """The ``[robot]`` table in file order, without ``encoder_modulus`` when it is None.

        The kinematic model is not part of it: see :meth:`model_table`."""
        d = {k: getattr(self, k) for k in _FIELDS}
        out = {k: d[k] for k in _FIELDS if d[k] is not None}
        if float(out["ticks_per_rev"]).is_integer():
            out["ticks_per_rev"] = int(out["ticks_per_rev"])
        return out

    def model_table(self) -> dict[str, object] | None:
        """The ``[model]`` table (``kind`` first), or None for the default differential drive."""
        if self.model == DIFF_DRIVE:
            return None
        return {"kind": self.model.kind, **self.model.to_dict()}

    def model_words(self) -> tuple[tuple[str, str], ...]:
        """The kinematic model and the ``[noise]`` table in words, as (label, text) pairs: what
        every face shows of a parameter set besides its ``[robot]`` numbers (``odolab trials
        params-versions``, the web's parameter versions). Empty for a plain differential drive
        without noise."""
        out: list[tuple[str, str]] = []
        table = self.model_table()
        if table is not None:
            out.append(("model", model_words(self.model)))
        if self.noise is not None:
            n = self.noise
            scrub = f", k_scrub {n.k_scrub:g} rad" if n.k_scrub else ""
            out.append(("noise", f"k_left {n.k_left:g}, k_right {n.k_right:g} m{scrub}"))
        return tuple(out)


def params_from_mapping(
    data: dict[str, Any],
    *,
    source: str = "parameters",
    model: dict[str, object] | None = None,
    noise: dict[str, object] | None = None,
) -> RobotParams:
    """Build :class:`RobotParams` from a ``[robot]`` mapping (and optional ``[model]`` and
    ``[noise]`` ones), naming ``source`` in any error."""
    check_table_keys(
        data, _FIELDS, _REQUIRED, source, "[robot]", expected=f"one of {', '.join(_FIELDS)}"
    )
    kinematic = DIFF_DRIVE if model is None else model_from_mapping(model, source=source)
    random = None if noise is None else noise_from_mapping(noise, source=source)
    try:
        return RobotParams(**data, model=kinematic, noise=random)
    except ParamsError as err:
        raise ParamsError(f"{source}: {err}") from err
    except TypeError as err:  # pragma: no cover - guarded by the key checks above
        raise ParamsError(f"{source}: {err}") from err


#: Largest integer a parameters file may hold: far past every plausible value, short of float's
#: range (an int past it made every range check an OverflowError).
_MAX_TOML_INT = 2**1000


def _check_integer_sizes(doc: object, path: Path, where: str = "") -> None:
    """Refuse an integer past :data:`_MAX_TOML_INT` anywhere in the file (Python reads any
    length; a float of it overflows), naming its table and key."""
    items = (
        doc.items() if isinstance(doc, dict) else enumerate(doc) if isinstance(doc, list) else ()
    )
    for key, value in items:
        name = f"{where}.{key}" if where else str(key)
        if isinstance(value, int) and not isinstance(value, bool) and abs(value) > _MAX_TOML_INT:
            raise ParamsError(
                f"{path}: {quote_input(name)} is an integer of {len(str(abs(value)))} digits; "
                "expected a parameter value such as 380"
            )
        if isinstance(value, dict | list):
            _check_integer_sizes(value, path, name)


def covariance_source(params: RobotParams) -> str | None:
    """Which covariance a parameter set gives, the one rule every face asks: ``"slip"`` (a slip
    model's own predictive variance, :mod:`odolab.core.slip_uncertainty`; a ``[noise]`` table does
    not apply to it), ``"noise"`` (the ``[noise]`` wheel constants, :func:`propagate_covariance`)
    or None (neither: no covariance)."""
    own = own_covariance(params.model)
    if own is not None:
        return own.covariance_name
    return "noise" if params.noise is not None else None


def load_params(path_or_preset: str | Path) -> RobotParams:
    """Load parameters from a TOML file, or return a preset by name (see :data:`PRESETS`)."""
    key = str(path_or_preset)
    if key in PRESETS and not Path(key).exists():
        return PRESETS[key]
    path = Path(path_or_preset)
    if not path.exists():
        raise ParamsError(
            f"{path}: no such parameters file or preset; presets are {', '.join(sorted(PRESETS))}"
        )
    try:
        if path.stat().st_size > MAX_TOML_BYTES:
            raise ParamsError(
                f"{path}: {path.stat().st_size:,} bytes; a parameters TOML is at most "
                f"{MAX_TOML_BYTES:,} bytes (is it the right file?)"
            )
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as err:
        raise ParamsError(f"{path}: not valid TOML ({err})") from err
    except ValueError as err:  # an integer of more than 4,300 digits (Python's own limit)
        raise ParamsError(
            f"{path}: a number too long to read ({str(err).split(':')[0]}); expected parameter "
            "values such as 0.0835"
        ) from err
    except RecursionError as err:  # arrays or tables nested thousands deep
        raise ParamsError(
            f"{path}: nested too deeply to read; expected the [robot] table of a parameters file"
        ) from err
    except (OSError, UnicodeDecodeError) as err:
        raise ParamsError(f"{path}: cannot read ({err})") from err
    _check_integer_sizes(doc, path)
    if "robot" not in doc or not isinstance(doc["robot"], dict):
        raise ParamsError(f"{path}: missing the [robot] table")
    extra = sorted(k for k in doc if k not in _TABLES)
    if extra:
        raise ParamsError(
            f"{path}: unknown table or key {extra[0]!r}; expected [robot] and optionally "
            "[model], [noise], [provenance]"
        )
    return params_from_mapping(
        doc["robot"], source=str(path), model=doc.get("model"), noise=doc.get("noise")
    )


@overload
def save_params(
    path: str | Path, params: RobotParams, *, provenance: dict[str, object] | None = None
) -> Path: ...
@overload
def save_params(  # the old order
    path: RobotParams, params: str | Path, *, provenance: dict[str, object] | None = None
) -> Path: ...
def save_params(
    path: str | Path | RobotParams,
    params: RobotParams | str | Path,
    *,
    provenance: dict[str, object] | None = None,
) -> Path:
    """Write ``params`` to ``path`` as TOML (and an optional ``[provenance]`` table)."""
    p, entry = path_first(path, params, RobotParams, "save_params")
    return _save_params(entry, p, provenance=provenance)


def _save_params(
    params: RobotParams, path: str | Path, *, provenance: dict[str, object] | None = None
) -> Path:
    doc: dict[str, object] = {"robot": params.to_dict()}
    model = params.model_table()
    if model is not None:
        doc["model"] = model
        posterior = getattr(params.model, "posterior", ())
        if posterior:  # the slip model's coefficient covariance: its predictive variance needs it
            model["posterior"] = [float(v) for v in posterior]
    if params.noise is not None:
        doc["noise"] = params.noise.to_dict()
    if provenance:
        doc["provenance"] = provenance
    import tomli_w  # here: 3 ms of every command's start-up otherwise

    from odolab.core.writing import write_text_file

    # a temporary file beside it, renamed over it: a link at the path is replaced, not followed
    return write_text_file(Path(path), tomli_w.dumps(doc), what="parameters", error=ParamsError)


#: Nominal parameter sets. ``jaguar-lite``: wheel radius 0.0835 m and 380 counts per wheel
#: revolution are the nominal figures seen in public Jaguar drivers (JAGUAR_PROTOCOL.md), the
#: track width 0.56 m is 2 x L_robot = 2 x 0.28 m as the lab report measured with a ruler, and the
#: counters are 15-bit. These are NOMINAL, not measured values: calibrate before trusting them.
PRESETS: dict[str, RobotParams] = {
    DEFAULT_ROBOT: RobotParams(
        name=DEFAULT_ROBOT,
        left_wheel_radius=0.0835,
        right_wheel_radius=0.0835,
        track_width=0.56,
        ticks_per_rev=380,
        encoder_modulus=32768,
    ),
}
