"""The lab's open questions (section IX) as experiments, each answered with an effect size and CI.

An *experiment* file (TOML; built-ins in ``odolab/data/experiments``) lists conditions, each a
motion driven by the nominal odometry on the virtual robot (:func:`odolab.sim.drives.drive`),
repeated with fresh noise, and the comparisons to make::

    [experiment]
    name = "in-place-vs-curves"
    question = "Does rotating in place slip more than turning in a wide curve?"
    repeats = 200                   # per condition (each a new seed)
    speed = 0.3                     # m/s, the faster wheel's surface speed (default)

    [[conditions]]
    label = "in place"              # unique
    motion = "rotate"               # rotate | curve | pivot | straight
    angle_deg = 180                 # rotate, curve, pivot: the heading change (sign = direction)
    # radius = 1.0                  # curve: m, of the body's path
    # held = "left"                 # pivot: the track that stands still
    # distance = 2.0                # straight: m (negative = reverse)
    # terrain = "tile"; speed = 0.3
    # stop = "abrupt"               # abrupt | gradual
    # decel = 0.5                   # gradual: s of linear slow-down before the stop

    [[effects]]                     # slip of a minus slip of b, percentage points, with a CI
    a = "in place"
    b = "curve 1 m"

    # trend = "speed"               # [experiment] key: a line of slip against speed
    # alternate = true              # [experiment] key: mirror every other repeat (turn sign,
                                    # pivot track), so a left-right difference cancels

Each repeat is measured as the lab would: a rotation by the compass (``compass_sigma`` per
reading, 0.05 rad), a distance with the meterstick (0.003 m indoors) or the tape (0.005 m
outdoors). The *slip* of a turn is ``1 - measured / predicted heading change``, of a straight run
``1 - measured / predicted distance`` (%; positive: the robot did less than its odometry says).
A turn in place on a terrain that does not allow it stalls: the condition reports the stall and
no slip. Effects are Welch differences of mean slip with their 95 % confidence interval; a trend
is a least-squares line through every repeat with the slope's 95 % CI.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from odolab.core.defaults import DEFAULT_TERRAIN
from odolab.core.errors import SimError
from odolab.core.motion import DriveShape
from odolab.core.odometry import integrate_increments
from odolab.core.params import RobotParams
from odolab.core.text import quote_input, safe_terminal
from odolab.sim.drives import Leg, drive
from odolab.sim.physics import TrueParams
from odolab.sim.protocols import (
    MAX_ANGLE_RAD,
    MAX_DISTANCE_M,
    MAX_SIDE_M,
    MAX_TRIAL_SECONDS,
    SPEED_RANGE_M_S,
    read_toml,
    toml_error,
    toml_number,
)
from odolab.sim.terrains import get_terrain

__all__ = [
    "Condition",
    "ConditionResult",
    "Effect",
    "Experiment",
    "ExperimentResult",
    "Trend",
    "builtin_experiments",
    "legs_for",
    "load_experiment",
    "parse_experiment",
    "run_experiment",
    "run_open_questions",
]

_MOTIONS = tuple(shape.value for shape in DriveShape)
_EXPERIMENT_KEYS = {"name", "question", "repeats", "speed", "trend", "alternate", "compass_sigma",
                    "meterstick_sigma", "tape_sigma"}  # fmt: skip
_CONDITION_KEYS = {"label", "motion", "angle_deg", "radius", "held", "distance", "terrain",
                   "speed", "stop", "decel"}  # fmt: skip
Progress = Callable[[int, int], None]
#: Most drives (conditions x repeats) one experiment may ask for: about 10 ms each, so some
#: 20 minutes; a typo such as ``repeats = 100000`` over many conditions is one sentence.
MAX_DRIVES = 100_000
#: Fewest encoder ticks the faster wheel must turn in a condition: below that the odometry may
#: see no motion at all, and a slip (measured / predicted) means nothing.
MIN_TICKS = 10.0


@dataclass(frozen=True)
class Condition:
    """One condition of an experiment (see the module)."""

    label: str
    motion: DriveShape
    terrain: str = DEFAULT_TERRAIN
    speed: float = 0.3
    angle: float = 0.0  #: rad
    radius: float = 0.0
    held: str = "left"
    distance: float = 0.0
    stop: str = "abrupt"
    decel: float = 0.0

    def __post_init__(self) -> None:
        where = f"condition {self.label!r}"
        object.__setattr__(self, "motion", DriveShape.parse(self.motion, where, SimError))


@dataclass(frozen=True)
class Experiment:
    """A parsed experiment file."""

    name: str
    question: str
    conditions: tuple[Condition, ...]
    effects: tuple[tuple[str, str], ...]
    repeats: int = 100
    trend: str | None = None
    #: mirror every other repeat (turns of both signs, pivots on both tracks): a left-right
    #: difference of the robot then cancels instead of passing for an effect
    alternate: bool = False
    compass_sigma: float = 0.05
    meterstick_sigma: float = 0.003
    tape_sigma: float = 0.005
    source: str = "<experiment>"


@dataclass(frozen=True)
class ConditionResult:
    """A condition's repeats: slip (%) mean and 95 % CI, or the stall."""

    condition: Condition
    n: int
    stalled: int
    slip: tuple[float, ...]  #: per repeat, % (empty when every repeat stalled)
    mean: float
    low: float
    high: float

    @property
    def label(self) -> str:
        return self.condition.label


