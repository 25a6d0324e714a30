"""The drift monitor: does the robot still turn as its parameters say? (a gyro, live).

Every ``window_s`` seconds of the run, the odometry's heading change and the gyro's integral
over the same interval make one pair; a recursive least-squares fit with exponential forgetting
(time constant ``memory_s``) of ``gyro = k * odometry + b * dt`` gives the yaw-rate ratio ``k``
(actual/predicted rotation, with a gyro of scale 1) and its 95 % interval. The parameters in use
say ``k`` lies in ``expected`` (their calibration's interval; by default 1 +- 3 %, which holds a
gyro's 1 % scale and a calibration's 2 %). When the whole interval of ``k`` stays outside it for
``hold_s`` seconds, the monitor flags it once (``the effective track is 6 % larger than
calibrated since 12.4 s: terrain or tyres changed``); it clears when ``k``'s interval comes back.
The robot is never stopped for it. A fit over too little turning (under ``min_turn`` rad in its
memory) says nothing: a gyro's bias and scale cannot be told apart there.

The **sense check** (:func:`sense_check`) is the coarse test beside it: odometry and gyro must
turn the same way, at a ratio near the calibrated one. A wrong link variant, swapped left and
right channels or a reversed encoder make them disagree by a sign or a large factor; that stops
the run (live, :class:`SenseCheckError`) or flags it (after the run). It returns what it found
(:class:`SenseFinding`: a kind and the numbers); each face words the likely cause for what
applies to it (a robot's link and options here, :func:`robot_sense_sentence`; a log's columns
and params in ``odolab validate``).

Pure Python and numpy on a few numbers per window: cheap enough for the control loop.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from odolab.core.distributions import Z95
from odolab.core.errors import OdolabError

__all__ = [
    "EXPECTED_RATIO",
    "DriftFlag",
    "DriftMonitor",
    "DriftState",
    "SenseCheckError",
    "SenseFinding",
    "robot_sense_sentence",
    "sense_check",
]

#: the sense check's bounds: a turn must reach this much (rad) beyond the gyro's possible bias
#: drift before odometry and gyro are compared; a ratio this many times outside the calibrated
#: range is "far outside" (a wrong track width or counts per revolution, not terrain)
SENSE_MIN_TURN = 0.5
SENSE_BIAS_ALLOWANCE = 0.01  #: rad/s of gyro bias a sense check allows for
#: a ratio outside the calibrated range widened by this factor is "far outside" (the lab's
#: jaguar-lab truth turns at 0.67-0.88 of its odometry on tile: slip, not a wiring fault)
SENSE_FAR = 2.0
#: opposite signs count when the smaller turn is at least this much (rad): a lagging sensor
#: at the very start of a turn is not a disagreement
SENSE_SIGN_FLOOR = 0.2


class SenseCheckError(OdolabError):
    """Odometry and the robot's gyro disagree in sign or by a large factor: the run was stopped."""


#: the calibrated range of the yaw-rate ratio gyro/odometry when the parameters carry none: a
#: gyro's 1 % scale and a calibration's 2 %, 1 +- 3 % on the odometry's side (the drift
#: monitor's ``expected`` and the sense check's, one constant)
EXPECTED_RATIO = (1.0 / 1.03, 1.0 / 0.97)


@dataclass(frozen=True)
class SenseFinding:
    """How odometry and a gyro disagree on a run's turn: ``kind`` is ``"opposite"`` (they turn
    opposite ways) or ``"ratio"`` (one saw much more turning than the other: ``ratio``, gyro over
    odometry, is far outside ``expected``). Data only: each face words it for what applies to
    it (:func:`robot_sense_sentence` for a robot run; ``odolab validate`` for a log)."""

    kind: Literal["opposite", "ratio"]
    odometry_turn: float  #: rad, ccw positive
    gyro_turn: float  #: rad, ccw positive
    elapsed: float  #: s
    ratio: float  #: gyro / odometry (inf when the odometry did not turn)
    expected: tuple[float, float]

    def numbers(self) -> str:
        """The turns, in words: ``odometry +0.59 rad, gyro -0.38 rad over 1.2 s``."""
        return (
            f"odometry {self.odometry_turn:+.2f} rad, gyro {self.gyro_turn:+.2f} rad over "
            f"{self.elapsed:.1f} s"
        )


