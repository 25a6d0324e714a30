"""One typed, validated configuration for a robot run, with physical bounds.

:class:`RunConfig` holds every setting of a run (loop rate, speeds, timeouts, watchdog, channels,
signs, deceleration). It is checked completely when it is built, before anything is sent to a
robot: a value out of its bounds raises :class:`RobotConfigError` with one sentence naming the
setting (its ``option`` field: a face words it as its flag or form field), the value and the
accepted range. :func:`check_motion` does the same for the
size and speed of a motion. The bounds are in :data:`BOUNDS` (and docs/robot.md, "Safety").
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, fields
from enum import StrEnum

from odolab.core.defaults import DEFAULT_MAX_WHEEL_SPEED
from odolab.core.errors import OPTION_NAMES, opt
from odolab.core.params import RobotParams
from odolab.core.trials import EXPLORE_DISTRIBUTIONS, Command, Exploration, MotionKind
from odolab.robot.errors import RobotConfigError

__all__ = [
    "BOUNDS",
    "EXPLORE_BOUNDS",
    "Bound",
    "CommandMode",
    "RunConfig",
    "check_bound",
    "check_motion",
    "check_signs",
]


class CommandMode(StrEnum):
    """How drive commands are sent."""

    PWM = "pwm"  #: all-channel PWM, type 6
    VELOCITY = "velocity"  #: all-channel velocity, type 27


@dataclass(frozen=True)
class Bound:
    """An accepted closed range [lo, hi] (open at lo when ``lo_open``) of one setting: ``option``
    is its library name (an :data:`odolab.core.errors.OPTION_NAMES` key) or, for a setting no face
    sets, words."""

    option: str
    lo: float
    hi: float
    unit: str
    lo_open: bool = False

    def describe(self) -> str:
        left = "(" if self.lo_open else "["
        return f"{left}{self.lo:g}, {self.hi:g}] {self.unit}".rstrip()


def check_bound(bound: Bound, value: float) -> float:
    """``value`` as a float if finite and inside ``bound``; else :class:`RobotConfigError`."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    inside = math.isfinite(v) and (v > bound.lo if bound.lo_open else v >= bound.lo)
    if not (inside and v <= bound.hi):
        named = bound.option in OPTION_NAMES
        raise RobotConfigError(
            f"{opt(bound.option) if named else bound.option} is {_show(value)}; expected a "
            f"number in {bound.describe()}",
            option=bound.option if named else None,
            value=value,
            allowed=bound.describe(),
        )
    return v


def _show(value: object) -> str:
    """A refused value as given: short (``1e+09``) where that is exact, else every digit
    (``4.9999999`` was refused as ``5``, a value inside the bound)."""
    if isinstance(value, float | int) and not isinstance(value, bool):
        short = f"{value:g}"
        if not math.isfinite(value) or float(short) == value:
            return short
        return repr(float(value))
    return repr(value)


#: The physical bounds of every numeric setting (field name -> bound). Rates below 5 Hz would
#: leave a robot at full speed for more than 0.2 s between commands (and let a board with a
#: 0.5 s command timeout stop between two of them); the maximum wheel speed of the Jaguars is
#: about 1.5 m/s.
BOUNDS: dict[str, Bound] = {
    "rate": Bound("rate", 5.0, 1000.0, "Hz"),
    "max_wheel_speed": Bound("max_wheel_speed", 0.0, 3.0, "m/s", lo_open=True),
    "watchdog": Bound("watchdog", 0.05, 2.0, "s"),
    "link_timeout": Bound("link_timeout", 0.1, 60.0, "s"),
    "stall_timeout": Bound("stall_timeout", 0.2, 60.0, "s"),
    "command_timeout": Bound("command_timeout", 0.05, 5.0, "s"),
    "decel": Bound("decel", 0.0, 100.0, "m or rad"),
    "settle": Bound("settle", 0.0, 10.0, "s"),
    "connect_timeout": Bound("connect_timeout", 0.1, 60.0, "s"),
}
_CHANNELS = ("left_channel", "right_channel")
_SIGNS = ("left_encoder_sign", "right_encoder_sign", "left_motor_sign", "right_motor_sign")


def _option(name: str) -> str:
    return opt(name)


