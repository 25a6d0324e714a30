"""Experiment protocols as data (TOML) and the vectorized Monte Carlo that runs them.

A protocol file::

    [protocol]
    campaign = "rotation-indoor"     # trial ids are "<campaign>-<index>"
    description = "..."
    terrain = "tile"                 # default for every trial set
    report_rate = 20.0               # Hz, encoder reports
    dt = 0.025                       # s, physics step (must divide 1 / report_rate)
    linear_speed = 0.3               # m/s, wheel surface speed on straight runs
    turn_speed = 0.3                 # m/s, wheel surface speed when turning

    [instruments]                    # optional
    compass_sigma = 0.05             # rad
    compass_resolution_deg = 1.0
    miscount_probability = 0.0       # chance the operator miscounts the turns by one
    meterstick_sigma = 0.003         # m, indoors
    tape_sigma = 0.005               # m, outdoors

    [[trials]]                       # a set of trials
    motion = "rotation"              # rotation | translation | pivot | square
    angle_pi = { from = 1, to = 20, step = 1 }   # or angle (rad); a number, list or range
    direction = "ccw"                # ccw | cw; a translation: forward | reverse
    repeats = 1
    # distance = [1.0, 2.5]          # translation (m, > 0)
    # side = 4.0                     # square (m)
    # held = "left"                  # pivot: the track that stands still
    # terrain = "grass"; campaign = "..."; speed = 0.3   (per set overrides)

Size limits, checked while the file is read (before any trial exists) and named with the file
and the key: at most 10,000 trials and repeats per set, 1,000 values per list or range;
angles up to 100 pi rad (50 turns), distances up to 1,000 m, square sides up to 250 m, speeds
from 0.01 to 5 m/s, a report rate from 0.1 to 1,000 Hz and a physics step from 0.1 ms to 1 s.
Before the run, with the nominal parameters known, no trial may last more than an hour.

Trials are driven "by odometry": each motion is turned into wheel count targets with the
nominal model (the first count at which the nominal odometry says the target is reached), the
motor controller stops each wheel on its count, and the true robot does what the ground lets it.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from odolab.core.defaults import DEFAULT_TERRAIN
from odolab.core.errors import SimError
from odolab.core.kinematics import wrap_angle
from odolab.core.odometry import integrate
from odolab.core.params import MAX_TOML_BYTES, RobotParams
from odolab.core.progress import Progress, no_progress
from odolab.core.text import quote_input
from odolab.core.trajectory import Pose
from odolab.core.trials import Command, EncoderLog, Measurement, MotionKind, Trial, TrialStatus
from odolab.sim.instruments import Compass, CompassReadings, Instruments, Meterstick
from odolab.sim.physics import (
    _NPARAM,
    BatchResult,
    TrueParams,
    kernel_params,
    simulate_batch,
)
from odolab.sim.terrains import get_terrain

__all__ = [
    "ExperimentProtocol",
    "Protocol",
    "TrialSpec",
    "builtin_protocols",
    "load_protocol",
    "parse_protocol",
    "read_toml",
    "run_protocol",
    "segments_for",
    "toml_error",
    "toml_number",
    "true_final_poses",
]

_PROTOCOL_KEYS = {
    "name",
    "campaign",
    "description",
    "terrain",
    "report_rate",
    "dt",
    "linear_speed",
    "turn_speed",
}
_INSTRUMENT_KEYS = {
    "compass_sigma",
    "compass_resolution_deg",
    "miscount_probability",
    "meterstick_sigma",
    "tape_sigma",
}
_SET_KEYS = {
    "motion",
    "angle",
    "angle_pi",
    "distance",
    "side",
    "direction",
    "held",
    "repeats",
    "terrain",
    "campaign",
    "speed",
}
_MOTIONS = ("rotation", "translation", "pivot", "square")

#: Size limits of a protocol (see the module docstring): a typo such as ``repeats = 1000000000``
#: or ``angle_pi = { from = 1, to = 1e9, step = 1 }`` is one sentence, not an exhausted memory.
MAX_TRIALS = 10_000
MAX_REPEATS = 10_000
MAX_VALUES = 1_000
MAX_ANGLE_RAD = 100.0 * math.pi
MAX_DISTANCE_M = 1_000.0
MAX_SIDE_M = 250.0
SPEED_RANGE_M_S = (0.01, 5.0)
REPORT_RATE_RANGE_HZ = (0.1, 1_000.0)
DT_RANGE_S = (1e-4, 1.0)
#: The numbers of the [protocol] table: key -> (default, allowed range, unit), read in this order.
_PROTOCOL_NUMBERS: dict[str, tuple[float, tuple[float, float], str]] = {
    "linear_speed": (0.3, SPEED_RANGE_M_S, " m/s"),
    "turn_speed": (0.3, SPEED_RANGE_M_S, " m/s"),
    "report_rate": (20.0, REPORT_RATE_RANGE_HZ, " Hz"),
    "dt": (0.025, DT_RANGE_S, " s"),
}
MAX_TRIAL_SECONDS = 3_600.0
#: Most encoder reports one run may hold (trials x the longest trial's reports): 2 x 8 bytes
#: each in the simulator's counters, so about 320 MB at most.
MAX_BATCH_REPORTS = 20_000_000
_DIRECTIONS = {
    "rotation": ("ccw", "cw"),
    "pivot": ("ccw", "cw"),
    "square": ("ccw", "cw"),
    "translation": ("forward", "reverse"),
}


@dataclass(frozen=True)
class TrialSpec:
    """One trial to run: the command, its terrain and campaign."""

    command: Command
    terrain: str
    campaign: str


@dataclass(frozen=True)
class ExperimentProtocol:
    """A parsed protocol: settings and the expanded list of trials, in file order."""

    name: str
    campaign: str
    description: str
    trials: tuple[TrialSpec, ...]
    report_rate: float = 20.0
    dt: float = 0.025
    instruments: Instruments = field(default_factory=Instruments)
    source: str = "<protocol>"

    def __len__(self) -> int:
        return len(self.trials)


#: Compatibility alias of :class:`ExperimentProtocol` (the old name collided with
#: ``typing.Protocol`` and the robot's wire protocol).
Protocol = ExperimentProtocol


# --------------------------------------------------------------------------- parsing


def toml_error(source: str, where: str, message: str) -> SimError:
    """The error for a value of the TOML file ``source`` at ``where`` (a table or key): the
    file, the place and the message, in one sentence (protocols and experiment files)."""
    return SimError(f"{source}: {where}: {message}")


def _check_keys(source: str, where: str, table: dict[str, object], allowed: set[str]) -> None:
    """Refuse the first key of ``table`` that is not in ``allowed``, naming it."""
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise toml_error(
            source,
            f"{where} key {unknown[0]!r}",
            f"unknown key; expected {', '.join(sorted(allowed))}",
        )


def toml_number(
    source: str,
    where: str,
    value: object,
    *,
    positive: bool = True,
    within: tuple[float, float] | None = None,
    most: float = math.inf,
    unit: str = "",
) -> float:
    """``value`` from the TOML file ``source`` at ``where`` as a float: a finite number (no
    bool, no text), > 0 with ``positive``, inside ``within`` (inclusive) and of magnitude at
    most ``most`` (in ``unit``) where given; else :func:`toml_error` with what was expected.
    The one check of a number in a protocol or an experiment file."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise toml_error(source, where, f"expected a finite number, got {quote_input(value)}")
    if positive and value <= 0:
        raise toml_error(source, where, f"expected a number > 0, got {value!r}")
    if abs(value) > most:
        either = "" if positive else " either way"
        raise toml_error(source, where, f"expected at most {most:g} {unit}{either}, got {value!r}")
    if within is not None and not within[0] <= value <= within[1]:
        raise toml_error(
            source,
            where,
            f"{value:g}{unit} is outside the allowed {within[0]:g} to {within[1]:g}{unit}",
        )
    return float(value)


