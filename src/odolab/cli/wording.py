"""The CLI's words for the library's settings: its flags.

The library's errors and hints name a setting by its library name (:data:`odolab.core.errors.OPTION_NAMES`,
as an error's ``option`` field or an :func:`odolab.core.errors.opt` mark in a sentence); the terminal
shows the flag the user typed. :data:`FLAGS` is the one table; :data:`CLI` words an error
(:meth:`~odolab.core.errors.Wording.error`) or a hint (:meth:`~odolab.core.errors.Wording.say`). The CLI's
error handler and :func:`odolab.cli._output.echo` use it, so command functions print library text
as it comes.
"""

from __future__ import annotations

from odolab.core.errors import Wording

__all__ = ["CLI", "FLAGS", "flag", "said", "worded"]

#: setting (library name) -> the command-line flag that sets it
FLAGS: dict[str, str] = {
    "board": "--board",
    "campaign": "--campaign",
    "chunk_rows": "--chunk-rows",
    "command_timeout": "--command-timeout",
    "connect_timeout": "--connect-timeout",
    "controller_name": "--controller-name",
    "corners": "--corners",
    "corrupt": "--corrupt",
    "covariance": "--covariance",
    "create_campaigns": "--create-campaigns",
    "db": "--db",
    "decel": "--decel",
    "degrees": "--degrees",
    "delay": "--delay",
    "delta": "--delta",
    "delta_unit": "--delta-unit",
    "distance": "--distance",
    "distribution": "--distribution",
    "drift_segment": "--drift-segment",
    "drift_turn": "--drift-turn",
    "drop": "--drop",
    "drop_incoming": "--drop-incoming",
    "duplicate": "--duplicate",
    "encoders": "--encoders",
    "exclude_campaign": "--exclude-campaign",
    "explore_seed": "--explore-seed",
    "fence": "--fence",
    "final": "--final",
    "flip_imu": "--flip-imu",
    "floor": "--floor",
    "format": "--format",
    "foxglove_host": "--foxglove-host",
    "foxglove_port": "--foxglove-port",
    "ground_truth": "--ground-truth",
    "hold": "--hold",
    "horizon": "--horizon",
    "imu": "--imu",
    "initial": "--initial",
    "jitter": "--jitter",
    "joint_topic": "--joint-topic",
    "json": "--json",
    "learning_curve": "--learning-curve",
    "left_channel": "--left-channel",
    "left_encoder_sign": "--left-encoder-sign",
    "left_motor_sign": "--left-motor-sign",
    "left_wheel": "--left-wheel",
    "link_timeout": "--link-timeout",
    "marker_height": "--marker-height",
    "marker_offset": "--marker-offset",
    "marker_size": "--marker-size",
    "max_dticks": "--max-dticks",
    "max_offset": "--max-offset",
    "max_speed": "--max-speed",
    "max_turn_rate": "--max-turn-rate",
    "max_wheel_speed": "--max-wheel-speed",
    "max_yaw_rate": "--max-yaw-rate",
    "mode": "--mode",
    "model": "--model",
    "models": "--models",
    "nees": "--nees",
    "nees_segment": "--nees-segment",
    "offset": "--offset",
    "out": "--out",
    "overlay": "--overlay",
    "params": "--params",
    "params_version": "--params-version",
    "rate": "--rate",
    "replace": "--replace",
    "report_rate": "--report-rate",
    "right_channel": "--right-channel",
    "right_encoder_sign": "--right-encoder-sign",
    "right_motor_sign": "--right-motor-sign",
    "right_wheel": "--right-wheel",
    "robot": "--robot",
    "robot_marker": "--robot-marker",
    "ros_distro": "--ros-distro",
    "scheduler": "--scheduler",
    "seconds": "--seconds",
    "seed": "--seed",
    "sensor_topic": "--sensor-topic",
    "settle": "--settle",
    "side": "--side",
    "silent_after": "--silent-after",
    "speed": "--speed",
    "stall_timeout": "--stall-timeout",
    "start_time": "--start-time",
    "step": "--step",
    "terrain": "--terrain",
    "time_offset": "--time-offset",
    "to": "--to",
    "truth": "--truth",
    "truth_out": "--truth-out",
    "turns": "--turns",
    "validate": "--validate",
    "virtual": "--virtual",
    "watchdog": "--watchdog",
    "window": "--window",
    "workers": "--workers",
    "x": "--x",
    "y": "--y",
    "angle": "--angle",
    "angle_pi": "--angle-pi",
    "create_campaign": "--create-campaign",
    "duty": "--duty",
    "encoder_dir": "--encoder-dir",
    "foxglove": "--foxglove",
    "idle_exit": "--idle-exit",
    "interval": "--interval",
    "jpeg": "--jpeg",
    "led_hz": "--led-hz",
    "predicted_heading": "--predicted-heading",
    "scan_topic": "--scan-topic",
}

#: The CLI's wording.
CLI = Wording(FLAGS, "the command line")


def flag(option: str) -> str:
    """The flag of setting ``option`` (``nees_segment`` -> ``--nees-segment``)."""
    return CLI.word(option)


def worded(err: BaseException) -> str:
    """The sentence of ``err`` with the flags the user typed."""
    return CLI.error(err)


def said(text: object) -> str:
    """A library text (a hint, a choice made) with the flags the user typed."""
    return CLI.error(text) if isinstance(text, BaseException) else CLI.say(str(text))
