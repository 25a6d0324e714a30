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
from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np
from numpy.typing import NDArray

from odolab.params import RobotParams
from odolab.trajectory import Pose

__all__ = [
    "Command",
    "EncoderLog",
    "Measurement",
    "MotionKind",
    "Trial",
    "TrialStatus",
]


class MotionKind(StrEnum):
    """What a trial commanded."""

    ROTATION = "rotation"  #: turn in place by ``angle`` (both tracks, opposite directions)
    TRANSLATION = "translation"  #: straight by ``distance`` (negative = reverse)
    PIVOT = "pivot"  #: turn by ``angle`` on one track, the other held
    SQUARE = "square"  #: UMBmark square of ``side``, ``direction`` "cw" or "ccw"
    FREE = "free"  #: anything else (a recorded log)


class TrialStatus(StrEnum):
    """Where a trial is in its life."""

    AWAITING = "awaiting"  #: driven, not yet measured
    MEASURED = "measured"
    EXCLUDED = "excluded"  #: kept, but left out of the analysis (with a reason)


@dataclass(frozen=True)
class Command:
    """A commanded motion. Angles in rad (ccw positive), distances in m (negative = reverse)."""

    kind: MotionKind
    angle: float | None = None
    distance: float | None = None
    side: float | None = None
    direction: str | None = None  #: "cw"/"ccw" for a square; "left"/"right" track held for pivot
    speed: float | None = None  #: commanded speed, m/s (translation) or rad/s (rotation)

    def describe(self) -> str:
        """Short human text, e.g. 'rotation 20.0 pi' or 'translation -2.5 m'."""
        if self.kind in (MotionKind.ROTATION, MotionKind.PIVOT) and self.angle is not None:
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