def _values(source: str, where: str, value: object, *, maximum: float, unit: str) -> list[float]:
    """A number, a list of numbers, or an inclusive range table {from, to, step}; all > 0.

    At most :data:`MAX_VALUES` values, each at most ``maximum``: a range's size is known from
    its ends, so a range too long is refused before any of its values is made.
    """
    limit = (0.0, maximum)
    if isinstance(value, dict):
        extra = sorted(set(value) - {"from", "to", "step"})
        if extra or not {"from", "to", "step"} <= set(value):
            raise toml_error(source, where, "a range must have exactly the keys from, to, step")
        lo = toml_number(source, f"{where}.from", value["from"], within=limit, unit=unit)
        hi = toml_number(source, f"{where}.to", value["to"], within=limit, unit=unit)
        step = toml_number(source, f"{where}.step", value["step"])
        if hi < lo:
            raise toml_error(source, where, f"range goes down (from {lo} to {hi})")
        count = math.floor((hi - lo) / step + 1e-9) + 1
        if count > MAX_VALUES:
            raise toml_error(
                source,
                where,
                f"the range from {lo:g} to {hi:g} in steps of {step:g} has {count} values; "
                f"expected at most {MAX_VALUES}",
            )
        return [lo + i * step for i in range(count)]
    if isinstance(value, list):
        if not value:
            raise toml_error(source, where, "expected at least one value")
        if len(value) > MAX_VALUES:
            raise toml_error(source, where, f"{len(value)} values; expected at most {MAX_VALUES}")
        return [
            toml_number(source, f"{where}[{i}]", v, within=limit, unit=unit)
            for i, v in enumerate(value)
        ]
    return [toml_number(source, where, value, within=limit, unit=unit)]