@dataclass(frozen=True)
class Effect:
    """Mean slip of ``a`` minus that of ``b`` (percentage points) with its Welch 95 % CI."""

    a: str
    b: str
    difference: float
    low: float
    high: float

    def sentence(self) -> str:
        """The answer in words (slip: how far the robot falls short of its odometry)."""
        ci = f"95 % CI [{self.low:+.1f}, {self.high:+.1f}] percentage points"
        if self.difference >= 0:
            return f"{self.a} slips {self.difference:.1f} % more than {self.b} ({ci})"
        return (
            f"{self.a} slips {-self.difference:.1f} % less than {self.b}: it goes further for "
            f"the same counts ({ci})"
        )


@dataclass(frozen=True)
class Trend:
    """Slip (%) against a condition key: slope per unit with its 95 % CI."""

    key: str
    slope: float
    low: float
    high: float
    unit: str

    def sentence(self) -> str:
        return (
            f"slip changes by {self.slope:+.2f} % per {self.unit} of {self.key} "
            f"(95 % CI [{self.low:+.2f}, {self.high:+.2f}])"
        )


@dataclass(frozen=True)
class ExperimentResult:
    """What :func:`run_experiment` returns."""

    experiment: Experiment
    truth: str
    seed: int
    conditions: list[ConditionResult]
    effects: list[Effect]
    trend: Trend | None

    def condition(self, label: str) -> ConditionResult:
        for c in self.conditions:
            if c.label == label:
                return c
        raise KeyError(label)

    def to_dict(self) -> dict[str, object]:
        return {
            "experiment": self.experiment.name,
            "question": self.experiment.question,
            "truth": self.truth,
            "seed": self.seed,
            "conditions": [
                {
                    "label": c.label,
                    "motion": c.condition.motion.value,
                    "terrain": c.condition.terrain,
                    "n": c.n,
                    "stalled": c.stalled,
                    "slip_pct": c.mean,
                    "ci95": [c.low, c.high],
                }
                for c in self.conditions
            ],
            "effects": [
                {
                    "a": e.a,
                    "b": e.b,
                    "difference_pct": e.difference,
                    "ci95": [e.low, e.high],
                    "answer": e.sentence(),
                }
                for e in self.effects
            ],
            "trend": None
            if self.trend is None
            else {
                "key": self.trend.key,
                "slope": self.trend.slope,
                "ci95": [self.trend.low, self.trend.high],
                "answer": self.trend.sentence(),
            },
        }


# --------------------------------------------------------------------------- parsing


def _speed(source: str, where: str, value: object) -> float:
    lo, hi = SPEED_RANGE_M_S
    v = toml_number(source, where, value, positive=False)
    if not lo <= v <= hi:
        raise toml_error(
            source, where, f"expected a wheel speed from {lo:g} to {hi:g} m/s, got {v!r}"
        )
    return v


def _kind(value: object) -> str:
    """What a TOML value is, in the file's words."""
    return "a table" if isinstance(value, dict) else f"{value!r}"


