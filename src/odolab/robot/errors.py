"""Errors of the robot stack, each named for what went wrong (all :class:`OdolabError`).

The CLI prints their one-sentence message and exits 1; none of them is raised after a command
could have left the robot moving without a stop having been sent first.
"""

from __future__ import annotations

from odolab.core.errors import OdolabError, RobotLinkError, SimError

__all__ = [
    "BoardConfigError",
    "CommandsIgnoredError",
    "FenceCrossedError",
    "LateCycleError",
    "LinkLostError",
    "MotionError",
    "NoSensorDataError",
    "PlantError",
    "RobotConfigError",
    "RobotUrlError",
    "RunFolderError",
    "RunNotSavedError",
]


class RobotConfigError(OdolabError):
    """A robot-run setting (CLI option) is out of its physical bounds; nothing was sent."""


class BoardConfigError(RobotConfigError):
    """A virtual board setting is out of its bounds."""


class MotionError(RobotConfigError, SimError):
    """A motion cannot be driven as asked (zero speed, unknown kind, non-finite target)."""


class RobotUrlError(RobotConfigError, RobotLinkError):
    """A ``--robot`` address is malformed or names no known link."""


class NoSensorDataError(RobotLinkError):
    """The robot sent no sensor data after the handshake."""


class LinkLostError(RobotLinkError):
    """Sensor data stopped for longer than the link timeout during a run."""


class CommandsIgnoredError(RobotLinkError):
    """The robot's encoders do not follow the commands (stalled, or the board ignores them)."""


class LateCycleError(OdolabError):
    """A control cycle ran later than the watchdog bound (the host froze, was swapped out or
    starved): the loop sent stop and failed the run instead of resuming the motion."""


class RunFolderError(RobotConfigError):
    """The run's output folder cannot take the run (checked before the robot moves)."""


class RunNotSavedError(OdolabError):
    """A run that has driven could be written neither where asked nor to any fallback."""


class FenceCrossedError(OdolabError):
    """An exploration left its geofence (by odometry): the robot was stopped there, the run ended
    early and was kept."""


class PlantError(OdolabError):
    """A plant (the virtual board's physics) was asked for something impossible."""