def _text(source: str, where: str, value: object, choices: Sequence[str]) -> str:
    if not isinstance(value, str) or value not in choices:
        raise toml_error(source, where, f"got {value!r}; expected one of {', '.join(choices)}")
    return value


def _commands(
    source: str,
    where: str,
    spec: dict[str, object],
    motion: str,
    sign: float,
    direction: str,
    speed: float,
) -> list[Command]:
    """The commands of one [[trials]] table: one per angle, distance or side given."""
    kind = MotionKind(motion)
    allowed = {
        "rotation": {"angle", "angle_pi"},
        "pivot": {"angle", "angle_pi", "held"},
        "translation": {"distance"},
        "square": {"side"},
    }[motion]
    for key in ("angle", "angle_pi", "distance", "side", "held"):
        if key in spec and key not in allowed:
            raise toml_error(source, f"{where} key {key!r}", f"does not apply to a {motion}")
    commands: list[Command] = []
    if kind in (MotionKind.ROTATION, MotionKind.PIVOT):
        if ("angle" in spec) == ("angle_pi" in spec):
            raise toml_error(
                source, f"{where} key 'angle'", "give exactly one of angle or angle_pi"
            )
        key = "angle" if "angle" in spec else "angle_pi"
        scale = 1.0 if key == "angle" else math.pi
        held = None
        if kind is MotionKind.PIVOT:
            held = _text(source, f"{where} key 'held'", spec.get("held", "left"), ("left", "right"))
        most, unit = (MAX_ANGLE_RAD, " rad") if key == "angle" else (MAX_ANGLE_RAD / math.pi, " pi")
        for a in _values(source, f"{where} key {key!r}", spec[key], maximum=most, unit=unit):
            commands.append(
                Command(kind, angle=sign * a * scale, direction=held or direction, speed=speed)
            )
    elif kind is MotionKind.TRANSLATION:
        if "distance" not in spec:
            raise toml_error(source, f"{where} key 'distance'", "missing")
        for d in _values(
            source, f"{where} key 'distance'", spec["distance"], maximum=MAX_DISTANCE_M, unit=" m"
        ):
            commands.append(Command(kind, distance=sign * d, speed=speed))
    else:
        if "side" not in spec:
            raise toml_error(source, f"{where} key 'side'", "missing")
        for s in _values(
            source, f"{where} key 'side'", spec["side"], maximum=MAX_SIDE_M, unit=" m"
        ):
            commands.append(Command(kind, side=s, direction=direction, speed=speed))
    return commands