@dataclass(frozen=True)
class RunConfig:
    """Every setting of one robot run; refused on construction when out of bounds.

    Times in s, speeds in m/s, ``rate`` in Hz. ``command_timeout`` is the board's: a virtual
    board started for the run stops its motors when no valid motor command came for that long
    (a real board has its own). ``link_timeout``: give up (stopped, non-zero exit) after the
    link has been lost that long. ``stall_timeout``: give up when the wheels are commanded and
    sensor data arrives but the counters do not move for that long.
    """

    rate: float = 20.0
    mode: CommandMode = CommandMode.PWM
    max_wheel_speed: float = DEFAULT_MAX_WHEEL_SPEED
    watchdog: float = 0.5
    link_timeout: float = 5.0
    stall_timeout: float = 3.0
    command_timeout: float = 0.5
    decel: float = 0.0
    settle: float = 0.5
    connect_timeout: float = 2.0
    left_channel: int = 0
    right_channel: int = 1
    left_encoder_sign: int = 1
    right_encoder_sign: int = 1
    left_motor_sign: int = 1
    right_motor_sign: int = 1

    def __post_init__(self) -> None:
        for name, bound in BOUNDS.items():
            object.__setattr__(self, name, check_bound(bound, getattr(self, name)))
        try:
            object.__setattr__(self, "mode", CommandMode(self.mode))
        except ValueError as err:
            raise RobotConfigError(
                option="mode",
                value=self.mode,
                allowed=f"one of {', '.join(m.value for m in CommandMode)}",
            ) from err
        for name in _CHANNELS:
            if getattr(self, name) not in (0, 1) or isinstance(getattr(self, name), bool):
                raise RobotConfigError(
                    f"{_option(name)} is {getattr(self, name)!r}; expected 0 or 1 (the motor "
                    "sensor packet reports the encoders of motors 0 and 1 only)"
                )
        if self.left_channel == self.right_channel:
            raise RobotConfigError(
                f"{opt('left_channel')} and {opt('right_channel')} are both {self.left_channel}; "
                "expected one "
                "track on channel 0 and the other on channel 1"
            )
        check_signs(self, _SIGNS, label=_option)
        period = 1.0 / self.rate
        if self.watchdog < 2.0 * period:
            raise RobotConfigError(
                f"{opt('watchdog')} is {self.watchdog:g} s, shorter than two loop cycles at "
                f"{opt('rate')} "
                f"{self.rate:g} Hz ({2 * period:g} s); expected a longer watchdog or a higher rate"
            )
        if self.link_timeout < self.watchdog:
            raise RobotConfigError(
                f"{opt('link_timeout')} is {self.link_timeout:g} s, shorter than "
                f"{opt('watchdog')} "
                f"{self.watchdog:g} s; expected at least the watchdog time"
            )
        if self.command_timeout < 2.0 * period:
            raise RobotConfigError(
                f"{opt('command_timeout')} is {self.command_timeout:g} s, shorter than two loop "
                f"cycles at {opt('rate')} {self.rate:g} Hz ({2 * period:g} s): the board would stop between "
                "commands; expected a longer timeout or a higher rate"
            )

    @property
    def period(self) -> float:
        """One loop cycle, s."""
        return 1.0 / self.rate

    def to_dict(self) -> dict[str, float | int | str]:
        """The settings as plain values (saved with every run)."""
        out: dict[str, float | int | str] = {}
        for f in fields(self):
            v = getattr(self, f.name)
            out[f.name] = v.value if isinstance(v, CommandMode) else v
        return out


#: Limits on the size of one motion (a typo of a factor 1000 is refused, not driven).
MOTION_BOUNDS: dict[str, Bound] = {
    "distance": Bound("distance", 0.0, 100.0, "m (absolute value, not 0)", lo_open=True),
    "side": Bound("side", 0.0, 50.0, "m", lo_open=True),
    "turns": Bound("turns", 0.0, 100.0, "turns (absolute value, not 0)", lo_open=True),
    "degrees": Bound("degrees", 0.0, 36000.0, "degrees (absolute value, not 0)", lo_open=True),
}


def check_signs(obj: object, names: tuple[str, ...], *, label: Callable[[str], str] = str) -> None:
    """Each of ``obj``'s attributes ``names`` is a motor or encoder sign: 1 or -1 (not a bool);
    else one sentence naming it (as ``label(name)``: an option, a field)."""
    for name in names:
        value = getattr(obj, name)
        if value not in (1, -1) or isinstance(value, bool):
            raise RobotConfigError(f"{label(name)} is {value!r}; expected 1 or -1")


#: Limits of an exploration's settings (its speeds are bounded by the run's, see check_motion).
EXPLORE_BOUNDS: dict[str, Bound] = {
    "seconds": Bound("seconds", 0.0, 600.0, "s", lo_open=True),
    "fence": Bound("fence", 0.0, 100.0, "m (radius about the start)", lo_open=True),
    "hold": Bound("hold", 0.0, 60.0, "s", lo_open=True),
}


