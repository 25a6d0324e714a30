"""The one root error of odolab and its few subclasses.

Every error a user can cause (a malformed file, a wrong unit, a corrupt packet) is raised as an
:class:`OdolabError` whose message is one sentence: what, where, what was expected. The CLI prints
that sentence and exits non-zero; it never shows a traceback for these.

Errors carry data, faces choose the words. An error about one setting names it by its library
name in the field ``option`` (a Python identifier such as ``nees_segment``), with ``value`` and
``allowed`` (the accepted range, as text). A sentence that names a setting writes it as a mark,
:func:`opt` (``{{nees_segment}}``): ``str(err)`` reads it in the library's neutral words
(:data:`OPTION_NAMES`: "the NEES segment length"); each face words the same error with its own
:class:`Wording` (the CLI its flags in ``odolab.cli.wording``, the web its form names in
``odolab.serve.wording``). Texts that are not errors (a hint to run a command) carry the same
marks, and the face that shows them words them with :meth:`Wording.say`.
"""

from __future__ import annotations

import re
from collections.abc import Collection, Mapping

__all__ = [
    "NEUTRAL",
    "OPTION_NAMES",
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
    "Wording",
    "check_table_keys",
    "opt",
]

#: The library's own words for each setting a sentence can name (identifier -> words). A face
#: names the same settings in its own words (``odolab.cli.wording.FLAGS``: ``--nees-segment``).
OPTION_NAMES: dict[str, str] = {
    "board": "the ChArUco board",
    "campaign": "the campaign filter",
    "chunk_rows": "the chunk size in rows",
    "command_timeout": "the board's command timeout",
    "connect_timeout": "the connect timeout",
    "controller_name": "the controller name",
    "corners": "the corner refinement",
    "corrupt": "the chance of corrupting a packet",
    "covariance": "the covariance output",
    "create_campaigns": "the campaign creation switch",
    "db": "the lab notebook's path",
    "decel": "the deceleration distance",
    "degrees": "the angle in degrees",
    "delay": "the packet delay",
    "delta": "the RPE delta",
    "delta_unit": "the RPE delta's unit",
    "distance": "the distance",
    "distribution": "the command distribution",
    "drift_segment": "the drift segment length",
    "drift_turn": "the drift turn segment",
    "drop": "the chance of dropping a packet",
    "drop_incoming": "the chance of losing a packet to the board",
    "duplicate": "the chance of duplicating a packet",
    "encoders": "the encoder log",
    "exclude_campaign": "the excluded campaigns",
    "explore_seed": "the exploration seed",
    "fence": "the fence radius",
    "final": "the final heading",
    "flip_imu": "the IMU sign flip",
    "floor": "the floor table",
    "format": "the log format",
    "foxglove_host": "the Foxglove host",
    "foxglove_port": "the Foxglove port",
    "ground_truth": "the ground truth",
    "hold": "the hold time",
    "horizon": "the horizon",
    "imu": "the IMU log",
    "initial": "the initial heading",
    "jitter": "the packet delay's jitter",
    "joint_topic": "the joint-state topic",
    "json": "the JSON result",
    "learning_curve": "the learning-curve lengths",
    "left_channel": "the left channel",
    "left_encoder_sign": "the left encoder sign",
    "left_motor_sign": "the left motor sign",
    "left_wheel": "the left wheel joints",
    "link_timeout": "the link timeout",
    "marker_height": "the marker height",
    "marker_offset": "the marker offset",
    "marker_size": "the marker size",
    "max_dticks": "the largest counter increment",
    "max_offset": "the largest clock offset",
    "max_speed": "the maximum speed",
    "max_turn_rate": "the maximum turn rate",
    "max_wheel_speed": "the maximum wheel speed",
    "max_yaw_rate": "the maximum yaw rate",
    "mode": "the command mode",
    "model": "the model",
    "models": "the models",
    "nees": "the NEES check",
    "nees_segment": "the NEES segment length",
    "offset": "the clock offset",
    "out": "the run folder",
    "overlay": "the overlay",
    "params": "the robot parameters",
    "params_version": "the parameters' version",
    "rate": "the loop rate",
    "replace": "the replace switch",
    "report_rate": "the report rate",
    "right_channel": "the right channel",
    "right_encoder_sign": "the right encoder sign",
    "right_motor_sign": "the right motor sign",
    "right_wheel": "the right wheel joints",
    "robot": "the robot",
    "robot_marker": "the robot's marker",
    "ros_distro": "the ROS distribution",
    "scheduler": "the Dask scheduler",
    "seconds": "the duration",
    "seed": "the seed",
    "sensor_topic": "the sensor's pose topic",
    "settle": "the settle time",
    "side": "the square's side",
    "silent_after": "the silence time",
    "speed": "the speed",
    "stall_timeout": "the stall timeout",
    "start_time": "the start time",
    "step": "the frame step",
    "terrain": "the terrain",
    "time_offset": "the time offset",
    "to": "the output format",
    "truth": "the truth preset",
    "truth_out": "the laser calibration's path output",
    "turns": "the number of turns",
    "validate": "the held-out runs",
    "virtual": "the virtual instruments",
    "watchdog": "the watchdog",
    "window": "the window",
    "workers": "the number of workers",
    "x": "x",
    "y": "y",
    "angle": "the commanded angle (rad)",
    "angle_pi": "the commanded angle in multiples of pi",
    "create_campaign": "creating the campaign",
    "duty": "the LED's duty cycle",
    "encoder_dir": "the encoder log folder",
    "foxglove": "serving the run to Foxglove",
    "idle_exit": "the idle time before the server exits",
    "interval": "the interval between sensor motions",
    "jpeg": "the JPEG quality",
    "led_hz": "the LED's blink rate",
    "predicted_heading": "the predicted heading",
    "scan_topic": "the scan topic",
}