def _parse_set(
    source: str, index: int, spec: object, defaults: dict[str, object]
) -> list[TrialSpec]:
    where = f"[[trials]] #{index + 1}"
    if not isinstance(spec, dict):
        raise toml_error(source, where, "expected a table")
    _check_keys(source, where, spec, _SET_KEYS)
    if "motion" not in spec:
        raise toml_error(source, f"{where} key 'motion'", "missing")
    motion = _text(source, f"{where} key 'motion'", spec["motion"], _MOTIONS)
    kind = MotionKind(motion)
    terrain = spec.get("terrain", defaults["terrain"])
    get_terrain(str(terrain), where=f"{source}: {where} key 'terrain'")
    if not isinstance(terrain, str):
        raise toml_error(source, f"{where} key 'terrain'", f"expected a name, got {terrain!r}")
    campaign = spec.get("campaign", defaults["campaign"])
    if not isinstance(campaign, str) or not campaign:
        raise toml_error(source, f"{where} key 'campaign'", "expected a non-empty string")
    repeats = spec.get("repeats", 1)
    if isinstance(repeats, bool) or not isinstance(repeats, int) or repeats < 1:
        raise toml_error(
            source,
            f"{where} key 'repeats'",
            f"expected an integer >= 1, got {quote_input(repeats)}",
        )
    if repeats > MAX_REPEATS:
        raise toml_error(
            source, f"{where} key 'repeats'", f"{repeats} repeats; expected at most {MAX_REPEATS}"
        )
    choices = _DIRECTIONS[motion]
    direction = _text(
        source, f"{where} key 'direction'", spec.get("direction", choices[0]), choices
    )
    sign = 1.0 if direction in ("ccw", "forward") else -1.0
    default_speed = (
        defaults["linear_speed"] if kind is MotionKind.TRANSLATION else defaults["turn_speed"]
    )
    speed = toml_number(
        source,
        f"{where} key 'speed'",
        spec.get("speed", default_speed),
        within=SPEED_RANGE_M_S,
        unit=" m/s",
    )

    commands = _commands(source, where, spec, motion, sign, direction, speed)
    if len(commands) * repeats > MAX_TRIALS:
        raise toml_error(
            source,
            f"{where} key 'repeats'",
            f"{len(commands)} values x {repeats} repeats = {len(commands) * repeats} trials; "
            f"expected at most {MAX_TRIALS} in a protocol",
        )
    return [TrialSpec(c, terrain, campaign) for c in commands for _ in range(repeats)]


def _instruments(source: str, doc: dict[str, object]) -> Instruments:
    """The [instruments] table (defaults for what it leaves out)."""
    inst = doc.get("instruments", {})
    if not isinstance(inst, dict):
        raise toml_error(source, "[instruments]", "expected a table")
    _check_keys(source, "[instruments]", inst, _INSTRUMENT_KEYS)

    def inum(key: str, default: float) -> float:
        return toml_number(
            source, f"[instruments] key {key!r}", inst.get(key, default), positive=False
        )

    try:
        instruments = Instruments(
            compass=Compass(
                sigma=inum("compass_sigma", 0.05),
                resolution_deg=inum("compass_resolution_deg", 1.0),
                miscount_probability=inum("miscount_probability", 0.0),
            ),
            meterstick=Meterstick(sigma=inum("meterstick_sigma", 0.003)),
            tape=Meterstick(sigma=inum("tape_sigma", 0.005)),
        )
    except SimError as err:
        raise toml_error(source, "[instruments]", str(err)) from err
    return instruments


def _trial_specs(
    source: str, doc: dict[str, object], defaults: dict[str, object]
) -> list[TrialSpec]:
    """Every [[trials]] table's trials, in order."""
    sets = doc.get("trials")
    if not isinstance(sets, list) or not sets:
        raise toml_error(source, "[[trials]]", "expected at least one [[trials]] table")
    trials: list[TrialSpec] = []
    for i, spec in enumerate(sets):
        trials.extend(_parse_set(source, i, spec, defaults))
        if len(trials) > MAX_TRIALS:
            raise toml_error(
                source,
                f"[[trials]] #{i + 1}",
                f"the protocol has {len(trials)} trials up to here; expected at most {MAX_TRIALS}",
            )
    return trials


