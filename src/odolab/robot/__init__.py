"""odolab.robot: the Jaguar link (protocol codec, UDP driver, virtual Jaguar board), the fixed-rate
control loop with its watchdog, and motions driven by odometry.

See docs/robot.md for the command line and the protocol choices.
"""

from __future__ import annotations

from odolab.robot.clock import Clock, RealClock, SimClock
from odolab.robot.driver import (
    ChannelMap,
    CommandMode,
    DriverConfig,
    EncoderReading,
    JaguarDriver,
    Transport,
    UdpTransport,
    parse_robot_url,
)
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
from odolab.robot.plant import IdealPlant, Plant, make_plant
from odolab.robot.server import (
    BoardConfig,
    Faults,
    InProcessLink,
    VirtualJaguar,
    VirtualJaguarServer,
)
from odolab.robot.session import RobotRun, run_motion, run_motion_simulated, save_run

__all__ = [
    "BoardConfig",
    "ChannelMap",
    "Clock",
    "CommandMode",
    "ControlLoop",
    "CycleInfo",
    "CycleLog",
    "DriverConfig",
    "EncoderReading",
    "Faults",
    "IdealPlant",
    "InProcessLink",
    "JaguarDriver",
    "LoopResult",
    "LoopStats",
    "Motion",
    "MotionSequence",
    "Pivot",
    "Plant",
    "RealClock",
    "RobotRun",
    "Rotate",
    "SimClock",
    "Straight",
    "Transport",
    "UdpTransport",
    "VirtualJaguar",
    "VirtualJaguarServer",
    "Watchdog",
    "make_plant",
    "motion_from_command",
    "parse_robot_url",
    "run_motion",
    "run_motion_simulated",
    "save_run",
    "square",
]