def _text(source: str, where: str, value: object) -> str:
    """``value`` as text that a terminal, a JSON file and a report all show as it is."""
    text = str(value)
    if safe_terminal(text) != text:
        raise toml_error(source, where,
                   f"{quote_input(text)} has a control or invisible character; expected "
                   "plain text on one line")  # fmt: skip
    return text


def _keys(source: str, where: str, table: dict[str, object], allowed: set[str]) -> None:
    extra = sorted(set(table) - allowed)
    if extra:
        raise toml_error(source, f"{where} key {extra[0]!r}",
                   f"unknown; expected one of {', '.join(sorted(allowed))}")  # fmt: skip


def parse_experiment(doc: dict[str, object], source: str = "<experiment>") -> Experiment:
    """An :class:`Experiment` from a parsed TOML document; errors name ``source`` and the key."""
    _keys(source, "top level", doc, {"experiment", "conditions", "effects"})
    head = doc.get("experiment")
    if not isinstance(head, dict):
        raise toml_error(source, "[experiment]", "missing; expected a table with name and question")
    _keys(source, "[experiment]", head, _EXPERIMENT_KEYS)
    name = _text(source, "[experiment] key 'name'", head.get("name", Path(source).stem))
    question = _text(source, "[experiment] key 'question'", head.get("question", ""))
    repeats = head.get("repeats", 100)
    if isinstance(repeats, bool) or not isinstance(repeats, int) or not 2 <= repeats <= 100_000:
        raise toml_error(source, "[experiment] key 'repeats'",
                   f"expected an integer from 2 to 100000, got {repeats!r}")  # fmt: skip
    speed = _speed(source, "[experiment] key 'speed'", head.get("speed", 0.3))
    trend = head.get("trend")
    if trend not in (None, "speed", "radius", "decel"):
        raise toml_error(source, "[experiment] key 'trend'",
                   f"expected speed, radius or decel, got {trend!r}")  # fmt: skip
    raw = doc.get("conditions")
    if raw is not None and not isinstance(raw, list):
        raise toml_error(source, "[[conditions]]", f"expected an array of tables, got {_kind(raw)}")
    if not raw:
        raise toml_error(source, "[[conditions]]", "missing; expected at least one condition")
    conditions = [_condition(source, i, c, speed) for i, c in enumerate(raw)]
    labels = [c.label for c in conditions]
    if trend is not None:
        values = {float(getattr(c, trend)) for c in conditions}
        if len(values) < 2:
            raise toml_error(source, "[experiment] key 'trend'",
                       f"{trend} is {values.pop():g} in every condition; expected conditions "
                       f"that differ in {trend}")  # fmt: skip
    dup = sorted({x for x in labels if labels.count(x) > 1})
    if dup:
        raise toml_error(source, "[[conditions]] key 'label'", f"{dup[0]!r} is used twice")
    effects = []
    raw_effects = doc.get("effects", [])
    if not isinstance(raw_effects, list):
        raise toml_error(
            source, "[[effects]]", f"expected an array of tables, got {_kind(raw_effects)}"
        )
    for i, e in enumerate(raw_effects):
        where = f"[[effects]] #{i + 1}"
        if not isinstance(e, dict):
            raise toml_error(source, where, "expected a table with a and b")
        _keys(source, where, e, {"a", "b"})
        for key in ("a", "b"):
            if e.get(key) not in labels:
                raise toml_error(source, f"{where} key {key!r}",
                           f"expected a condition label, got {e.get(key)!r}")  # fmt: skip
        effects.append((str(e["a"]), str(e["b"])))
    alternate = head.get("alternate", False)
    if not isinstance(alternate, bool):
        raise toml_error(
            source, "[experiment] key 'alternate'", f"expected true or false, got {alternate!r}"
        )
    sig = {k: toml_number(source, f"[experiment] key {k!r}", head[k], positive=True)
           for k in ("compass_sigma", "meterstick_sigma", "tape_sigma") if k in head}  # fmt: skip
    return Experiment(
        name, question, tuple(conditions), tuple(effects), repeats,
        trend, alternate, source=source, **sig,
    )  # fmt: skip