def parse_protocol(doc: dict[str, object], source: str = "<protocol>") -> ExperimentProtocol:
    """Build an :class:`ExperimentProtocol` from a parsed TOML document; errors name ``source`` and the key."""
    extra = sorted(set(doc) - {"protocol", "instruments", "trials"})
    if extra:
        raise toml_error(
            source,
            f"key {extra[0]!r}",
            "unknown table; expected [protocol], [instruments], [[trials]]",
        )
    head = doc.get("protocol")
    if not isinstance(head, dict):
        raise toml_error(source, "[protocol]", "missing table")
    _check_keys(source, "[protocol]", head, _PROTOCOL_KEYS)
    name = head.get("name", Path(source).stem)
    campaign = head.get("campaign", name)
    if not isinstance(campaign, str) or not campaign:
        raise toml_error(source, "[protocol] key 'campaign'", "expected a non-empty string")
    terrain = head.get("terrain", DEFAULT_TERRAIN)
    get_terrain(str(terrain), where=f"{source}: [protocol] key 'terrain'")
    numbers = {
        key: toml_number(source, f"[protocol] key {key!r}", head.get(key, default), within=within,
                     unit=unit)
        for key, (default, within, unit) in _PROTOCOL_NUMBERS.items()
    }  # fmt: skip
    rate, dt = numbers["report_rate"], numbers["dt"]
    defaults: dict[str, object] = {
        "terrain": terrain, "campaign": campaign,
        "linear_speed": numbers["linear_speed"], "turn_speed": numbers["turn_speed"],
    }  # fmt: skip
    spr = 1.0 / (rate * dt)
    if abs(spr - round(spr)) > 1e-6 or round(spr) < 1:
        raise toml_error(
            source, "[protocol] key 'dt'", f"{dt} s does not divide the report period 1/{rate} s"
        )
    instruments = _instruments(source, doc)
    trials = _trial_specs(source, doc, defaults)
    desc = head.get("description", "")
    return ExperimentProtocol(
        name=str(name),
        campaign=campaign,
        description=str(desc),
        trials=tuple(trials),
        report_rate=rate,
        dt=dt,
        instruments=instruments,
        source=source,
    )


def builtin_index(folder_name: str, table: str, key: str) -> dict[str, str]:
    """Names of the built-in TOML files in ``odolab/data/<folder_name>`` and each file's
    ``[table] key`` (a description, a question)."""
    out: dict[str, str] = {}
    folder = resources.files("odolab").joinpath("data", folder_name)
    for entry in sorted(folder.iterdir(), key=lambda e: e.name):
        if entry.name.endswith(".toml"):
            doc = tomllib.loads(entry.read_text(encoding="utf-8"))
            out[entry.name[:-5]] = str(doc.get(table, {}).get(key, ""))
    return out


def builtin_protocols() -> dict[str, str]:
    """Built-in protocol names and their one-line descriptions."""
    return builtin_index("protocols", "protocol", "description")


def read_toml(
    name_or_path: str | Path, *, folder: str, what: str, builtins: Callable[[], Iterable[str]]
) -> tuple[dict[str, object], str]:
    """The TOML document of a file, or of the built-in ``odolab/data/FOLDER/NAME.toml`` by name,
    and the name the errors give it. A name that ends in ``.toml`` or is an existing path is a
    file (at most :data:`odolab.core.params.MAX_TOML_BYTES`, a parameters file's cap); anything else names a built-in. ``what`` ("protocol",
    "experiment") and ``builtins`` (their names) word the errors: one rule for both kinds.

    Raises:
        SimError: the file cannot be read, is too large or is not TOML, or no built-in has
            that name.
    """
    key = str(name_or_path)
    path = Path(key)
    if path.suffix == ".toml" or path.exists():
        source = str(path)
        try:
            size = path.stat().st_size
            if size > MAX_TOML_BYTES:
                raise SimError(
                    f"{path}: {size:,} bytes; a {what} TOML is at most {MAX_TOML_BYTES:,} bytes "
                    "(is it the right file?)"
                )
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as err:
            raise SimError(f"{path}: cannot read the {what} ({err})") from err
    else:
        entry = resources.files("odolab").joinpath(f"data/{folder}/{key}.toml")
        if not entry.is_file():
            raise SimError(
                f"{key}: no such {what} file or built-in {what}; built-ins are "
                f"{', '.join(builtins())}"
            )
        source = f"{key}.toml"
        text = entry.read_text(encoding="utf-8")
    try:
        return tomllib.loads(text), source
    except tomllib.TOMLDecodeError as err:
        raise SimError(f"{source}: not valid TOML ({err})") from err


