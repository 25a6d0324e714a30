"""A simulated differential-drive robot with a gyro: one minute of mixed turning.

:func:`simulate_gyro_drive` drives a robot whose TRUE wheel radii and track are known through a
random program (standing still, turning in place both ways, straight runs forwards and
backwards, arcs), with smooth speed changes. Its encoders count whole ticks at
``encoder_hz``; its gyro, on its own clock ``clock_offset`` seconds ahead, reads
``scale * true yaw rate + bias + white noise`` at ``gyro_hz``, the noise of density
``noise_density`` (rad/s/sqrt(Hz): a standard deviation of ``noise_density * sqrt(gyro_hz)``
per sample). No wheel slips: the true yaw rate is ``(r_R phidot_R - r_L phidot_L) / B``.
:func:`write_gyro_drive` writes it as an encoder log and its ``NAME_imu.csv``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from odolab.core.arrays import FloatArray
from odolab.core.params import PRESETS, RobotParams
from odolab.core.trials import EncoderLog
from odolab.core.writing import write_text_file
from odolab.io.encoder_csv import write_encoder_csv
from odolab.io.gyro import GyroRun, GyroSegment

__all__ = ["GyroDrive", "simulate_gyro_drive", "write_gyro_drive"]


@dataclass(frozen=True, eq=False)
class GyroDrive:
    """The simulated run, the truth it came from, and the gyro's true errors."""

    run: GyroRun
    truth: RobotParams
    nominal: RobotParams
    bias: float
    scale: float
    clock_offset: float
    noise_density: float
    turned: float  #: the true net heading change over the encoder log (rad)
    encoder_log: EncoderLog
    gyro_t: FloatArray
    gyro_wz: FloatArray


def _program(rng: np.random.Generator, duration: float) -> list[tuple[float, float, float]]:
    """(seconds, v m/s, omega rad/s) legs: still at both ends, the rest shuffled."""
    legs = [
        (rng.uniform(6, 8), 0.0, 2.0),
        (rng.uniform(6, 8), 0.0, 2.0 * rng.uniform(0.8, 1.1)),
        (rng.uniform(4, 5), 0.0, -1.5),
        (rng.uniform(7, 9), rng.uniform(0.7, 0.9), 0.0),
        (rng.uniform(6, 8), -rng.uniform(0.6, 0.8), 0.0),
        (rng.uniform(5, 6), 0.6, rng.uniform(0.6, 1.0)),
        (rng.uniform(5, 6), 0.6, -rng.uniform(0.6, 1.0)),
        (2.0, 0.0, 0.0),
    ]
    order = rng.permutation(len(legs))
    body = [legs[int(i)] for i in order]
    total = sum(d for d, _, _ in body)
    still = max(duration - total, 2.0) / 2.0
    return [(still, 0.0, 0.0), *body, (still, 0.0, 0.0)]


