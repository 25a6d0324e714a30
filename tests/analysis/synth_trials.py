"""A small synthetic lab campaign with known truth (the lab report's Table I numbers).

Used by the analysis, calibration and report tests until the simulator lands. Every draw comes
from ``np.random.default_rng(seed)``.
"""

from __future__ import annotations

import math

import numpy as np

from odolab.core.params import PRESETS, RobotParams
from odolab.core.trajectory import Pose
from odolab.core.trials import Command, Measurement, MotionKind, Trial, TrialStatus

PARAMS: RobotParams = PRESETS["jaguar-lite"]

#: the truth the generator uses (the lab report's Table I)
TRUTH = {
    "rotation_ratio": 0.875,
    "rotation_sigma_a": 2.94 / math.sqrt(20 * math.pi),  # sigma = a * heading**0.5
    "rotation_p": 0.5,
    "x_ratio": {"tile": 0.905, "concrete": 0.920, "grass": 0.904},
    "x_sigma_a": 0.01,  # sigma_x = a * d**0.5
    "y_slope_forward": 0.028,
    "y_slope_reverse": 0.091,  # per metre travelled
    "y_sigma_a": 0.027,  # sigma_y = a * d**1.0
    "y_p": 1.0,
}


def _pose(x: float, y: float, heading: float) -> Pose:
    wrapped = math.atan2(math.sin(heading), math.cos(heading))
    return Pose(0.0, x, y, wrapped, heading)


def rotation_trials(
    rng: np.random.Generator,
    *,
    terrain: str = "tile",
    ratio: float = TRUTH["rotation_ratio"],
    sigma_a: float = TRUTH["rotation_sigma_a"],
    p: float = TRUTH["rotation_p"],
    repeats_at_20pi: int = 18,
    campaign: str = "rotation",
) -> list[Trial]:
    angles = [k * math.pi for k in range(1, 21)] + [20 * math.pi] * repeats_at_20pi
    out = []
    for i, ang in enumerate(angles):
        pred = ang + rng.normal(0, 0.01)
        actual = ratio * pred + rng.normal(0, sigma_a * abs(pred) ** p)
        out.append(
            Trial(
                trial_id=f"{campaign}-{terrain}-{i:03d}",
                campaign=campaign,
                terrain=terrain,
                command=Command(MotionKind.ROTATION, angle=ang),
                predicted=_pose(0.0, 0.0, pred),
                params=PARAMS,
                measured=Measurement("compass", rotation=actual, sigma_rotation=0.05),
                status=TrialStatus.MEASURED,
            )
        )
    return out


def translation_trials(
    rng: np.random.Generator,
    *,
    terrain: str = "tile",
    distances: tuple[float, ...] = (1.1, 2.5, -1.1, -2.5),
    repeats: int = 5,
    ratio: float | None = None,
    y_forward: float = TRUTH["y_slope_forward"],
    y_reverse: float = TRUTH["y_slope_reverse"],
    x_sigma_a: float = TRUTH["x_sigma_a"],
    y_sigma_a: float = TRUTH["y_sigma_a"],
    y_p: float = TRUTH["y_p"],
    measure_y: bool = True,
    campaign: str = "translation",
) -> list[Trial]:
    ratio = TRUTH["x_ratio"][terrain] if ratio is None else ratio
    out = []
    k = 0
    for d in distances:
        for _ in range(repeats):
            px = d + rng.normal(0, 0.005)
            py = rng.normal(0, 0.002)
            ax = ratio * px + rng.normal(0, x_sigma_a * abs(px) ** 0.5)
            slope = y_forward if d > 0 else -y_reverse  # error per metre of predicted x
            err_y = slope * px + rng.normal(0, y_sigma_a * abs(px) ** y_p)
            ay = py - err_y
            out.append(
                Trial(
                    trial_id=f"{campaign}-{terrain}-{k:03d}",
                    campaign=campaign,
                    terrain=terrain,
                    command=Command(MotionKind.TRANSLATION, distance=d),
                    predicted=_pose(px, py, rng.normal(0, 0.001)),
                    params=PARAMS,
                    measured=Measurement(
                        "meterstick", x=ax, y=ay if measure_y else None, sigma_xy=0.005
                    ),
                    status=TrialStatus.MEASURED,
                )
            )
            k += 1
    return out


def lab_trials(seed: int = 0) -> list[Trial]:
    """The lab's three campaigns: rotation indoors, x/y indoors, x outdoors (concrete, grass)."""
    rng = np.random.default_rng(seed)
    trials = rotation_trials(rng)
    trials += translation_trials(rng)
    outdoor = tuple(0.5 * k for k in range(1, 11))
    for terrain in ("concrete", "grass"):
        trials += translation_trials(
            rng,
            terrain=terrain,
            distances=outdoor,
            repeats=1,
            measure_y=False,
            campaign="outdoor",
        )
    return trials