def load_protocol(name_or_path: str | Path) -> ExperimentProtocol:
    """A built-in protocol by name (see :func:`builtin_protocols`) or a protocol TOML file."""
    doc, source = read_toml(
        name_or_path, folder="protocols", what="protocol", builtins=builtin_protocols
    )
    return parse_protocol(doc, source)


# --------------------------------------------------------------------------- running


def segments_for(command: Command, nominal: RobotParams) -> list[tuple[int, int, float, float]]:
    """Wheel count targets and speeds of a command, driven by the nominal model.

    Returns segments ``(dticks_left, dticks_right, speed_left, speed_right)``: each wheel turns by
    the first whole count at which the nominal odometry says the target is reached.
    """
    ml, mr = nominal.left_metres_per_tick, nominal.right_metres_per_tick
    b = nominal.track_width
    v = float(command.speed or 0.3)

    def counts(dist: float, mpt: float) -> int:
        return math.ceil(abs(dist) / mpt - 1e-9)

    def straight(d: float) -> tuple[int, int, float, float]:
        s = 1 if d >= 0 else -1
        return s * counts(d, ml), s * counts(d, mr), s * v, s * v

    def turn(a: float) -> tuple[int, int, float, float]:
        s = 1 if a >= 0 else -1
        arc = abs(a) * b / 2.0
        return -s * counts(arc, ml), s * counts(arc, mr), -s * v, s * v

    kind = command.kind
    if kind is MotionKind.TRANSLATION and command.distance is not None:
        return [straight(command.distance)]
    if kind is MotionKind.ROTATION and command.angle is not None:
        return [turn(command.angle)]
    if kind is MotionKind.PIVOT and command.angle is not None:
        a = command.angle
        s = 1 if a >= 0 else -1
        arc = abs(a) * b
        if command.direction == "right":  # right track held: the left one moves
            return [(-s * counts(arc, ml), 0, -s * v, 0.0)]
        return [(0, s * counts(arc, mr), 0.0, s * v)]
    if kind is MotionKind.SQUARE and command.side is not None:
        a = math.pi / 2 if command.direction != "cw" else -math.pi / 2
        return [straight(command.side), turn(a)] * 4
    raise SimError(f"cannot drive a {kind.value} command by odometry: {command!r}")


def _check_run_size(
    protocol: Protocol, segs: Sequence[list[tuple[int, int, float, float]]], nominal: RobotParams
) -> None:
    """Refuse a trial longer than :data:`MAX_TRIAL_SECONDS`, or a run too big for memory."""
    ml, mr = nominal.left_metres_per_tick, nominal.right_metres_per_tick
    longest = 0.0
    for i, ss in enumerate(segs):
        seconds = sum(
            max(abs(dl) * ml / abs(vl) if vl else 0.0, abs(dr) * mr / abs(vr) if vr else 0.0)
            for dl, dr, vl, vr in ss
        )
        if seconds > MAX_TRIAL_SECONDS:
            raise SimError(
                f"{protocol.source}: trial {i + 1} ({protocol.trials[i].command.describe()}) "
                f"would last {seconds:.0f} s; expected at most {MAX_TRIAL_SECONDS:.0f} s "
                "(check its speed, distance and angle)"
            )
        longest = max(longest, seconds)
    reports = len(segs) * (longest * protocol.report_rate + 1)
    if reports > MAX_BATCH_REPORTS:
        raise SimError(
            f"{protocol.source}: {len(segs)} trials of up to {longest:.0f} s at "
            f"{protocol.report_rate:g} Hz are {reports:.3g} encoder reports; expected at most "
            f"{MAX_BATCH_REPORTS:.3g} in one run (split the protocol)"
        )


