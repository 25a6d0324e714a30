"""A plausible trial for the tests in tests/arch."""

from __future__ import annotations

from odolab.core.params import PRESETS
from odolab.core.trajectory import Pose
from odolab.core.trials import Command, Measurement, MotionKind, Trial, TrialStatus


def one_trial() -> Trial:
    return Trial(
        trial_id="A1",
        campaign="fwd",
        terrain="lab",
        command=Command(MotionKind.TRANSLATION, distance=2.5, speed=0.3),
        predicted=Pose(8.3, 2.5, 0.01, 0.002, 0.002),
        params=PRESETS["jaguar-lite"],
        measured=Measurement("meterstick", x=2.43, y=-0.05, sigma_xy=0.003),
        status=TrialStatus.MEASURED,
    )
