"""Seeded lab notebooks for the parity suite, made with the simulator and the store's API.

Each notebook has, drawn from its seed: rotation, translation and square campaigns of one or two
robots on the virtual Jaguar (small protocols, so that a notebook takes a fraction of a second),
a validation campaign (notes ``validation: ...``) of rotations that would move Table I if it were
counted, a few excluded trials, and several parameter versions: some trials driven with a second
version, and a newest version that no trial was driven with (a calibration recorded earlier), so
that "the latest version" and "the version the trials were driven with" differ.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from odolab.core.params import PRESETS, RobotParams
from odolab.core.trials import Trial
from odolab.sim.physics import TrueParams
from odolab.sim.presets import TRUTH_PRESETS
from odolab.sim.protocols import parse_protocol, run_protocol
from odolab.store import Notebook

ROBOT_A = PRESETS["jaguar-lite"]
ROBOT_B = ROBOT_A.with_(
    name="rover-b", left_wheel_radius=0.08, right_wheel_radius=0.0805, track_width=0.5
)
VALIDATION = "phone-check"


@dataclass
class Generated:
    """What a generated notebook holds (for the tests' expectations)."""

    db: Path
    robots: list[str]
    campaigns: dict[str, str] = field(default_factory=dict)  #: campaign -> robot
    validation: list[str] = field(default_factory=list)
    excluded: list[str] = field(default_factory=list)
    driven_version: dict[str, int] = field(default_factory=dict)  #: robot -> most trials'


def _protocol(campaign: str, kind: str, rng: np.random.Generator) -> Any:
    if kind == "rotation":
        angles = sorted(rng.choice(np.arange(1, 9), size=int(rng.integers(4, 7)), replace=False))
        sets = [{"motion": "rotation", "angle_pi": [int(a) for a in angles], "direction": "ccw"}]
    elif kind == "translation":
        sets = [
            {"motion": "translation", "distance": [1.0, 2.0, 3.0], "direction": d, "repeats": 2}
            for d in ("forward", "reverse")
        ]
    else:
        sets = [
            {"motion": "square", "side": 1.0, "direction": d, "repeats": 2} for d in ("cw", "ccw")
        ]
    doc = {
        "protocol": {
            "campaign": campaign,
            "terrain": "tile",
            "report_rate": 10.0,
            "dt": 0.05,
            "turn_speed": 0.6,
            "linear_speed": 0.6,
        },
        "trials": sets,
    }
    return parse_protocol(doc, source=f"<parity {campaign}>")


def _truth(robot: RobotParams) -> TrueParams:
    if robot.name == ROBOT_A.name:
        return TRUTH_PRESETS["jaguar-lab"]
    return TrueParams.from_nominal(
        robot, left_radius_forward=0.083, right_radius_forward=0.0815, track_width=0.53
    )


def _run(
    campaign: str, kind: str, robot: RobotParams, rng: np.random.Generator, seed: int
) -> list[Trial]:
    return run_protocol(_protocol(campaign, kind, rng), _truth(robot), robot, seed=seed)


def make_notebook(folder: Path, seed: int, *, two_robots: bool | None = None) -> Generated:
    """A notebook drawn from ``seed`` (see the module's doc)."""
    rng = np.random.default_rng(seed)
    two = bool(rng.integers(0, 2)) if two_robots is None else two_robots
    robots = [ROBOT_A, ROBOT_B] if two else [ROBOT_A]
    gen = Generated(folder / f"parity-{seed}.db", [r.name for r in robots])
    with Notebook(gen.db) as nb:
        for robot in robots:
            nb.add_params_version(robot, method="nominal preset")
            tag = "a" if robot is ROBOT_A else "b"
            trials: list[Trial] = []
            for kind in ("rotation", "translation", "square"):
                name = f"{kind}-{tag}"
                trials += _run(name, kind, robot, rng, seed * 100 + len(gen.campaigns))
                gen.campaigns[name] = robot.name
            nb.add_trials(trials)
            gen.driven_version[robot.name] = 1
            # a second version, a few more rotations driven with it (fewer than with the first)
            v2 = robot.with_(left_wheel_radius=robot.left_wheel_radius * 1.01)
            nb.add_params_version(v2, method="ratios", notes="an earlier calibration")
            extra = _run(f"rotation-{tag}2", "rotation", v2, rng, seed * 100 + 50)
            nb.add_trials(extra[:3])
            gen.campaigns[f"rotation-{tag}2"] = robot.name
            # the newest version: no trial was driven with it (a calibration recorded before)
            v3 = robot.with_(track_width=robot.track_width * 1.07)
            nb.add_params_version(v3, method="umbmark", notes="an earlier calibration")
        # a validation campaign of robot A's rotations, with the phone's note
        nb.add_campaign(VALIDATION, "rotation", "tile", notes="validation: a phone rode along")
        val = _run(VALIDATION, "rotation", ROBOT_A.with_(track_width=0.62), rng, seed + 7)
        nb.add_trials([t for t in val if t.trial_id.startswith(VALIDATION)])
        gen.validation.append(VALIDATION)
        ids = sorted(t.trial_id for t in nb.load_trials(status="measured", with_logs=False))
        for tid in rng.choice(ids, size=2, replace=False):
            nb.exclude_trial(str(tid), "parity: a bumped trial")
            gen.excluded.append(str(tid))
    return gen