def _condition(source: str, index: int, c: object, speed: float) -> Condition:
    where = f"[[conditions]] #{index + 1}"
    if not isinstance(c, dict):
        raise toml_error(source, where, "expected a table")
    _keys(source, where, c, _CONDITION_KEYS)
    label = c.get("label")
    if not isinstance(label, str) or not label:
        raise toml_error(source, f"{where} key 'label'", "missing; expected a non-empty name")
    _text(source, f"{where} key 'label'", label)
    motion = c.get("motion")
    if motion not in _MOTIONS:
        raise toml_error(source, f"{where} key 'motion'",
                   f"expected one of {', '.join(_MOTIONS)}, got {motion!r}")  # fmt: skip
    terrain = str(c.get("terrain", DEFAULT_TERRAIN))
    get_terrain(terrain, where=f"{source}: {where} key 'terrain'")
    kw: dict[str, Any] = {
        "terrain": terrain,
        "speed": _speed(source, f"{where} key 'speed'", c.get("speed", speed)),
    }
    shape = DriveShape(motion)
    needs = shape.needs
    for key in needs:
        if key not in c:
            raise toml_error(source, f"{where} key {key!r}", f"missing; a {motion} needs it")
    for key in ("angle_deg", "radius", "held", "distance"):
        if key in c and key not in shape.takes:
            raise toml_error(source, f"{where} key {key!r}", f"does not apply to a {motion}")
    if "angle_deg" in c:
        most = math.degrees(MAX_ANGLE_RAD)
        angle = toml_number(
            source,
            f"{where} key 'angle_deg'",
            c["angle_deg"],
            most=most,
            unit="degrees",
            positive=False,
        )
        if angle == 0:
            raise toml_error(source, f"{where} key 'angle_deg'", "expected a non-zero angle")
        kw["angle"] = math.radians(angle)
    if "radius" in c:
        kw["radius"] = toml_number(
            source, f"{where} key 'radius'", c["radius"], positive=True, most=MAX_SIDE_M, unit="m"
        )
    if "distance" in c:
        kw["distance"] = toml_number(
            source,
            f"{where} key 'distance'",
            c["distance"],
            most=MAX_DISTANCE_M,
            unit="m",
            positive=False,
        )
        if kw["distance"] == 0:
            raise toml_error(source, f"{where} key 'distance'", "expected a non-zero distance")
    if "held" in c:
        if c["held"] not in ("left", "right"):
            raise toml_error(
                source, f"{where} key 'held'", f"expected left or right, got {c['held']!r}"
            )
        kw["held"] = c["held"]
    stop = c.get("stop", "abrupt")
    if stop not in ("abrupt", "gradual"):
        raise toml_error(source, f"{where} key 'stop'", f"expected abrupt or gradual, got {stop!r}")
    kw["stop"] = stop
    if stop == "gradual":
        kw["decel"] = toml_number(
            source, f"{where} key 'decel'", c.get("decel", 0.5), positive=True,
            most=MAX_TRIAL_SECONDS, unit="s",
        )  # fmt: skip
    elif "decel" in c:
        raise toml_error(source, f"{where} key 'decel'", 'applies only to stop = "gradual"')
    return Condition(label, shape, **kw)


def builtin_experiments() -> dict[str, str]:
    """Built-in experiment names and their questions."""
    from odolab.sim.protocols import builtin_index

    return builtin_index("experiments", "experiment", "question")


def load_experiment(name_or_path: str | Path) -> Experiment:
    """A built-in experiment by name or an experiment TOML file (:func:`odolab.sim.protocols.read_toml`)."""
    doc, source = read_toml(
        name_or_path, folder="experiments", what="experiment", builtins=builtin_experiments
    )
    return parse_experiment(doc, source)


# --------------------------------------------------------------------------- running