def sense_check(
    odometry_turn: float,
    gyro_turn: float,
    elapsed: float,
    expected: tuple[float, float] = EXPECTED_RATIO,
) -> SenseFinding | None:
    """None when odometry and gyro agree on a run's turn (rad, ccw positive, over ``elapsed``
    s); else how they disagree (:class:`SenseFinding`). Nothing is said before either has
    turned ``SENSE_MIN_TURN`` plus what a gyro bias of ``SENSE_BIAS_ALLOWANCE`` could add;
    ``expected`` is the calibrated range of gyro/odometry (the drift monitor's)."""
    o, g, dt = float(odometry_turn), float(gyro_turn), float(elapsed)
    need = SENSE_MIN_TURN + SENSE_BIAS_ALLOWANCE * max(dt, 0.0)
    if not (math.isfinite(o) and math.isfinite(g)) or max(abs(o), abs(g)) < need:
        return None
    ratio = g / o if o != 0 else math.inf
    exp = (float(expected[0]), float(expected[1]))
    if o * g < 0 and min(abs(o), abs(g)) >= SENSE_SIGN_FLOOR:
        return SenseFinding("opposite", o, g, dt, ratio, exp)
    lo, hi = exp[0] / SENSE_FAR, exp[1] * SENSE_FAR
    # a ratio needs twice the turn: early in a turn one sensor's lag moves it most
    if max(abs(o), abs(g)) < 2 * need or lo <= ratio <= hi:
        return None
    return SenseFinding("ratio", o, g, dt, ratio, exp)


def robot_sense_sentence(finding: SenseFinding) -> str:
    """The robot face's sentence for a sense check's finding: the causes that apply to a robot
    driven through a link (its variant, its channels, the encoder-sign options, ``--params``)."""
    if finding.kind == "opposite":
        return (
            f"odometry and gyro turn opposite ways ({finding.numbers()}): the robot turns "
            "against its commands while the encoders follow them; likely a wrong link variant "
            "(tcp://...?variant=wheel or track), swapped left and right channels, or both motor "
            "and encoder signs reversed"
        )
    shown = "infinite" if not math.isfinite(finding.ratio) else f"{finding.ratio:.2f}"
    which = (
        "the gyro saw much more turning"
        if abs(finding.gyro_turn) > abs(finding.odometry_turn)
        else "the odometry saw much more turning"
    )
    lo, hi = finding.expected
    return (
        f"{which} than the other ({finding.numbers()}; gyro/odometry {shown}, calibrated "
        f"{lo:.2f} to {hi:.2f}): likely one encoder counting backwards "
        "({{left_encoder_sign}}/{{right_encoder_sign}}) or on the wrong channel, or counts per "
        "revolution or track width in {{params}} far from this robot's"
    )


@dataclass(frozen=True)
class DriftFlag:
    """A flag raised (or cleared) at ``t`` (s, run time): the ratio and its interval then, and
    the time its interval first left the expected range."""

    t: float
    since: float
    ratio: float
    ci95: tuple[float, float]
    cleared: bool = False

    @property
    def track_change(self) -> float:
        """Relative change of the effective track implied by the ratio (0.06: 6 % larger)."""
        return 1.0 / self.ratio - 1.0

    def message(self) -> str:
        if self.cleared:
            return (
                f"the yaw-rate ratio is back within the calibrated range at {self.t:.1f} s "
                f"({self.ratio:.3f}, 95 % [{self.ci95[0]:.3f}, {self.ci95[1]:.3f}])"
            )
        change = self.track_change
        word = "larger" if change > 0 else "smaller"
        return (
            f"the effective track is {100 * abs(change):.0f} % {word} than calibrated since "
            f"{self.since:.1f} s (gyro/odometry yaw rate {self.ratio:.3f}, 95 % "
            f"[{self.ci95[0]:.3f}, {self.ci95[1]:.3f}]): terrain or tyres changed"
        )


@dataclass(frozen=True)
class DriftState:
    """The monitor's latest estimate (nan before there is one)."""

    t: float
    ratio: float
    ci95: tuple[float, float]
    turned: float  #: |odometry turn| in the fit's memory (rad)