def check_exploration(
    e: Exploration,
    params: RobotParams,
    max_wheel_speed: float,
    limit: str = opt("max_wheel_speed"),
) -> None:
    """Each setting of an exploration, one sentence naming its option: on a robot
    (:func:`check_motion`, ``limit`` its ``--max-wheel-speed``) and on the simulator (``odolab
    sim explore``, up to the largest wheel speed odolab drives)."""
    check_bound(EXPLORE_BOUNDS["seconds"], e.seconds)
    vmax = max_wheel_speed
    if e.max_speed is None:
        raise RobotConfigError(
            f"{opt('max_speed')} is missing; expected a number of m/s",
            option="max_speed",
            allowed="a number of m/s",
        )
    v = check_bound(
        Bound("max_speed", 0.0, vmax, f"m/s ({limit} {vmax:g} m/s)", lo_open=True),
        e.max_speed,
    )
    if e.max_turn_rate is None:
        raise RobotConfigError(
            f"{opt('max_turn_rate')} is missing; expected a number of rad/s",
            option="max_turn_rate",
            allowed="a number of rad/s",
        )
    turn = v / (0.5 * params.track_width)
    check_bound(
        Bound(
            "max_turn_rate",
            0.0,
            turn,
            f"rad/s (a turn in place with both tracks at {opt('max_speed')} {v:g} m/s)",
            lo_open=True,
        ),
        e.max_turn_rate,
    )
    hold = e.hold
    if not (isinstance(hold, tuple | list) and len(hold) == 2):
        raise RobotConfigError(option="hold", value=hold, allowed="LOW,HIGH seconds, e.g. 1,3")
    lo = check_bound(EXPLORE_BOUNDS["hold"], hold[0])
    hi = check_bound(EXPLORE_BOUNDS["hold"], hold[1])
    if lo > hi:
        raise RobotConfigError(
            f"{opt('hold')} is {lo:g},{hi:g}; expected LOW,HIGH seconds with 0 < LOW <= HIGH",
            option="hold",
            value=hold,
            allowed="LOW,HIGH seconds with 0 < LOW <= HIGH",
        )
    check_bound(EXPLORE_BOUNDS["fence"], e.fence)
    if e.distribution not in EXPLORE_DISTRIBUTIONS:
        raise RobotConfigError(
            option="distribution",
            value=e.distribution,
            allowed=f"one of {', '.join(EXPLORE_DISTRIBUTIONS)}",
        )
    if isinstance(e.seed, bool) or not isinstance(e.seed, int) or e.seed < 0:
        raise RobotConfigError(option="explore_seed", value=e.seed, allowed="a whole number >= 0")


def _check_exploration(e: Exploration, config: RunConfig, params: RobotParams) -> None:
    """Each setting of an exploration, one sentence naming its option (see check_motion)."""
    check_exploration(e, params, config.max_wheel_speed)
    if config.decel != 0:
        raise RobotConfigError(
            f"{opt('decel')} is {config.decel:g}; an exploration has no target to slow down to "
            "(its commands change at once, as drawn); expected 0",
            option="decel",
            value=config.decel,
            allowed="0",
        )


def check_motion(command: Command, config: RunConfig, params: RobotParams) -> None:
    """Refuse a motion whose size or speed is not finite, zero, or beyond what the robot can do.

    Speeds must be positive and reachable within ``config.max_wheel_speed``: m/s for straight
    runs and the square's sides, rad/s for rotations (wheel speed = rate * track / 2) and pivots
    (rate * track). An exploration: ``--seconds`` in (0, 600], ``--max-speed`` in (0,
    ``--max-wheel-speed``], ``--max-turn-rate`` in (0, a turn in place at ``--max-speed``],
    ``--hold`` 0 < LOW <= HIGH <= 60 s, ``--fence`` in (0, 100] m, a known ``--distribution``,
    ``--explore-seed`` >= 0, no ``--decel``. The error names the setting (``option``).
    """
    kind = command.kind
    if command.explore is not None:
        if kind is not MotionKind.FREE:
            raise RobotConfigError(
                f"a {kind.value} command cannot carry an exploration; expected a free one"
            )
        _check_exploration(command.explore, config, params)
        return
    if kind is MotionKind.TRANSLATION:
        size_option, size = "distance", abs(_num(command.distance, "distance"))
    elif kind is MotionKind.ROTATION:
        turns = _num(command.angle, "turns") / (2.0 * math.pi)
        size_option, size = "turns", abs(turns)
    elif kind is MotionKind.PIVOT:
        size_option, size = "degrees", abs(math.degrees(_num(command.angle, "degrees")))
    elif kind is MotionKind.SQUARE:
        size_option, size = "side", _num(command.side, "side")
    else:
        raise RobotConfigError(f"a {kind.value} command cannot be driven by odometry")
    bound = MOTION_BOUNDS[size_option]
    if not (math.isfinite(size) and bound.lo < size <= bound.hi):
        raise RobotConfigError(
            f"{opt(size_option)} is {size:g}; expected {bound.describe()}",
            option=size_option,
            value=size,
            allowed=bound.describe(),
        )
    if command.speed is None:
        return
    vmax = config.max_wheel_speed
    if kind in (MotionKind.TRANSLATION, MotionKind.SQUARE):
        limit, unit = vmax, "m/s"
    elif kind is MotionKind.ROTATION:
        limit, unit = vmax / (0.5 * params.track_width), "rad/s"
    else:
        limit, unit = vmax / params.track_width, "rad/s"
    check_bound(
        Bound(
            "speed",
            0.0,
            limit,
            f"{unit} (reachable at {opt('max_wheel_speed')} {vmax:g} m/s)",
            lo_open=True,
        ),
        command.speed,
    )


def _num(value: float | None, option: str) -> float:
    if value is None:
        raise RobotConfigError(
            f"{opt(option)} is missing; expected a number", option=option, allowed="a number"
        )
    return float(value)
