"""Instruments that measure the true pose the way people in the lab did, errors included.

- :class:`Compass`: an analog compass read to ``sigma`` (0.05 rad) and rounded to its marks
  (``resolution_deg``). A compass reads a *bearing* (clockwise from north, degrees), so it knows
  the heading only modulo 2 pi; the operator counts the whole turns (in the way the robot
  turned, never fewer than none: :func:`odolab.core.measurement.count_turns`) and can miscount by
  one (``miscount_probability`` per trial).
  The measured rotation (counter-clockwise positive) is
  ``2 pi * turns + ((initial_bearing - final_bearing) mod 360 deg)`` counter-clockwise and
  ``-(2 pi * turns + ((final_bearing - initial_bearing) mod 360 deg))`` clockwise.
- :class:`Meterstick`: x, y of the robot in the tape frame, read with ``sigma`` and rounded to
  ``resolution`` (m). Outdoors the lab used tape marks and a meterstick: a larger ``sigma``.

All readers are vectorized: arrays of n true values in, arrays of n readings out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from odolab.core.errors import SimError
from odolab.core.measurement import count_turns, rotation_from_compass

__all__ = ["Compass", "CompassReadings", "Instruments", "Meterstick", "flag_miscounted_turns"]

_TWO_PI = 2.0 * math.pi


def _check(name: str, value: float, *, upper: float | None = None) -> None:
    if not math.isfinite(value) or value < 0 or (upper is not None and value > upper):
        rng = f"in [0, {upper}]" if upper is not None else ">= 0"
        raise SimError(f"instrument setting {name} must be a finite number {rng}, got {value!r}")


@dataclass(frozen=True, eq=False)
class CompassReadings:
    """Readings of n rotation trials: bearings (deg), counted turns and the measured rotation."""

    initial_deg: NDArray[np.float64]
    final_deg: NDArray[np.float64]
    turns: NDArray[np.int64]
    rotation: NDArray[np.float64]  #: rad, counter-clockwise positive
    miscounted: NDArray[np.int64]  #: the operator's counting error (turns), 0 when right
    clockwise: NDArray[np.bool_]  #: the way the turns were counted and the rest read


@dataclass(frozen=True)
class Compass:
    """Analog compass read to ``sigma`` rad, marks every ``resolution_deg``; turns counted."""

    sigma: float = 0.05
    resolution_deg: float = 1.0
    miscount_probability: float = 0.0

    def __post_init__(self) -> None:
        _check("compass sigma", self.sigma)
        _check("compass resolution_deg", self.resolution_deg)
        _check("miscount_probability", self.miscount_probability, upper=1.0)

    def _bearing(self, heading: NDArray[np.float64], north: NDArray[np.float64],
                 rng: np.random.Generator) -> NDArray[np.float64]:  # fmt: skip
        b = np.degrees(north - heading + self.sigma * rng.standard_normal(heading.shape))
        if self.resolution_deg > 0:
            b = np.round(b / self.resolution_deg) * self.resolution_deg
        return np.mod(b, 360.0)

    def read_rotation(
        self,
        heading_start: NDArray[np.float64],
        heading_end: NDArray[np.float64],
        rng: np.random.Generator,
    ) -> CompassReadings:
        """Measure the rotation from true unwrapped headings at start and end, shape (n,)."""
        h0 = np.asarray(heading_start, dtype=np.float64)
        h1 = np.asarray(heading_end, dtype=np.float64)
        north = rng.uniform(0.0, _TWO_PI, h0.shape)  # where north happens to be in the lab
        b0 = self._bearing(h0, north, rng)
        b1 = self._bearing(h1, north, rng)
        # the operator counts whole turns the way the robot turned (a stall read a hair the
        # other way: that way), as odolab.core.measurement.count_turns says
        counted = [
            count_turns(float(a), float(b), float(c))
            for a, b, c in zip(b0.ravel(), b1.ravel(), (h1 - h0).ravel(), strict=True)
        ]
        turns = np.array([n for n, _ in counted], dtype=np.int64).reshape(h0.shape)
        cw = np.array([d == "cw" for _, d in counted], dtype=np.bool_).reshape(h0.shape)
        miss = np.zeros_like(turns)
        if self.miscount_probability > 0:
            wrong = rng.random(h0.shape) < self.miscount_probability
            miss = np.where(wrong, rng.choice(np.array([-1, 1]), h0.shape), 0).astype(np.int64)
            miss = np.maximum(turns + miss, 0) - turns
        turns = turns + miss
        rotation = np.array(
            [
                rotation_from_compass(float(a), float(b), int(n), "cw" if c else "ccw")
                for a, b, n, c in zip(
                    b0.ravel(), b1.ravel(), turns.ravel(), cw.ravel(), strict=True
                )
            ],
            dtype=np.float64,
        ).reshape(h0.shape)
        return CompassReadings(b0, b1, turns, rotation, miss, cw)

    def read_turn(
        self, heading_change: float, rng: np.random.Generator
    ) -> tuple[float, float, int, Literal["ccw", "cw"]]:
        """One run's readings as the operator takes them: (initial bearing, final bearing, whole
        turns, the direction they were counted in), for a true heading change (rad, ccw
        positive), counted by :func:`odolab.core.measurement.count_turns` (no miscount). North lies
        where ``rng`` puts it."""
        north = rng.uniform(0.0, _TWO_PI, 1)
        b = self._bearing(np.array([0.0, float(heading_change)]), np.repeat(north, 2), rng)
        b0, b1 = float(b[0]), float(b[1])
        turns, direction = count_turns(b0, b1, float(heading_change))
        return b0, b1, turns, direction


@dataclass(frozen=True)
class Meterstick:
    """A meterstick (or tape and meterstick) read with ``sigma`` m, rounded to ``resolution``."""

    sigma: float = 0.003
    resolution: float = 0.001

    def __post_init__(self) -> None:
        _check("meterstick sigma", self.sigma)
        _check("meterstick resolution", self.resolution)

    def read(
        self, true_value: NDArray[np.float64], rng: np.random.Generator
    ) -> NDArray[np.float64]:
        """Readings of true coordinates (m), any shape."""
        v = np.asarray(true_value, dtype=np.float64)
        r = v + self.sigma * rng.standard_normal(v.shape)
        if self.resolution > 0:
            r = np.round(r / self.resolution) * self.resolution
        return r


@dataclass(frozen=True)
class Instruments:
    """The instrument set of a campaign: compass, indoor meterstick, outdoor tape."""

    compass: Compass = field(default_factory=Compass)
    meterstick: Meterstick = field(default_factory=Meterstick)
    tape: Meterstick = field(default_factory=lambda: Meterstick(sigma=0.005, resolution=0.001))


def flag_miscounted_turns(
    measured: NDArray[np.float64],
    predicted: NDArray[np.float64],
    *,
    n_sigma: float = 3.0,
) -> NDArray[np.bool_]:
    """Flag rotation trials whose measurement looks off by whole turns (a miscount).

    Fits ``measured = ratio * predicted`` robustly (median of the ratios). The random error of a
    rotation grows like ``sqrt(|predicted|)`` (turn scrub), so residuals are standardized by it and
    their spread is taken robustly (1.4826 * MAD). A trial is flagged when its residual is more
    than half a turn (pi) from the typical residual and more than ``n_sigma`` robust sigmas out:
    a miscounted turn shows as a residual near +-2 pi on top of the random error. Where the random
    error itself approaches pi (long rotations), a single miscount cannot be told apart reliably.
    Shapes (n,) -> (n,) bool.
    """
    m = np.asarray(measured, dtype=np.float64)
    p = np.asarray(predicted, dtype=np.float64)
    if m.shape != p.shape or m.ndim != 1:
        raise SimError("measured and predicted rotations must be 1-D arrays of the same length")
    ok = np.abs(p) > 1e-9
    if ok.sum() < 3:
        return np.zeros(m.shape, dtype=np.bool_)
    ratio = float(np.median(m[ok] / p[ok]))
    res = m - ratio * p
    center = float(np.median(res))
    z = np.where(ok, (res - center) / np.sqrt(np.maximum(np.abs(p), 1e-9)), 0.0)
    zc = float(np.median(z[ok]))
    scale = 1.4826 * float(np.median(np.abs(z[ok] - zc)))
    far = np.abs(res - center) > math.pi
    out = far & (np.abs(z - zc) > n_sigma * max(scale, 1e-12))
    return np.asarray(out, dtype=np.bool_)
