"""Recording a trial typed by hand: ``odolab trials add`` calls :func:`add_trial`.

The rules live here once: the commanded angle given once (rad or multiples of pi), a
translation's distance, which parameters the trial was driven with (the version named, else the
robot's latest in the notebook, else its preset: the result says which was chosen), and an
unknown campaign created only when asked, with its terrain.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from odolab.core.defaults import DEFAULT_ROBOT
from odolab.core.errors import opt

if TYPE_CHECKING:
    from odolab.core.params import RobotParams
    from odolab.core.trials import Measurement, Trial
    from odolab.store import Notebook

__all__ = ["AddRequest", "AddedTrial", "add_trial"]


@dataclass(frozen=True)
class AddRequest:
    """A trial typed by hand: its id, campaign, command and odometry's final pose; the readings,
    when given, are measured by the face's ``measure``."""

    trial_id: str
    campaign: str
    kind: str
    predicted_heading: float = 0.0
    predicted_x: float = 0.0
    predicted_y: float = 0.0
    terrain: str | None = None
    angle: float | None = None
    angle_pi: float | None = None
    distance: float | None = None
    robot: str = DEFAULT_ROBOT
    params_version: int | None = None
    readings: tuple[float | int | None, ...] = ()  #: initial, final, turns, x, y
    notes: str = ""
    create_campaign: bool = False


@dataclass(frozen=True)
class AddedTrial:
    """The trial recorded, its parameters' version, and the sentence saying which parameters
    were chosen for the user ("" when the version was named)."""

    trial: Trial
    version: int
    chosen: str


def _params(nb: Notebook, db: Path, robot: str, version: int | None) -> RobotParams:
    """The version named, else the robot's latest in the notebook, else its preset."""
    from odolab.core.errors import StoreError
    from odolab.core.params import PRESETS

    if version is not None:
        return nb.get_params(robot, version)
    if nb.latest_params_version(robot) is not None:
        return nb.latest_params(robot)
    if robot in PRESETS:
        return PRESETS[robot]
    raise StoreError(f"no parameters of robot {robot!r} in {db} and no such preset")


def _trial(nb: Notebook, db: Path, req: AddRequest, angle: float | None) -> Trial:
    """The trial as typed, before its measurement.

    Raises:
        StoreError: an unknown campaign (not to be created), or a heading that is not finite.
    """
    from odolab.core.errors import StoreError
    from odolab.core.kinematics import wrap_angle
    from odolab.core.trajectory import Pose
    from odolab.core.trials import Command, MotionKind, Trial

    params = _params(nb, db, req.robot, req.params_version)
    campaign, terrain, trial_id = req.campaign, req.terrain, req.trial_id
    if campaign not in nb.campaign_names() and not (req.create_campaign and terrain):
        # one sentence whatever was given (it said "give --terrain to create it", and with
        # --terrain "add it first")
        raise StoreError(
            f"unknown campaign {campaign!r} in {db}; expected one of its campaigns, or "
            "{{create_campaign}} with {{terrain}} to create it (or odolab trials campaign-add)"
        )
    if terrain is None:
        terrain = nb.get_campaign(campaign).terrain
    heading = req.predicted_heading
    if not math.isfinite(heading):
        raise StoreError(
            f"trial {trial_id}: {opt('predicted_heading')} is {heading}; expected a finite number (rad)"
        )
    return Trial(
        trial_id=trial_id,
        campaign=campaign,
        terrain=terrain,
        command=Command(MotionKind(req.kind), angle=angle, distance=req.distance),
        predicted=Pose(0.0, req.predicted_x, req.predicted_y, float(wrap_angle(heading)), heading),
        params=params,
        notes=req.notes,
    )


def add_trial(db: Path, req: AddRequest, measure: Callable[[Trial], Measurement]) -> AddedTrial:
    """Record the trial in the notebook ``db`` (created when new), measured by ``measure``
    when any reading was given.

    Raises:
        StoreError: the angle given twice, a translation without its distance, no parameters
            for the robot, an unknown campaign, a heading that is not finite.
    """
    from odolab.core.errors import StoreError
    from odolab.core.params import PRESETS
    from odolab.core.trials import MotionKind, TrialStatus
    from odolab.store import Notebook

    angle = req.angle
    if angle is not None and req.angle_pi is not None:
        raise StoreError("give the commanded angle once: {{angle}} (rad) or {{angle_pi}}")
    if req.angle_pi is not None:
        angle = req.angle_pi * math.pi
    # import refuses the same
    if MotionKind.parse(req.kind).needs == "distance" and req.distance is None:
        raise StoreError("a translation needs {{distance}} (the commanded distance, m)")
    with Notebook(db) as nb:
        trial = _trial(nb, db, req, angle)
        if any(v is not None for v in req.readings):
            m = measure(trial)
            trial = dataclasses.replace(trial, measured=m, status=TrialStatus.MEASURED)
        nb.add_trial(trial, create_campaign=req.create_campaign)
        _, version = nb.trial_params_version(req.trial_id)
    robot = req.robot
    if req.params_version is not None:
        chosen = ""
    elif version == 1 and robot in PRESETS:
        chosen = f"; parameters {robot} v1 (the preset; give {opt('params_version')} to choose)"
    else:
        chosen = (
            f"; parameters {robot} v{version} (the robot's latest; give {opt('params_version')} "
            "to choose the version it was driven with)"
        )
    return AddedTrial(trial, version, chosen)
