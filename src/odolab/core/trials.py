"""The experiment vocabulary shared by the simulator, the robot, the notebook and the analysis.

A *trial* is one run of one commanded motion: the robot drove "by odometry" until the nominal
model said the target was reached; the odometry's final pose is ``predicted``; a person (or an
instrument) then measured the ``actual`` motion. ``error = predicted - actual`` (the lab report's
sign) and ratios are ``actual / predicted``.

All poses are in the trial's start frame: the robot starts at the origin facing +x; y is to the
left; heading is counter-clockwise positive and unwrapped (a 20*pi rotation has heading ~62.8).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from enum import StrEnum

import numpy as np
from numpy.typing import NDArray

from odolab.core.defaults import TrialStatus  # its home is odolab.core.defaults; re-exported here
from odolab.core.errors import InvalidTrialError, StoreError
from odolab.core.motion import MotionKind  # its home is odolab.core.motion; re-exported here
from odolab.core.params import RobotParams
from odolab.core.trajectory import Pose

__all__ = [
    "EXPLORE_DISTRIBUTIONS",
    "MAX_ANGLE_RAD",
    "MAX_DISTANCE_M",
    "MAX_POSITION_M",
    "TRIAL_FIELDS",
    "Command",
    "EncoderLog",
    "Exploration",
    "FieldType",
    "Measurement",
    "MotionKind",
    "Trial",
    "TrialField",
    "TrialStatus",
    "check_direction",
    "check_field",
    "draw_exploration_value",
    "signed_command",
    "trial_field",
    "validate_trial",
]


#: How an exploration draws its commands: uniformly over what the robot can do, or three in four
#: from the outer half of each range (more data where slip is largest).
EXPLORE_DISTRIBUTIONS = ("uniform", "edges")


def draw_exploration_value(rng: np.random.Generator, limit: float, distribution: str) -> float:
    """One speed (or turn rate) of an exploration command, within ``+-limit``: uniformly, or
    (``"edges"``) three in four from the outer half of the range, either sign. The one draw of
    the live exploration (:mod:`odolab.robot.explore_motion`) and the simulator's
    (:mod:`odolab.sim.explore`)."""
    if distribution == "edges" and rng.random() < 0.75:
        sign = 1.0 if rng.random() < 0.5 else -1.0
        return float(rng.uniform(0.5, 1.0) * limit * sign)
    return float(rng.uniform(-limit, limit))


@dataclass(frozen=True)
class Exploration:
    """What an exploration drives (issue 29, after DRIVE, Baril et al. 2024): for ``seconds``,
    commands (forward speed m/s, turn rate rad/s) drawn by ``distribution`` within
    ``|v| <= max_speed``, ``|w| <= max_turn_rate`` and both track speeds within ``max_speed``,
    each held for a time drawn uniformly in ``hold`` (s), inside a circle of ``fence`` m about
    the start (by odometry, a hard limit), from the random ``seed``.

    ``max_speed`` / ``max_turn_rate`` None: not chosen yet (the robot layer fills them in from
    the run's limits and says so). Validated by :func:`odolab.robot.config.check_motion`.
    """

    seconds: float = 60.0
    max_speed: float | None = None
    max_turn_rate: float | None = None
    hold: tuple[float, float] = (1.0, 3.0)
    fence: float = 3.0
    distribution: str = "uniform"
    seed: int = 0

    def describe(self) -> str:
        """One line, e.g. '60 s, speeds up to 0.5 m/s, turn rates up to 1 rad/s, ...'."""
        v = "?" if self.max_speed is None else f"{self.max_speed:g}"
        w = "?" if self.max_turn_rate is None else f"{self.max_turn_rate:g}"
        return (
            f"{self.seconds:g} s, speeds up to {v} m/s, turn rates up to {w} rad/s, each held "
            f"{self.hold[0]:g}-{self.hold[1]:g} s, drawn {self.distribution} (seed {self.seed}), "
            f"fence {self.fence:g} m about the start"
        )


@dataclass(frozen=True)
class Command:
    """A commanded motion. Angles in rad (ccw positive), distances in m (negative = reverse)."""

    kind: MotionKind
    angle: float | None = None
    distance: float | None = None
    side: float | None = None
    direction: str | None = None  #: "cw"/"ccw" for a square; "left"/"right" track held for pivot
    speed: float | None = None  #: commanded speed, m/s (translation) or rad/s (rotation)
    #: an exploration (a FREE command, :meth:`exploration`): what it drives
    explore: Exploration | None = None

    def __post_init__(self) -> None:
        # a translation's direction word, said once in one spelling: "Reverse " is "reverse"
        if self.kind is MotionKind.TRANSLATION and isinstance(self.direction, str):
            word = self.direction.strip().lower()
            object.__setattr__(self, "direction", word or None)

    @classmethod
    def exploration(cls, spec: Exploration) -> Command:
        """The command of an exploration: a free motion (not one of Table I's kinds, so the
        notebook's kinds and every analysis stay as they are) that carries its settings."""
        return cls(MotionKind.FREE, explore=spec)

    @property
    def label(self) -> str:
        """The motion's name in run ids and folders: ``explore`` or the kind."""
        return "explore" if self.explore is not None else self.kind.value

    def to_dict(self) -> dict[str, object]:
        """``kind`` (its name), ``angle``, ``distance``, ``side``, ``direction``, ``speed``: the
        command as the notebook's ``trials`` row and the JSON API hold it (an exploration's
        settings are not among them)."""
        return {
            "kind": self.kind.value,
            "angle": self.angle,
            "distance": self.distance,
            "side": self.side,
            "direction": self.direction,
            "speed": self.speed,
        }

    def describe(self) -> str:
        """Short human text, e.g. 'rotation 20.0 pi', 'translation -2.5 m' or 'explore 60 s'."""
        if self.explore is not None:
            return f"explore {self.explore.seconds:g} s"
        if self.kind.turns_in_place and self.angle is not None:
            return f"{self.kind.value} {self.angle / math.pi:g} pi"
        if self.kind is MotionKind.TRANSLATION and self.distance is not None:
            return f"translation {self.distance:g} m"
        if self.kind is MotionKind.SQUARE and self.side is not None:
            return f"square {self.side:g} m {self.direction or ''}".rstrip()
        return self.kind.value


@dataclass(frozen=True)
class Measurement:
    """What an instrument says the robot actually did, in the start frame, with uncertainty.

    For a rotation: ``rotation`` is the total heading change (rad, unwrapped: compass difference
    plus counted whole turns). For a translation or a square: ``x``, ``y`` (m). ``raw`` keeps the
    readings as typed (e.g. ``compass_initial_deg``, ``compass_final_deg``, ``turns``).
    """

    instrument: str
    rotation: float | None = None
    x: float | None = None
    y: float | None = None
    sigma_rotation: float | None = None
    sigma_xy: float | None = None
    raw: Mapping[str, float] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class EncoderLog:
    """Raw encoder counters of one trial: ``t`` (s) and counters as the robot reported them."""

    t: NDArray[np.float64]
    left_ticks: NDArray[np.int64]
    right_ticks: NDArray[np.int64]
    modulus: int | None = None

    def __len__(self) -> int:
        return int(self.t.size)


@dataclass(frozen=True, eq=False)
class Trial:
    """One run of one commanded motion, with its prediction and (once known) its measurement."""

    trial_id: str
    campaign: str
    terrain: str
    command: Command
    predicted: Pose
    params: RobotParams
    measured: Measurement | None = None
    true: Pose | None = None  #: known only in simulation
    encoder_log: EncoderLog | None = None
    status: TrialStatus = TrialStatus.AWAITING
    exclusion_reason: str | None = None
    notes: str = ""


# -- the trial record: one definition of every field ---------------------------------------------

#: Largest measured position (m) a person reads with a meterstick or tape: a lab floor or a
#: sidewalk (``odolab trials add`` and every import refuse more: centimetres typed as metres).
MAX_POSITION_M = 100.0
#: Largest commanded, predicted or true distance/position of one trial (m).
MAX_DISTANCE_M = 1.0e4
#: Largest commanded angle or unwrapped heading of one trial (rad), about 1,600 turns.
MAX_ANGLE_RAD = 1.0e4
#: Largest time stamp of a pose (s): a robot clock or a Unix time.
_MAX_TIME_S = 1.0e10
#: Largest commanded speed (m/s or rad/s).
_MAX_SPEED = 100.0


class FieldType(StrEnum):
    """How a trial-record field is stored."""

    TEXT = "text"
    NUMBER = "number"
    INTEGER = "integer"
    JSON = "json"  #: a mapping of raw readings (JSON text in SQL and CSV ``raw_<key>`` columns)


_SQL_TYPES = {
    FieldType.TEXT: "TEXT",
    FieldType.NUMBER: "REAL",
    FieldType.INTEGER: "INTEGER",
    FieldType.JSON: "TEXT",
}


@dataclass(frozen=True)
class TrialField:
    """One field of the trial record and every name it has.

    ``name`` is the SQL column of ``trials`` and the JSON key; ``csv`` the CSV header (the unit in
    the name); ``unit`` the SI unit (``""`` a number without unit, None for text); ``low`` and
    ``high`` the plausible range (inclusive), checked by :func:`validate_trial` for every way a
    trial comes in (the robot, ``odolab trials add``, CSV and JSON import).
    """

    name: str
    type: FieldType
    unit: str | None
    csv: str
    doc: str
    required: bool = False
    low: float | None = None
    high: float | None = None

    @property
    def json_key(self) -> str:
        """The key of this field in the notebook's JSON export."""
        return self.name

    @property
    def sql_type(self) -> str:
        """Its SQLite column type."""
        return _SQL_TYPES[self.type]

    @property
    def numeric(self) -> bool:
        """Whether the field holds a number."""
        return self.type in (FieldType.NUMBER, FieldType.INTEGER)


def _num(name: str, unit: str, csv: str, doc: str, low: float, high: float, *,
         required: bool = False, integer: bool = False) -> TrialField:  # fmt: skip
    kind = FieldType.INTEGER if integer else FieldType.NUMBER
    return TrialField(name, kind, unit, csv, doc, required, low, high)


def _text(name: str, doc: str, *, required: bool = False) -> TrialField:
    return TrialField(name, FieldType.TEXT, None, name, doc, required)


def _pose_fields(prefix: str, what: str, *, required: bool) -> tuple[TrialField, ...]:
    return (
        _num(f"{prefix}_t", "s", f"{prefix}_t_s", f"time of the {what} pose", -_MAX_TIME_S,
             _MAX_TIME_S),
        _num(f"{prefix}_x", "m", f"{prefix}_x_m", f"{what} x", -MAX_DISTANCE_M, MAX_DISTANCE_M,
             required=required),
        _num(f"{prefix}_y", "m", f"{prefix}_y_m", f"{what} y", -MAX_DISTANCE_M, MAX_DISTANCE_M,
             required=required),
        _num(f"{prefix}_theta", "rad", f"{prefix}_theta_rad", f"{what} heading wrapped to "
             "(-pi, pi]", -math.pi, math.pi),
        _num(f"{prefix}_heading", "rad", f"{prefix}_heading_rad", f"{what} heading, unwrapped",
             -MAX_ANGLE_RAD, MAX_ANGLE_RAD, required=required),
    )  # fmt: skip


#: Every field of a stored trial, in the order of the ``trials`` table (time stamps left out).
TRIAL_FIELDS: tuple[TrialField, ...] = (
    _text("trial_id", "unique text", required=True),
    _text("campaign", "the campaign it belongs to", required=True),
    _text("terrain", "where, e.g. lab, concrete, grass", required=True),
    _text("kind", "rotation, translation, pivot, square or free", required=True),
    _num("angle", "rad", "angle_rad", "commanded angle (ccw positive)", -MAX_ANGLE_RAD,
         MAX_ANGLE_RAD),
    _num("distance", "m", "distance_m", "commanded distance (negative = reverse)",
         -MAX_DISTANCE_M, MAX_DISTANCE_M),
    _num("side", "m", "side_m", "square side", 0.0, MAX_DISTANCE_M),
    _text("direction", "cw/ccw (square), left/right (pivot)"),
    _num("speed", "", "speed", "commanded speed (m/s, or rad/s for a rotation)", -_MAX_SPEED,
         _MAX_SPEED),
    *_pose_fields("predicted", "odometry's final", required=True),
    _text("robot", "robot name", required=True),
    _num("params_version", "", "params_version", "the parameter version of the prediction", 1,
         2**62, integer=True),
    _text("instrument", "what measured it, e.g. compass, meterstick"),
    _num("measured_rotation", "rad", "measured_rotation_rad", "actual rotation, unwrapped",
         -MAX_ANGLE_RAD, MAX_ANGLE_RAD),
    _num("measured_x", "m", "measured_x_m", "actual x (start frame)", -MAX_POSITION_M,
         MAX_POSITION_M),
    _num("measured_y", "m", "measured_y_m", "actual y (start frame)", -MAX_POSITION_M,
         MAX_POSITION_M),
    _num("sigma_rotation", "rad", "sigma_rotation_rad", "standard uncertainty of the rotation",
         0.0, math.pi),
    _num("sigma_xy", "m", "sigma_xy_m", "standard uncertainty of x and y", 0.0, MAX_POSITION_M),
    TrialField("raw", FieldType.JSON, None, "raw_<key>", "readings as typed"),
    *_pose_fields("true", "true", required=False),
    _text("status", "awaiting, measured or excluded", required=True),
    _text("exclusion_reason", "why an excluded trial is left out"),
    _text("notes", "free text"),
)  # fmt: skip

_BY_NAME = {f.name: f for f in TRIAL_FIELDS}

#: The raw readings of a compass measurement, with their plausible ranges (deg, deg, count).
COMPASS_RAW: dict[str, tuple[float, float]] = {
    "compass_initial_deg": (0.0, math.nextafter(360.0, 0.0)),
    "compass_final_deg": (0.0, math.nextafter(360.0, 0.0)),
    "turns": (0.0, MAX_ANGLE_RAD / (2.0 * math.pi)),
}


def trial_field(name: str) -> TrialField:
    """The field called ``name`` (its SQL column / JSON key)."""
    return _BY_NAME[name]


def _unit_text(f: TrialField, value: float) -> str:
    return f"{value:g} {f.unit}".rstrip()


def check_field(name: str, value: object, where: str) -> None:
    """Refuse (:class:`InvalidTrialError`) a value of field ``name`` that is not plausible.

    ``None`` passes unless the field is required; numbers must be finite and in the field's
    range; text must be text.
    """
    f = _BY_NAME[name]
    if value is None:
        if f.required:
            raise InvalidTrialError(f"{where}: {name} is missing", name)
        return
    if f.type is FieldType.TEXT:
        if not isinstance(value, str):
            raise InvalidTrialError(f"{where}: {name} must be text, got {value!r}", name)
        return
    if not f.numeric:
        return
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InvalidTrialError(f"{where}: {name} must be a finite number, got {value!r}", name)
    if f.type is FieldType.INTEGER and not float(value).is_integer():
        raise InvalidTrialError(f"{where}: {name} must be a whole number, got {value!r}", name)
    assert f.low is not None and f.high is not None
    if not f.low <= value <= f.high:
        raise InvalidTrialError(
            f"{where}: {name} is {_unit_text(f, float(value))}; expected "
            f"{_unit_text(f, f.low)} to {_unit_text(f, f.high)}",
            name,
        )


def _check_text(value: object, name: str, where: str) -> None:
    if not isinstance(value, str) or not value.strip():
        raise InvalidTrialError(f"{where}: {name} must be non-empty text, got {value!r}", name)


def check_no_nul(
    value: object, name: str, where: str, error: type[StoreError] = InvalidTrialError
) -> None:
    """Refuse text with a NUL character, at every way into the notebook, as the CSV import
    does (one stored through the web's API made the notebook's CSV export unreadable)."""
    if isinstance(value, str) and "\x00" in value:
        at = value.index("\x00") + 1
        message = (
            f"{where}: {name} has a NUL character (character {at}); expected text without "
            "NUL characters"
        )
        raise InvalidTrialError(message, name) if error is InvalidTrialError else error(message)


def _check_command(c: Command, where: str) -> None:
    if not isinstance(c.kind, MotionKind):
        raise InvalidTrialError(f"{where}: command kind {c.kind!r} is not a MotionKind", "kind")
    if c.explore is not None:  # the notebook has no column for its settings: never dropped
        raise InvalidTrialError(
            f"{where}: an exploration's settings have no place in the notebook (it is not a "
            "Table I trial; its log and ground truth stay in its run folder); expected the "
            "excluded free run that odolab robot explore {{db}} records, its settings in the notes",
            "kind",
        )
    for name in ("angle", "distance", "side", "speed"):
        check_field(name, getattr(c, name), where)
    need = c.kind.needs
    if need is not None and getattr(c, need) is None:
        raise InvalidTrialError(f"{where}: a {c.kind.value} command needs its {need}", need)
    words = TRANSLATION_DIRECTIONS
    if c.kind is MotionKind.TRANSLATION and c.direction not in (None, *words):
        raise InvalidTrialError(
            f"{where}: direction {c.direction!r} is not a translation's direction; expected "
            f"{' or '.join(repr(w) for w in words)} (or none: the distance's sign says which way)",
            "direction",
        )


#: A translation's ``direction`` words; without one, the distance's sign says which way.
TRANSLATION_DIRECTIONS = ("forward", "reverse")


def signed_command(command: Command) -> Command:
    """The command with a translation's distance signed by its ``direction``: a row that says
    ``direction = reverse`` with a positive distance is the same run as one with a negative
    distance (the two sign conventions of a spreadsheet), so every analysis, which goes by the
    sign, reads it as a reverse run. Every other command as it is. The notebook writes and reads
    every trial through this (:meth:`odolab.store.notebook.Notebook.add_trials`,
    :func:`odolab.store.records.trial_from_record`), after :func:`validate_trial` checked the
    words against the numbers (:func:`check_direction`). The word is already in one spelling
    (:class:`Command` lowercases it)."""
    if (
        command.kind is MotionKind.TRANSLATION
        and command.direction == "reverse"
        and command.distance is not None
        and command.distance > 0
    ):
        return replace(command, distance=-command.distance)
    return command


def check_direction(trial: Trial) -> None:
    """Refuse (:class:`InvalidTrialError`, naming the field) a translation whose ``direction``
    contradicts its numbers: ``forward`` with a negative distance, or a predicted or measured x
    on the other side of the start than the direction says by more than half the distance (a
    reverse run ends behind its start, x < 0, in its start frame). Without a direction word the
    distance's sign is the convention, and nothing is checked."""
    c = trial.command
    if c.kind is not MotionKind.TRANSLATION or c.direction not in TRANSLATION_DIRECTIONS:
        return
    where = f"trial {trial.trial_id}"
    d = c.distance
    if d is None:
        return
    if c.direction == "forward" and d < 0:
        raise InvalidTrialError(
            f"{where}: direction 'forward' with a distance of {d:g} m (a negative distance is a "
            "reverse run); expected a positive distance, or direction 'reverse'",
            "direction",
        )
    sign = -1.0 if c.direction == "reverse" else 1.0
    xs = [("predicted_x", trial.predicted.x)]
    if trial.measured is not None and trial.measured.x is not None:
        xs.append(("measured_x", trial.measured.x))
    for name, x in xs:
        if x * sign < 0 and abs(x) > 0.5 * abs(d):
            raise InvalidTrialError(
                f"{where}: a {c.direction} run of {abs(d):g} m ends "
                f"{'ahead of' if x > 0 else 'behind'} its start ({name.replace('_', ' ')} "
                f"{x:g} m); expected x {'< 0' if sign < 0 else '> 0'} (start frame: a reverse "
                "run ends behind its start), or the other direction",
                name,
            )


def _check_pose(pose: Pose | None, prefix: str, where: str) -> None:
    if pose is None:
        if prefix == "predicted":
            raise InvalidTrialError(f"{where}: predicted pose is missing", "predicted_x")
        return
    for name in Pose._fields:
        value = getattr(pose, name)
        if value is None:
            raise InvalidTrialError(f"{where}: {prefix} {name} is missing", f"{prefix}_{name}")
        check_field(f"{prefix}_{name}", value, where)


def _check_measurement(m: Measurement, where: str) -> None:
    if not isinstance(m.instrument, str) or not m.instrument.strip():
        raise InvalidTrialError(
            f"{where}: measurement instrument must be non-empty text", "instrument"
        )
    for name in ("rotation", "x", "y"):
        check_field(f"measured_{name}", getattr(m, name), where)
    for name in ("sigma_rotation", "sigma_xy"):
        check_field(name, getattr(m, name), where)
    if m.rotation is None and m.x is None and m.y is None:
        raise InvalidTrialError(
            f"{where}: a measurement needs a rotation or x and y", "measured_rotation"
        )
    for key, v in m.raw.items():
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise InvalidTrialError(f"{where}: raw reading {key!r} must be a finite number", "raw")
        bounds = COMPASS_RAW.get(key)
        if bounds is not None and not bounds[0] <= v <= bounds[1]:
            raise InvalidTrialError(
                f"{where}: raw reading {key!r} is {v:g}; expected {bounds[0]:g} up to "
                f"{'360 (not included)' if key.startswith('compass') else f'{bounds[1]:g}'}",
                "raw",
            )


def validate_trial(trial: Trial) -> None:
    """Refuse (:class:`InvalidTrialError`, naming the trial and the field) an unstorable trial.

    Every way into the notebook calls this: the robot and the simulator, ``odolab trials add``,
    CSV and JSON import. Ranges are those of :data:`TRIAL_FIELDS`; a translation's direction word
    is ``forward``, ``reverse`` or none, and agrees with its numbers (:func:`check_direction`).
    A command that carries an
    exploration (:attr:`Command.explore`) is refused: the notebook has no place for its settings
    (``odolab.robot.explore.notebook_trial`` records an exploration as an excluded free run
    with its settings in the notes).
    """
    tid = trial.trial_id
    if not isinstance(tid, str) or not tid.strip() or tid != tid.strip():
        raise InvalidTrialError(
            f"trial id {tid!r} must be non-empty text without surrounding spaces", "trial_id"
        )
    where = f"trial {tid}"
    for name, text in (
        ("trial_id", tid),
        ("campaign", trial.campaign),
        ("terrain", trial.terrain),
        ("exclusion_reason", trial.exclusion_reason),
        ("notes", trial.notes),
        ("instrument", None if trial.measured is None else trial.measured.instrument),
    ):
        check_no_nul(text, name, where)
    _check_text(trial.campaign, "campaign", where)
    _check_text(trial.terrain, "terrain", where)
    _check_command(trial.command, where)
    _check_pose(trial.predicted, "predicted", where)
    _check_pose(trial.true, "true", where)
    m = trial.measured
    if m is not None:
        _check_measurement(m, where)
    check_direction(trial)
    status = TrialStatus(trial.status)
    if status is TrialStatus.MEASURED and m is None:
        raise InvalidTrialError(f"{where}: status 'measured' but no measurement", "status")
    if status is TrialStatus.AWAITING and m is not None:
        raise InvalidTrialError(f"{where}: status 'awaiting' but it has a measurement", "status")
    if status is TrialStatus.EXCLUDED and not (trial.exclusion_reason or "").strip():
        raise InvalidTrialError(f"{where}: an excluded trial needs a reason", "exclusion_reason")
    log = trial.encoder_log
    if log is not None and not (log.t.size == log.left_ticks.size == log.right_ticks.size):
        raise InvalidTrialError(f"{where}: encoder log arrays differ in length")