def legs_for(c: Condition, nominal: RobotParams) -> list[Leg]:
    """The wheel-speed legs that make the nominal model do condition ``c``.

    The faster wheel runs at ``c.speed``; the duration is the nominal wheel travel over that
    speed. A gradual stop adds a leg that slows linearly to 0 over ``c.decel`` seconds (its
    travel is counted by the encoders like any other)."""
    if not nominal.model.is_differential_drive:
        left, right, duration = _first_leg_for_model(c, nominal)
    elif not c.motion.angular:
        sign = 1.0 if c.distance > 0 else -1.0
        left = right = sign * c.speed
        duration = abs(c.distance) / c.speed
    else:
        half = nominal.track_width / 2.0
        a = c.angle
        if c.motion is DriveShape.ROTATE:
            dl, dr = -a * half, a * half
        elif c.motion is DriveShape.CURVE:
            dl, dr = (
                abs(a) * (c.radius - math.copysign(half, a)),
                abs(a) * (c.radius + math.copysign(half, a)),
            )
        else:  # pivot: the held track stands, the other travels angle * track
            width = 2.0 * half
            dl, dr = (0.0, a * width) if c.held == "left" else (-a * width, 0.0)
        big = max(abs(dl), abs(dr))
        duration = big / c.speed
        left, right = dl / duration, dr / duration
    legs = [Leg(left, right, duration)]
    if c.stop == "gradual":
        legs.append(Leg(0.0, 0.0, c.decel, ramp=c.decel))
    return legs


def _first_leg_for_model(c: Condition, nominal: RobotParams) -> tuple[float, float, float]:
    """(left, right, duration) of :func:`legs_for` through the nominal model's coefficients (any
    linear model): the wheel travels whose body motion is the condition's forward distance and
    turn. For the differential drive this is the closed form of :func:`legs_for`."""
    w_l, w_r, e_l, e_r, den, _ = nominal.coefficients
    if c.motion is DriveShape.PIVOT:  # the held track stands, the other one turns the body alone
        dl, dr = (0.0, c.angle * den / e_r) if c.held == "left" else (-c.angle * den / e_l, 0.0)
    else:
        turn = c.angle if c.motion.angular else 0.0
        forward = {DriveShape.STRAIGHT: c.distance, DriveShape.ROTATE: 0.0}.get(
            c.motion, abs(c.angle) * c.radius
        )
        # [[w_l, w_r], [-e_l/den, e_r/den]] (ds_l, ds_r) = (forward, turn)
        det = (w_l * e_r + w_r * e_l) / den
        dl = (forward * e_r / den - w_r * turn) / det
        dr = (w_l * turn + forward * e_l / den) / det
    duration = max(abs(dl), abs(dr)) / c.speed
    return dl / duration, dr / duration, duration


def _welch(a: np.ndarray, b: np.ndarray) -> tuple[float, float, float]:
    from odolab.core.distributions import t_ppf

    d = float(a.mean() - b.mean())
    va, vb = a.var(ddof=1) / a.size, b.var(ddof=1) / b.size
    se = math.sqrt(va + vb)
    if se == 0:
        return d, d, d
    dof = (va + vb) ** 2 / (va**2 / (a.size - 1) + vb**2 / (b.size - 1))
    q = t_ppf(0.975, dof)
    return d, d - q * se, d + q * se


def _mean_ci(x: np.ndarray) -> tuple[float, float, float]:
    from odolab.core.distributions import t_ppf

    m = float(x.mean())
    if x.size < 2:
        return m, math.nan, math.nan
    h = t_ppf(0.975, x.size - 1) * float(x.std(ddof=1)) / math.sqrt(x.size)
    return m, m - h, m + h


def _check_size(experiment: Experiment, repeats: int, nominal: RobotParams) -> None:
    """Refuse, before any drive, an experiment too big to run or a condition too long or too
    short to drive (see :data:`MAX_DRIVES`, :data:`MIN_TICKS`)."""
    src = experiment.source
    count = len(experiment.conditions)
    if count * repeats > MAX_DRIVES:
        raise SimError(
            f"{src}: {count} conditions x {repeats} repeats are {count * repeats} drives; "
            f"expected at most {MAX_DRIVES} (fewer repeats)"
        )
    per_tick = max(nominal.left_metres_per_tick, nominal.right_metres_per_tick)
    for c in experiment.conditions:
        legs = legs_for(c, nominal)
        seconds = sum(leg.duration for leg in legs)
        if seconds > MAX_TRIAL_SECONDS:
            raise SimError(
                f"{src}: condition {c.label!r} would last {seconds:.0f} s; expected at most "
                f"{MAX_TRIAL_SECONDS:.0f} s (check its speed, distance, radius and angle)"
            )
        ticks = max(abs(legs[0].left), abs(legs[0].right)) * legs[0].duration / per_tick
        if ticks < MIN_TICKS:
            raise SimError(
                f"{src}: condition {c.label!r} moves the faster wheel {ticks:.1f} encoder ticks; "
                f"expected at least {MIN_TICKS:g} (a longer distance or a larger angle)"
            )


