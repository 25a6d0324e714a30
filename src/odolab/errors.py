"""The one root error of odolab and its few subclasses.

Every error a user can cause (a malformed file, a wrong unit, a corrupt packet) is raised as an
:class:`OdolabError` whose message is one sentence: what, where, what was expected. The CLI prints
that sentence and exits non-zero; it never shows a traceback for these.
"""

from __future__ import annotations

__all__ = [
    "CalibrationError",
    "EncoderJumpError",
    "ImuLogError",
    "InsufficientDataError",
    "InvalidTrialError",
    "LogFormatError",
    "OdolabError",
    "ParamsError",
    "ProtocolError",
    "RobotLinkError",
    "SimError",
    "StoreError",
]


class OdolabError(Exception):
    """Root of every error odolab raises on purpose."""


class ParamsError(OdolabError):
    """A robot parameter set is invalid or its file is malformed."""


class LogFormatError(OdolabError):
    """A log file (encoder CSV, trajectory, bag, IMU log) is malformed."""


class EncoderJumpError(LogFormatError):
    """Encoder counters jumped more in one cycle than a wrap or plausible motion explains."""


class ProtocolError(OdolabError):
    """A robot protocol file or packet is invalid."""


class RobotLinkError(OdolabError):
    """The link to a robot failed (no data, lost connection)."""


class SimError(OdolabError):
    """A simulation or experiment protocol is invalid."""


class StoreError(OdolabError):
    """The lab notebook (SQLite store) refused an operation."""


class InsufficientDataError(OdolabError):
    """Too few trials or samples for the requested statistic."""


class CalibrationError(OdolabError):
    """A calibration could not be computed from the given data."""


class ImuLogError(LogFormatError):
    """An IMU (SensorLog) log is malformed or does not overlap the encoder log."""


class InvalidTrialError(StoreError):
    """A trial record has a missing, malformed or implausible value.

    ``field`` names the trial-record field (:data:`odolab.trials.TRIAL_FIELDS`) at fault, when
    there is one, so that an importer can name its own column or key for it.
    """

    def __init__(self, message: str, field: str | None = None) -> None:
        super().__init__(message)
        self.field = field