_MARK = re.compile(r"\{\{([a-z][a-z0-9_]*)\}\}")


def opt(name: str) -> str:
    """The mark for setting ``name`` in a sentence (``{{name}}``): each face words it."""
    if name not in OPTION_NAMES:
        raise KeyError(f"{name!r} is not a setting of odolab.core.errors.OPTION_NAMES")
    return "{{" + name + "}}"


class Wording:
    """How one face names the settings: ``words`` maps a setting (an :data:`OPTION_NAMES` key)
    to the face's word for it (a flag, a form field); a setting it lacks keeps the library's."""

    def __init__(self, words: Mapping[str, str], name: str = "the library") -> None:
        self.words = dict(words)
        self.name = name

    def word(self, option: str) -> str:
        """The face's word for setting ``option``."""
        return self.words.get(option) or OPTION_NAMES.get(option, option)

    def say(self, text: str) -> str:
        """``text`` with each setting's mark (:func:`opt`) in this face's words."""
        return _MARK.sub(
            lambda m: self.word(m.group(1)) if m.group(1) in OPTION_NAMES else m.group(0),
            text,
        )

    def error(self, err: BaseException) -> str:
        """The sentence of ``err`` in this face's words (``str(err)`` for a foreign error)."""
        template = getattr(err, "template", None)
        return self.say(template) if isinstance(template, str) else str(err)


#: The library's own words (what ``str()`` of an error says).
NEUTRAL = Wording({}, "the library")


class OdolabError(Exception):
    """Root of every error odolab raises on purpose.

    ``option``: the setting at fault (an :data:`OPTION_NAMES` key), when there is one; ``value``:
    the value refused; ``allowed``: the accepted range, as text. The message may name settings
    with :func:`opt` marks; ``str()`` reads them in the library's words, :attr:`template` keeps
    them for a face's :class:`Wording`. With no message, the sentence is "OPTION is VALUE;
    expected ALLOWED".
    """

    def __init__(
        self,
        message: object = "",
        *args: object,
        option: str | None = None,
        value: object = None,
        allowed: str | None = None,
    ) -> None:
        self.template: str
        self.option: str | None
        self.value: object
        self.allowed: str | None
        # (an error re-raised as another keeps its marks and fields)
        text = str(message)
        if isinstance(message, OdolabError):
            text = message.template
            option = option if option is not None else message.option
            value = value if value is not None else message.value
            allowed = allowed if allowed is not None else message.allowed
        if not text and option is not None:
            text = f"{opt(option)} is {value!r}; expected {allowed}"
        self.template = text
        self.option = option
        self.value = value
        self.allowed = allowed
        super().__init__(NEUTRAL.say(text), *args)


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

    ``field`` names the trial-record field (:data:`odolab.core.trials.TRIAL_FIELDS`) at fault, when
    there is one, so that an importer can name its own column or key for it.
    """

    def __init__(self, message: str, field: str | None = None) -> None:
        super().__init__(message)
        self.field = field


def check_table_keys(
    data: Mapping[str, object],
    allowed: Collection[str],
    required: Collection[str],
    source: str,
    table: str,
    *,
    expected: str,
    error: type[OdolabError] = ParamsError,
) -> None:
    """Refuse ``table`` (``"[noise]"``) of the file ``source`` with ``error``: its first key not
    in ``allowed`` (the sentence ends "expected " and ``expected``), else the first key of
    ``required`` that it lacks."""
    unknown = sorted(set(data) - set(allowed))
    if unknown:
        raise error(f"{source}: unknown key {unknown[0]!r} in {table}; expected {expected}")
    missing = [k for k in required if k not in data]
    if missing:
        raise error(f"{source}: missing key {missing[0]!r} in {table}")