def _speeds(
    legs: list[tuple[float, float, float]], fine: float, ramp: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The legs' (duration, v, w) on a ``fine`` time grid: (t, v, w), speed changes smoothed by
    a Hann window of ``ramp`` seconds."""
    total = sum(d for d, _, _ in legs)
    n = math.ceil(total / fine) + 1
    tf = np.asarray(fine * np.arange(n), dtype=np.float64)
    v = np.zeros(n)
    w = np.zeros(n)
    t0 = 0.0
    for d, vv, ww in legs:
        sel = (tf >= t0) & (tf < t0 + d)
        v[sel], w[sel] = vv, ww
        t0 += d
    k = np.hanning(max(3, round(ramp / fine)))
    k /= k.sum()
    return tf, np.convolve(v, k, mode="same"), np.convolve(w, k, mode="same")


def simulate_gyro_drive(
    *,
    seed: int = 0,
    duration: float = 60.0,
    nominal: RobotParams | None = None,
    track_factor: float = 1.07,
    radius_ratio: float = 1.01,
    encoder_hz: float = 20.0,
    gyro_hz: float = 100.0,
    bias: float = 0.01,
    scale: float = 1.005,
    noise_density: float = 0.005,
    clock_offset: float = 0.04,
    ramp: float = 0.6,
) -> GyroDrive:
    """One run of mixed turning (see the module). The true robot has the nominal mean wheel
    radius, the track ``track_factor`` times the nominal one and ``r_R / r_L = radius_ratio``.
    All randomness comes from ``np.random.default_rng(seed)``."""
    nom = nominal or PRESETS["jaguar-lite"]
    r_mean = 0.5 * (nom.left_wheel_radius + nom.right_wheel_radius)
    rl = 2.0 * r_mean / (1.0 + radius_ratio)
    truth = nom.with_(
        left_wheel_radius=rl,
        right_wheel_radius=rl * radius_ratio,
        track_width=nom.track_width * track_factor,
        name=f"{nom.name}-true",
    )
    rng = np.random.default_rng(seed)
    legs = _program(rng, duration)
    fine = 1e-3
    tf, v, w = _speeds(legs, fine, ramp)
    b = truth.track_width
    rate_r = (v + 0.5 * b * w) / truth.right_wheel_radius
    rate_l = (v - 0.5 * b * w) / truth.left_wheel_radius
    phi_r = np.concatenate(([0.0], np.cumsum(0.5 * (rate_r[1:] + rate_r[:-1]) * fine)))
    phi_l = np.concatenate(([0.0], np.cumsum(0.5 * (rate_l[1:] + rate_l[:-1]) * fine)))
    omega = (truth.right_wheel_radius * rate_r - truth.left_wheel_radius * rate_l) / b
    heading = (truth.right_wheel_radius * phi_r - truth.left_wheel_radius * phi_l) / b
    # encoders: whole ticks from a random phase, at encoder_hz
    te = np.arange(0.0, tf[-1] + 1e-12, 1.0 / encoder_hz)
    tpr = truth.ticks_per_rev
    ph = rng.uniform(0.0, 1.0, 2)
    ticks_r = np.floor(np.interp(te, tf, phi_r) * tpr / (2 * math.pi) + ph[0]).astype(np.int64)
    ticks_l = np.floor(np.interp(te, tf, phi_l) * tpr / (2 * math.pi) + ph[1]).astype(np.int64)
    # the gyro, on its own clock: t_gyro = t_robot + clock_offset
    tg = np.arange(0.0, tf[-1] + 1e-12, 1.0 / gyro_hz) + clock_offset
    sigma = noise_density * math.sqrt(gyro_hz)
    wz = scale * np.interp(tg - clock_offset, tf, omega) + bias
    wz = wz + sigma * rng.standard_normal(tg.size)
    to_rad = 2 * math.pi / tpr
    seg = GyroSegment(
        te,
        to_rad * (ticks_l - ticks_l[0]).astype(np.float64),
        to_rad * (ticks_r - ticks_r[0]).astype(np.float64),
        tg,
        wz,
        tf[::10].copy(),
        heading[::10].copy(),
    )
    run = GyroRun(f"sim-gyro-{seed}", f"simulated run {seed}", f"simulated gyro {seed}", (seg,))
    start = 1000
    modulus = nom.encoder_modulus
    lt, rt = ticks_l - ticks_l[0] + start, ticks_r - ticks_r[0] + start
    if modulus is not None:
        lt, rt = lt % modulus, rt % modulus
    log = EncoderLog(te, lt, rt, modulus)
    turned = float(np.interp(te[-1], tf, heading) - np.interp(te[0], tf, heading))
    return GyroDrive(run, truth, nom, bias, scale, clock_offset, noise_density, turned, log, tg, wz)


def write_gyro_drive(folder: str | Path, drive: GyroDrive, name: str = "drive") -> Path:
    """Write ``NAME.csv`` (the encoder log) and ``NAME_imu.csv`` (``t,wz``) in ``folder``;
    return the encoder log's path."""
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    log_path = write_encoder_csv(out / f"{name}.csv", drive.encoder_log)
    rows = ["t,wz", *(f"{t:.6f},{w:.7f}" for t, w in zip(drive.gyro_t, drive.gyro_wz, strict=True))]
    write_text_file(out / f"{name}_imu.csv", "\n".join(rows) + "\n", what="gyro log")
    return log_path