def _pose(t: float, x: float, y: float, h: float) -> Pose:
    return Pose(t, x, y, float(wrap_angle(h)), h)


def _campaign_on(campaign: str, protocol_terrain: str, terrain: str) -> str:
    """The campaign name for trials moved to another terrain: ``translation-indoor`` run with
    ``--terrain grass`` is ``translation-grass`` (a trailing place word is replaced)."""
    if terrain == protocol_terrain:
        return campaign
    places = ("indoor", "outdoor", "tile", "concrete", "grass", protocol_terrain)
    base = campaign
    for word in places:
        if base.endswith(f"-{word}"):
            base = base[: -len(word) - 1]
            break
    return f"{base}-{terrain}"


def _simulate(
    protocol: ExperimentProtocol,
    truth: TrueParams,
    nominal: RobotParams,
    terrains: list[str],
    rng: np.random.Generator,
) -> BatchResult:
    """Every trial driven at once on the virtual robot (see :func:`simulate_batch`)."""
    specs = protocol.trials
    n = len(specs)
    cache = {name: kernel_params(truth, nominal, get_terrain(name)) for name in set(terrains)}
    P = np.stack([cache[name] for name in terrains]) if n else np.zeros((0, _NPARAM))
    segs = [segments_for(s.command, nominal) for s in specs]
    _check_run_size(protocol, segs, nominal)
    width = max((len(s) for s in segs), default=1)
    arr = np.zeros((4, n, width))
    nseg = np.zeros(n, dtype=np.int64)
    for i, ss in enumerate(segs):
        nseg[i] = len(ss)
        arr[:, i, : len(ss)] = np.array(ss, dtype=np.float64).T
    batch = simulate_batch(
        P,
        arr[0].astype(np.int64),
        arr[1].astype(np.int64),
        arr[2],
        arr[3],
        nseg,
        align_sigma=truth.align_sigma,
        track_sigma=truth.track_sigma,
        report_rate=protocol.report_rate,
        dt=protocol.dt,
        rng=rng,
    )
    return batch


