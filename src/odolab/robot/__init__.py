"""odolab.robot: driving a robot by odometry, safely.

The control loop with its watchdog (:mod:`.loop`) and the motions (:mod:`.motions`) know a robot
only through the :class:`Driver` interface (:mod:`.interface`); the ``--robot`` URL picks a link
from :mod:`.registry` (``udp://`` a Jaguar board, ``tcp://`` a Jaguar 4x4 of 2014, ``sim://`` a
virtual one). Each link's codec, driver and virtual board are one package: :mod:`.jaguar`
(binary over UDP), :mod:`.jaguar2014` (text over TCP). Every run has one validated
:class:`RunConfig` (:mod:`.config`). The virtual board's physics come in through the
:class:`Plant` interface (:mod:`.plant`), never by importing the simulator. An exploration
(``odolab robot explore``: commands over the input space inside a hard geofence, one run with its
ground truth) is :mod:`.explore` over the motion :mod:`.explore_motion`.

See docs/robot.md for the command line, the protocol choices and the safety guarantees.
"""

from __future__ import annotations

from odolab.robot.clock import Clock, RealClock, SimClock
from odolab.robot.config import CommandMode, RunConfig, check_motion
from odolab.robot.errors import (
    BoardConfigError,
    CommandsIgnoredError,
    FenceCrossedError,
    LateCycleError,
    LinkLostError,
    MotionError,
    NoSensorDataError,
    PlantError,
    RobotConfigError,
    RobotUrlError,
    RunFolderError,
    RunNotSavedError,
)
from odolab.robot.explore import ExplorePlan, plan_exploration
from odolab.robot.explore_motion import Explore
from odolab.robot.interface import Driver, DriverStats, EncoderReading
from odolab.robot.loop import ControlLoop, CycleInfo, CycleLog, LoopResult, LoopStats, Watchdog
from odolab.robot.motions import (
    Motion,
    MotionSequence,
    Pivot,
    Rotate,
    Straight,
    motion_from_command,
    square,
)
from odolab.robot.plant import IdealPlant, Plant, PlantFactory
from odolab.robot.registry import LINKS, RobotLink, VirtualSpec, open_link
from odolab.robot.session import (
    AbortReport,
    RobotRun,
    check_run_folder,
    keep_run,
    run_motion,
    run_motion_simulated,
    run_simulated,
    save_run,
)

__all__ = [
    "LINKS",
    "AbortReport",
    "BoardConfigError",
    "Clock",
    "CommandMode",
    "CommandsIgnoredError",
    "ControlLoop",
    "CycleInfo",
    "CycleLog",
    "Driver",
    "DriverStats",
    "EncoderReading",
    "Explore",
    "ExplorePlan",
    "FenceCrossedError",
    "IdealPlant",
    "LateCycleError",
    "LinkLostError",
    "LoopResult",
    "LoopStats",
    "Motion",
    "MotionError",
    "MotionSequence",
    "NoSensorDataError",
    "Pivot",
    "Plant",
    "PlantError",
    "PlantFactory",
    "RealClock",
    "RobotConfigError",
    "RobotLink",
    "RobotRun",
    "RobotUrlError",
    "Rotate",
    "RunConfig",
    "RunFolderError",
    "RunNotSavedError",
    "SimClock",
    "Straight",
    "VirtualSpec",
    "Watchdog",
    "check_motion",
    "check_run_folder",
    "keep_run",
    "motion_from_command",
    "open_link",
    "plan_exploration",
    "run_motion",
    "run_motion_simulated",
    "run_simulated",
    "save_run",
    "square",
]