def run_experiment(
    experiment: Experiment,
    truth: TrueParams,
    nominal: RobotParams,
    *,
    seed: int = 0,
    repeats: int | None = None,
    progress: Progress | None = None,
) -> ExperimentResult:
    """Run every condition ``repeats`` times (default the file's) and answer the comparisons."""
    n = repeats if repeats is not None else experiment.repeats
    if n < 2:
        raise SimError(f"repeats must be at least 2 for a confidence interval, got {n}")
    _check_size(experiment, n, nominal)
    rng = np.random.default_rng(seed)
    total = n * len(experiment.conditions)
    done = 0
    results: list[ConditionResult] = []
    trend_x: list[float] = []
    trend_y: list[float] = []
    for c in experiment.conditions:
        mirror = replace(c, angle=-c.angle, held="right" if c.held == "left" else "left")
        plans = [(c, legs_for(c, nominal)), (mirror, legs_for(mirror, nominal))]
        terrain = get_terrain(c.terrain)
        slips: list[float] = []
        stalled = 0
        for k in range(n):
            cc, legs = plans[k % 2 if experiment.alternate and c.motion.mirrors else 0]
            d = drive(truth, nominal, legs, terrain=terrain, seed=int(rng.integers(2**31)))
            done += 1
            if progress is not None:
                progress(done, total)
            if d.stalled:
                stalled += 1
                continue
            pred = integrate_increments(d.t, d.dticks_left, d.dticks_right, nominal, "arc")
            if not c.motion.angular:  # a distance, by meterstick or tape
                sigma = experiment.tape_sigma if terrain.outdoor else experiment.meterstick_sigma
                p = math.hypot(pred.x[-1], pred.y[-1])
                m = math.hypot(d.x[-1], d.y[-1]) + sigma * float(rng.standard_normal())
            else:
                sigma = math.sqrt(2.0) * experiment.compass_sigma
                p = abs(pred.heading[-1])
                m = math.copysign(1.0, cc.angle) * d.heading[-1] + sigma * float(
                    rng.standard_normal()
                )
            slips.append(100.0 * (1.0 - m / p))
            if experiment.trend is not None:
                trend_x.append(float(getattr(c, experiment.trend)))
                trend_y.append(slips[-1])
        arr = np.array(slips)
        mean, lo, hi = _mean_ci(arr) if arr.size else (math.nan, math.nan, math.nan)
        results.append(ConditionResult(c, n, stalled, tuple(slips), mean, lo, hi))
    by_label = {r.label: r for r in results}
    effects = []
    for a, b in experiment.effects:
        ra, rb = by_label[a], by_label[b]
        if len(ra.slip) < 2 or len(rb.slip) < 2:
            continue  # a stalled condition has no slip to compare
        effects.append(Effect(a, b, *_welch(np.array(ra.slip), np.array(rb.slip))))
    trend = None
    if experiment.trend is not None and len(set(trend_x)) > 1:
        from scipy import stats

        from odolab.core.distributions import t_ppf

        fit = stats.linregress(trend_x, trend_y)
        q = t_ppf(0.975, len(trend_x) - 2)
        unit = {"speed": "m/s", "radius": "m", "decel": "s"}[experiment.trend]
        trend = Trend(experiment.trend, float(fit.slope), float(fit.slope - q * fit.stderr),
                      float(fit.slope + q * fit.stderr), unit)  # fmt: skip
    return ExperimentResult(experiment, truth.name, seed, results, effects, trend)


def run_open_questions(
    truth: TrueParams,
    nominal: RobotParams,
    *,
    seed: int = 0,
    repeats: int | None = None,
    names: Sequence[str] | None = None,
) -> list[ExperimentResult]:
    """Every built-in experiment (or ``names``) on one truth, in name order."""
    return [
        run_experiment(load_experiment(name), truth, nominal, seed=seed, repeats=repeats)
        for name in (names or sorted(builtin_experiments()))
    ]