def _raw_counters(
    batch: BatchResult, modulus: int | None, rng: np.random.Generator
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The trials' counters as the robot reports them: from a random start, wrapped."""
    n = batch.ticks_left.shape[0]
    offsets = np.zeros((n, 2), dtype=np.int64)
    if modulus:
        offsets = rng.integers(0, modulus, size=(n, 2))
    all_left = batch.ticks_left + offsets[:, :1]
    all_right = batch.ticks_right + offsets[:, 1:]
    if modulus:
        np.mod(all_left, modulus, out=all_left)
        np.mod(all_right, modulus, out=all_right)
    return all_left, all_right


def _measurement(
    kind: MotionKind,
    i: int,
    readings: CompassReadings,
    sig_rot: float,
    xy: NDArray[np.float64],
    outdoor: bool,
    tape: Meterstick,
    stick: Meterstick,
) -> Measurement:
    """Trial ``i``'s measurement: the compass for a turn, else the meterstick (tape outdoors)."""
    if kind in (MotionKind.ROTATION, MotionKind.PIVOT):
        return Measurement(
            instrument="compass",
            rotation=float(readings.rotation[i]),
            sigma_rotation=sig_rot,
            raw={
                "compass_initial_deg": float(readings.initial_deg[i]),
                "compass_final_deg": float(readings.final_deg[i]),
                "turns": float(readings.turns[i]),
            },
        )
    inst = "tape" if outdoor else "meterstick"
    return Measurement(
        instrument=inst,
        x=float(xy[i, 0]),
        y=float(xy[i, 1]),
        sigma_xy=(tape if outdoor else stick).sigma,
        raw={"x_m": float(xy[i, 0]), "y_m": float(xy[i, 1])},
    )


def run_protocol(
    protocol: ExperimentProtocol,
    truth: TrueParams,
    nominal: RobotParams,
    *,
    terrain: str | None = None,
    seed: int = 0,
    progress: Progress | None = None,
) -> list[Trial]:
    """Run every trial of ``protocol`` on the virtual robot (all at once) and measure it.

    ``terrain`` overrides the protocol's terrains. Returns one :class:`~odolab.core.trials.Trial` per
    trial, in protocol order: ``predicted`` = final pose of :func:`odolab.core.odometry.integrate`
    over the trial's own encoder log with ``nominal``; ``measured`` = the instruments' reading;
    ``true`` = the true final pose (tape frame); ``encoder_log`` = raw counters at the report rate.
    A trial that stalled (turn in place where the ground does not allow it) is EXCLUDED.
    """
    report = progress or no_progress
    if terrain is not None:
        get_terrain(terrain, where="terrain override")
    specs = protocol.trials
    n = len(specs)
    rng = np.random.default_rng(seed)
    terrains = [terrain or s.terrain for s in specs]
    batch = _simulate(protocol, truth, nominal, terrains, rng)
    modulus = nominal.encoder_modulus
    all_left, all_right = _raw_counters(batch, modulus, rng)
    h0 = batch.start_heading
    fx, fy, fh = batch.final_pose.T
    # instruments, vectorized over all trials (only the relevant readings are kept per trial)
    readings = protocol.instruments.compass.read_rotation(h0, fh, rng)
    stick = protocol.instruments.meterstick
    tape = protocol.instruments.tape
    outdoor = np.array([get_terrain(name).outdoor for name in terrains], dtype=bool)
    xy_true = np.stack([fx, fy], axis=1)
    xy_stick = stick.read(xy_true, rng)
    xy_tape = tape.read(xy_true, rng)
    xy = np.where(outdoor[:, None], xy_tape, xy_stick)
    sig_rot = math.sqrt(2.0) * protocol.instruments.compass.sigma

    counters: dict[str, int] = {}
    out: list[Trial] = []
    for i, spec in enumerate(specs):
        m = int(batch.n_samples[i])
        t = np.arange(m, dtype=np.float64) / protocol.report_rate
        log = EncoderLog(t, all_left[i, :m], all_right[i, :m], modulus)
        pred = integrate(t, log.left_ticks, log.right_ticks, nominal).final
        true = _pose(float(t[-1]), float(fx[i]), float(fy[i]), float(fh[i]))
        meas = _measurement(
            spec.command.kind, i, readings, sig_rot, xy, bool(outdoor[i]), tape, stick
        )
        campaign = _campaign_on(spec.campaign, spec.terrain, terrains[i])
        idx = counters.get(campaign, 0)
        counters[campaign] = idx + 1
        stalled = bool(batch.stalled[i])
        out.append(
            Trial(
                trial_id=f"{campaign}-{idx:03d}",
                campaign=campaign,
                terrain=terrains[i],
                command=spec.command,
                predicted=pred,
                params=nominal,
                measured=meas,
                true=true,
                encoder_log=log,
                status=TrialStatus.EXCLUDED if stalled else TrialStatus.MEASURED,
                exclusion_reason=(
                    f"robot stalled: a tracked robot cannot turn in place on {terrains[i]}"
                    if stalled
                    else None
                ),
                notes=f"simulated ({truth.name}, seed {seed}); start misalignment {h0[i]:+.5f} rad",
            )
        )
        report(i + 1, n, protocol.name)
    return out


def true_final_poses(trials: Sequence[Trial]) -> NDArray[np.float64]:
    """True final (x, y, heading) of simulated trials, shape (n, 3)."""
    rows = []
    for t in trials:
        if t.true is None:
            raise SimError(f"trial {t.trial_id} has no true pose (not simulated)")
        rows.append((t.true.x, t.true.y, t.true.heading))
    return np.array(rows, dtype=np.float64).reshape(-1, 3)
