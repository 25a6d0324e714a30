"""A simulated phone taped to a robot, and a stand-alone rotation scenario for demos and tests.

:func:`simulate_phone_log` gives what a phone would log given the robot's TRUE heading (from a
simulator's truth): its own clock (offset from the robot's), its own sample rate, a gyro with
white noise and a constant bias, and a yaw that is the integral of that gyro (so it drifts, as
Core Motion's yaw does without a magnetometer) from an arbitrary zero.

:func:`rotation_scenario` makes, without the robot simulator, a robot turning in place whose TRUE
track width differs from the nominal one: the encoder counts the tracks really made, the true
heading, and the parameter sets "old" (nominal) and "new" (corrected), as in the lab's
section VIII. :func:`write_demo` writes it all to files for ``odolab validate``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from odolab.core.arrays import FloatArray
from odolab.core.defaults import DEFAULT_ROBOT
from odolab.core.errors import ImuLogError
from odolab.core.params import PRESETS, RobotParams, save_params
from odolab.core.trials import EncoderLog
from odolab.validation.sensorlog import ImuLog, write_sensorlog

__all__ = ["RotationScenario", "rotation_scenario", "simulate_phone_log", "write_demo"]


def simulate_phone_log(
    true_t: ArrayLike,
    true_heading: ArrayLike,
    *,
    clock_offset: float,
    rate_hz: float = 100.0,
    gyro_noise: float = 0.005,
    bias: float = 0.0,
    yaw0: float | None = None,
    seed: int = 0,
) -> ImuLog:
    """A phone's log of a robot whose true heading is ``true_heading`` (rad) at ``true_t`` (s,
    robot clock), shape (n,) each.

    The phone samples at ``rate_hz`` over the same span; its clock reads ``clock_offset``
    seconds more than the robot's (``t_phone = t_robot + clock_offset``). Its gyro is the true
    rate plus ``bias`` (rad/s) plus white noise of standard deviation ``gyro_noise`` (rad/s);
    its yaw is the integral of that gyro from ``yaw0`` (random by default: yaw has an arbitrary
    zero): the true heading change plus the drift of the bias and of the integrated noise. The
    truth is interpolated between its samples by a cubic spline. All randomness comes from
    ``np.random.default_rng(seed)``.

    Raises:
        ImuLogError: the inputs are out of range.
    """
    t = np.asarray(true_t, dtype=np.float64)
    h = np.asarray(true_heading, dtype=np.float64)
    if t.ndim != 1 or h.shape != t.shape or t.size < 2 or np.any(np.diff(t) <= 0):
        raise ImuLogError("true_t and true_heading must be 1-D, equally long, t increasing")
    if not rate_hz > 0:
        raise ImuLogError(f"rate_hz must be positive, got {rate_hz!r}")
    rng = np.random.default_rng(seed)
    step = 1.0 / rate_hz
    t_robot = t[0] + step * np.arange(math.floor((t[-1] - t[0]) / step) + 1)
    # the truth between its samples: a cubic spline (exact for cubics; smooth rate)
    from scipy import interpolate  # (0.5 s to import: when a phone log is simulated)

    spline = interpolate.CubicSpline(t, h)
    true_rate = np.asarray(spline(t_robot, 1), dtype=np.float64)
    noise = gyro_noise * rng.standard_normal(t_robot.size)
    gyro = true_rate + bias + noise
    start = float(rng.uniform(-math.pi, math.pi)) if yaw0 is None else float(yaw0)
    # yaw = the integral of the gyro: the true heading change plus drift from bias and noise
    drift = bias * (t_robot - t_robot[0]) + np.concatenate(
        ([0.0], np.cumsum(0.5 * (noise[1:] + noise[:-1]) * step))
    )
    yaw = (
        start + (np.asarray(spline(t_robot), dtype=np.float64) - float(spline(t_robot[0]))) + drift
    )
    return ImuLog(
        t_robot + clock_offset,
        yaw,
        gyro,
        source="simulated phone",
        heading_column="motionYaw(rad)",
        rate_column="motionRotationRateZ(rad/s)",
        time_column="motionTimestamp_sinceReboot(s)",
    )


@dataclass(frozen=True, eq=False)
class RotationScenario:
    """A robot turning in place: the encoder log it wrote, its true heading, the nominal
    parameters (``old``) and the parameters with the true track width (``new``)."""

    encoder_log: EncoderLog
    true_t: FloatArray
    true_heading: FloatArray
    old: RobotParams
    new: RobotParams


def rotation_scenario(
    *,
    turns: float = 3.0,
    rate: float = 0.8,
    ramp: float = 2.0,
    rest: float = 3.0,
    control_hz: float = 20.0,
    true_track_width: float | None = None,
    nominal: RobotParams | None = None,
    slip_noise: float = 0.002,
    seed: int = 0,
) -> RotationScenario:
    """A robot that rests, speeds up to ``rate`` (rad/s, true) over ``ramp`` seconds, turns
    ``turns`` full turns counter-clockwise in place, slows down and rests again.

    Its true track width defaults to the nominal one / 0.875 (the lab's Table I: actual/predicted
    rotation 0.875), so the nominal odometry over-estimates rotation by 1/0.875. ``slip_noise``
    (rad/s, white) perturbs the true rate a little. The encoder log has counters that wrap at
    the nominal modulus, sampled at ``control_hz``.
    """
    old = nominal or PRESETS[DEFAULT_ROBOT]
    track = old.track_width / 0.875 if true_track_width is None else float(true_track_width)
    new = old.with_(track_width=track, name=f"{old.name}-corrected")
    rng = np.random.default_rng(seed)
    dt = 1.0 / control_hz
    cruise = max(2.0 * math.pi * turns / rate - ramp, 0.0)
    total = 2.0 * rest + 2.0 * ramp + cruise
    t = dt * np.arange(math.ceil(total / dt) + 1, dtype=np.float64)
    # trapezoidal rate profile: rest, ramp up, cruise, ramp down, rest
    u = t - rest
    profile = np.clip(np.minimum(u / ramp, (2.0 * ramp + cruise - u) / ramp), 0.0, 1.0)
    true_rate = rate * profile
    moving = profile > 0
    true_rate = true_rate + moving * slip_noise * rng.standard_normal(t.size)
    heading: FloatArray = np.concatenate(
        ([0.0], np.cumsum(0.5 * (true_rate[1:] + true_rate[:-1]) * dt))
    )
    # tracks: right forward, left back by track/2 * dheading (the truth uses the true track)
    arc = 0.5 * track * heading
    right = np.floor(arc / old.right_metres_per_tick).astype(np.int64)
    left = np.floor(-arc / old.left_metres_per_tick).astype(np.int64)
    modulus = old.encoder_modulus
    start = 1000
    if modulus is not None:
        right = (right + start) % modulus
        left = (left + start) % modulus
    log = EncoderLog(t, left, right, modulus)
    return RotationScenario(log, t, heading, old, new)


def write_demo(
    outdir: str | Path,
    *,
    clock_offset: float = 2.0 * 3600.0 + 17.25,
    turns: float = 10.0,
    seed: int = 0,
) -> dict[str, Path]:
    """Write a complete validation demo into ``outdir``: ``encoder.csv`` (robot clock),
    ``sensorlog.csv`` (a phone whose clock reads ``clock_offset`` s more), ``new.toml`` (the
    corrected parameters; the old ones are the ``jaguar-lite`` preset). The robot turns in place
    ``turns`` times (10 = the lab's 20 pi). Returns the paths."""
    from odolab.io import write_encoder_csv

    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    sc = rotation_scenario(turns=turns, seed=seed)
    phone = simulate_phone_log(
        sc.true_t, sc.true_heading, clock_offset=clock_offset, bias=0.002, seed=seed + 1
    )
    rate = phone.yaw_rate if phone.yaw_rate is not None else np.gradient(phone.yaw, phone.t)
    paths = {
        "encoder_log": write_encoder_csv(out / "encoder.csv", sc.encoder_log),
        "imu_log": write_sensorlog(out / "sensorlog.csv", phone.t, phone.yaw, rate),
        "new_params": save_params(
            out / "new.toml", sc.new, provenance={"source": "odolab validation demo"}
        ),
    }
    return paths
