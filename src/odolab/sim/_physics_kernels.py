"""The virtual robot's physics step as plain Python, the one source of both ways it runs.

:mod:`odolab.sim._physics_jit` compiles each of these with numba (its twin, made from this
source: :func:`odolab.core._jit.twin`) for the scripted batches and the schedules of
:mod:`odolab.sim.physics`; a :class:`~odolab.sim.physics.VirtualRobot` made with
``compiled=False`` (the ``odolab robot sim-server`` board, which runs in real time: a 50 ms
cycle's 50 steps take about half a millisecond as Python) calls them here, and its process does
not load numba (a server serving one drive: 0.59 s of CPU against 1.87 s with numba's physics,
benchmarks/bench_sim_server_process.py). The same
operations in the same order, so both ways give the same numbers (tests/sim/test_plain_physics.py).
The kernels take the parameter vector of :func:`odolab.sim.physics.kernel_params`.
"""

from __future__ import annotations

import math

from odolab.core._step_kernels import body_motion, step_pose
from odolab.core.arrays import FloatArray

__all__ = ["_advance", "_denominator", "_move", "_slide", "_step"]


def _denominator(p: FloatArray, dnl: float, dnr: float) -> float:
    """The true model's turning denominator for commanded wheel motions dnl, dnr (turn slip)."""
    if p[19] == 0.0:
        return float(p[4])
    total = abs(dnl) + abs(dnr)
    s = abs(dnr - dnl) / total if total > 0.0 else 1.0
    return float(p[4] * (1.0 - p[19] * (1.0 - s)))


def _move(
    x: float,
    y: float,
    h: float,
    dsl: float,
    dsr: float,
    p: FloatArray,
    dth_noise: float,
    den: float,
) -> tuple[float, float, float]:
    """The body's exact arc for true wheel displacements dsl, dsr through the true model."""
    fwd, side, dth = body_motion(p[14], p[15], p[16], p[17], den, p[18], dsl, dsr)
    dth += dth_noise
    side = p[18] * dth
    return step_pose(x, y, h, fwd, side, dth, True)


def _step(
    x: float, y: float, h: float, dnl: float, dnr: float, dt: float, p: FloatArray,
    zl: float, zr: float, zs: float,
) -> tuple[float, float, float]:  # fmt: skip
    """One physics step: nominal wheel surface displacements dnl, dnr (m) -> new true pose."""
    rl = p[0] if dnl >= 0.0 else p[1]
    rr = p[2] if dnr >= 0.0 else p[3]
    if p[9] != 0.0 and dt > 0.0:
        rl *= max(0.0, 1.0 - p[9] * abs(dnl) / dt)
        rr *= max(0.0, 1.0 - p[9] * abs(dnr) / dt)
    dsl = dnl * rl
    dsr = dnr * rr
    if p[6] != 0.0:
        dsl += math.sqrt(p[6] * abs(dsl)) * zl
    if p[7] != 0.0:
        dsr += math.sqrt(p[7] * abs(dsr)) * zr
    noise = 0.0
    if p[8] != 0.0:
        noise = math.sqrt(p[8] * abs(dnr - dnl) / p[5]) * zs
    return _move(x, y, h, dsl, dsr, p, noise, _denominator(p, dnl, dnr))


def _slide(
    x: float, y: float, h: float, vl: float, vr: float, p: FloatArray
) -> tuple[float, float, float]:
    """Abrupt stop from wheel speeds vl, vr (m/s): each side slides on by stop_slide * v^2."""
    if p[10] == 0.0:
        return x, y, h
    dsl = math.copysign(p[10] * vl * vl, vl)
    dsr = math.copysign(p[10] * vr * vr, vr)
    return _move(x, y, h, dsl, dsr, p, 0.0, _denominator(p, vl, vr))


def _advance(
    state: FloatArray, p: FloatArray, vl: float, vr: float, dt: float, nsteps: int, z: FloatArray
) -> bool:
    """Advance a single robot nsteps at dt with wheel speeds vl, vr (m/s).

    state = [x, y, h, wheel_l_ticks, wheel_r_ticks]; ``z``: the steps' standard normal draws,
    in order (left, right, slip of each step; only those whose sigma in ``p`` is not zero).
    Returns True when stalled (then nothing moves and no draw is used)."""
    stalled = p[11] == 0.0 and vl * vr < 0.0
    if stalled:
        return True
    dnl = vl * dt
    dnr = vr * dt
    tl = dnl / p[12]
    tr = dnr / p[13]
    x = state[0]
    y = state[1]
    h = state[2]
    j = 0
    for _ in range(nsteps):
        zl = 0.0
        zr = 0.0
        zs = 0.0
        if p[6] != 0.0:
            zl = z[j]
            j += 1
        if p[7] != 0.0:
            zr = z[j]
            j += 1
        if p[8] != 0.0:
            zs = z[j]
            j += 1
        x, y, h = _step(x, y, h, dnl, dnr, dt, p, zl, zr, zs)
        state[3] += tl
        state[4] += tr
    state[0] = x
    state[1] = y
    state[2] = h
    return False