@dataclass
class DriftMonitor:
    """See the module. Feed it with :meth:`odometry` (each cycle's heading) and :meth:`gyro`
    (each gyro sample, on the same clock); it returns flags as they are raised."""

    expected: tuple[float, float] = EXPECTED_RATIO
    window_s: float = 0.5
    memory_s: float = 1.5
    hold_s: float = 1.0
    #: the flag's test: the ratio's interval at this z (99.9 %, two-sided) must stay outside
    #: ``expected`` for ``hold_s``; a 95 % test repeated every window would cry wolf
    z_flag: float = 3.29
    #: memory (s) of the residuals' long-run variance, a floor under the short fit's
    long_memory_s: float = 30.0
    min_turn: float = 1.0
    #: what the gyro's bias is known to be (rad/s) and how well (a turn at one constant rate
    #: cannot tell a bias from a ratio: the bias is taken as known, its uncertainty carried)
    bias: float = 0.0
    bias_sd: float = 0.002
    flags: list[DriftFlag] = field(default_factory=list)
    state: DriftState | None = None
    _odo: list[tuple[float, float]] = field(default_factory=list)
    _gt: list[float] = field(default_factory=list)
    _gcum: list[float] = field(default_factory=list)
    _last_rate: float = 0.0
    _s: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    _turned: float = 0.0
    _n: float = 0.0
    _long_rss: float = 0.0
    _long_n: float = 0.0
    _out_since: float | None = None
    _raised: bool = False

    def odometry(self, t: float, heading: float) -> None:
        """The odometry's heading (rad, unwrapped) at run time ``t`` (s)."""
        if not self._odo or t >= self._odo[-1][0] + self.window_s:
            self._odo.append((t, heading))

    def gyro(self, samples: Iterable[tuple[float, float]]) -> list[DriftFlag]:
        """New gyro samples (t s, yaw rate rad/s), in time order; returns the flags raised."""
        for t, rate in samples:
            if self._gt and t <= self._gt[-1]:
                continue
            if not self._gt:
                self._gt.append(t)
                self._gcum.append(0.0)
            else:
                dt = t - self._gt[-1]
                self._gcum.append(self._gcum[-1] + 0.5 * (rate + self._last_rate) * dt)
                self._gt.append(t)
            self._last_rate = rate
        return self._consume()

    def _gyro_at(self, t: float) -> float:
        return float(np.interp(t, self._gt, self._gcum))

    def gyro_span(self) -> tuple[float, float] | None:
        """The first and last gyro sample times (None before two samples)."""
        return (self._gt[0], self._gt[-1]) if len(self._gt) >= 2 else None

    def gyro_turn(self, t0: float, t1: float) -> float:
        """The gyro's integral (rad) from ``t0`` to ``t1``, inside :meth:`gyro_span`."""
        return self._gyro_at(t1) - self._gyro_at(t0)

    def _consume(self) -> list[DriftFlag]:
        out: list[DriftFlag] = []
        # windows whose both ends the gyro has covered
        while len(self._odo) >= 2 and self._gt and self._odo[1][0] <= self._gt[-1]:
            (t0, h0), (t1, h1) = self._odo[0], self._odo[1]
            self._odo.pop(0)
            if t0 < self._gt[0]:
                continue
            flag = self._update(t1, h1 - h0, self._gyro_at(t1) - self._gyro_at(t0), t1 - t0)
            if flag is not None:
                out.append(flag)
        self.flags.extend(out)
        return out

    def _update(self, t: float, dodo: float, dgyro: float, dt: float) -> DriftFlag | None:
        lam = math.exp(-dt / self.memory_s)
        # the gyro less its known bias, against the odometry's turn, through the origin
        v = np.array([dodo, dgyro - self.bias * dt, dt])
        self._s = lam * self._s + np.outer(v, v)
        self._turned = lam * self._turned + abs(dodo)
        self._n = lam * self._n + 1.0
        s_oo, s_og, s_gg, s_ot = self._s[0, 0], self._s[0, 1], self._s[1, 1], self._s[0, 2]
        if self._n < 3 or self._turned < self.min_turn or s_oo <= 0:
            self.state = DriftState(t, math.nan, (math.nan, math.nan), self._turned)
            return None
        k = float(s_og / s_oo)
        rss = max(float(s_gg - k * s_og), 0.0)
        # a floor under the residual: a noise-free gyro must not claim an exact ratio
        sigma2 = max(rss / max(self._n - 1.0, 1.0), (1e-3 * self.window_s) ** 2)
        # the short memory sees few windows: its residual variance can come out small by
        # chance; the long-run variance of the residuals is a floor under it
        r = float(v[1] - k * dodo)
        mu = math.exp(-dt / self.long_memory_s)
        self._long_rss = mu * self._long_rss + r * r
        self._long_n = mu * self._long_n + 1.0
        if self._long_n > 2.0:
            sigma2 = max(sigma2, self._long_rss / (self._long_n - 1.0))
        # the bias's own uncertainty moves k by sd_b * sum(dodo dt) / sum(dodo^2)
        var = sigma2 / s_oo + (self.bias_sd * s_ot / s_oo) ** 2
        se = math.sqrt(var)
        ci = (k - Z95 * se, k + Z95 * se)
        self.state = DriftState(t, k, ci, self._turned)
        lo, hi = self.expected
        outside = k - self.z_flag * se > hi or k + self.z_flag * se < lo
        if outside:
            if self._out_since is None:
                self._out_since = t
            if not self._raised and t - self._out_since >= self.hold_s:
                self._raised = True
                return DriftFlag(t, self._out_since, k, ci)
            return None
        self._out_since = None
        if self._raised and lo <= ci[0] and ci[1] <= hi:  # back, and surely so
            self._raised = False
            return DriftFlag(t, t, k, ci, cleared=True)
        return None
