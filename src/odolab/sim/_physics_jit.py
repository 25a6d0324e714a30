"""The virtual robot's compiled physics (numba), in its own module so that importing
:mod:`odolab.sim.physics` does not import numba: :mod:`odolab.sim.physics` loads it on first use.

The step's kernels are the twins of :mod:`odolab.sim._physics_kernels` (the same source,
compiled: :func:`odolab.core._jit.twin`, with the pose step's own twins of
:mod:`odolab.core._kinematics_jit`); the loops over a schedule and over scripted trials are
numba's only.
"""

from __future__ import annotations

import math

from odolab.core import _kinematics_jit as _kinematics
from odolab.core._jit import njit, twin
from odolab.sim import _physics_kernels as _plain

__all__ = ["_advance", "_batch", "_run_schedule", "_slide"]

#: The plain module's names, with each kernel replaced by its twin as it is made.
_TWINS: dict[str, object] = dict(vars(_plain))
_TWINS["body_motion"] = _kinematics.body_motion
_TWINS["step_pose"] = _kinematics.step_pose

_denominator = twin(_plain._denominator, _TWINS)
_move = twin(_plain._move, _TWINS)
_step = twin(_plain._step, _TWINS)
_slide = twin(_plain._slide, _TWINS)
_advance = twin(_plain._advance, _TWINS, inline=False)


@njit(cache=True)
def _run_schedule(state, p, left, right, vl0, vr0, stalled0, period, dt, nsteps, rest, z, t0, out):  # type: ignore[no-untyped-def]  # pragma: no cover
    """:meth:`VirtualRobot.run_schedule`'s loop: for each report k, the wheel speeds
    ``left[k]``, ``right[k]`` set as :meth:`~VirtualRobot.set_wheel_speeds` sets them (an abrupt
    stop slides), ``period`` advanced as :meth:`~VirtualRobot.advance` advances it (``nsteps``
    steps of ``dt``, then one of ``rest`` when it is not 0) with the draws ``z`` in order, and
    (time, wheel ticks left and right, x, y, unwrapped heading) written to ``out[k]``. The
    same operations in the same order as those methods, so the same numbers."""
    vl_prev = vl0
    vr_prev = vr0
    stalled = stalled0
    t = t0
    j = 0
    for k in range(left.shape[0]):
        vl = left[k]
        vr = right[k]
        if vl == 0.0 and vr == 0.0 and (vl_prev != 0.0 or vr_prev != 0.0) and not stalled:
            x, y, h = _slide(state[0], state[1], state[2], vl_prev, vr_prev, p)
            state[0] = x
            state[1] = y
            state[2] = h
        vl_prev = vl
        vr_prev = vr
        stalled = p[11] == 0.0 and vl * vr < 0.0
        if nsteps > 0:
            stalled = _advance(state, p, vl, vr, dt, nsteps, z[j:])
            if not stalled:
                j += nsteps * _draws_per_step(p)
        if rest > 0.0:
            stalled = _advance(state, p, vl, vr, rest, 1, z[j:])
            if not stalled:
                j += _draws_per_step(p)
        t += period
        out[k, 0] = t
        out[k, 1] = state[3]
        out[k, 2] = state[4]
        out[k, 3] = state[0]
        out[k, 4] = state[1]
        out[k, 5] = state[2]
    return stalled


@njit(cache=True, inline="always")
def _draws_per_step(p):  # type: ignore[no-untyped-def]  # pragma: no cover - compiled
    """The standard normal draws one step uses (left, right, scrub: those whose sigma is set)."""
    return int(p[6] != 0.0) + int(p[7] != 0.0) + int(p[8] != 0.0)


@njit(cache=True, inline="always")
def _toward(pos: float, step: float, target: float) -> tuple[float, bool]:  # pragma: no cover
    """A wheel's count after one step toward ``target``, and whether it stopped there."""
    n = pos + step
    if (step > 0.0 and n >= target) or (step < 0.0 and n <= target):
        return target, True
    return n, False


@njit(cache=True, inline="always")
def _report(  # type: ignore[no-untyped-def]  # pragma: no cover - compiled
    out_l, out_r, i: int, k: int, pl: float, pr: float
) -> int:
    """Record the next report of trial ``i`` (the counts rounded); its index."""
    k += 1
    out_l[i, k] = math.floor(pl + 0.5)
    out_r[i, k] = math.floor(pr + 0.5)
    return k


@njit(cache=True)
def _batch(  # type: ignore[no-untyped-def]  # pragma: no cover - compiled
    P,
    seg_l,
    seg_r,
    seg_vl,
    seg_vr,
    nseg,
    h0,
    spr,
    dt,
    stall_reports,
    rng,
    out_l,
    out_r,
    out_len,
    out_pose,
    out_stalled,
):
    """Scripted trials, one after the other, same step as :func:`_advance`.

    Segment j of trial i turns the wheels by seg_l/seg_r ticks (integers, signed) at seg_vl/seg_vr
    (m/s, signs as the ticks); the wheel stops exactly on its target count (the motor controller
    stops by encoder). Every segment starts on a report instant; after its last wheel stops the
    robot slides (abrupt stop) and stands still until the next report instant."""
    n = P.shape[0]
    for i in range(n):
        p = P[i]
        x = 0.0
        y = 0.0
        h = h0[i]
        pl = 0.0
        pr = 0.0
        k = 0
        out_l[i, 0] = 0
        out_r[i, 0] = 0
        phase = 0
        stalled = False
        for j in range(nseg[i]):
            vl = seg_vl[i, j]
            vr = seg_vr[i, j]
            if p[11] == 0.0 and vl * vr < 0.0:
                for _ in range(stall_reports):
                    k = _report(out_l, out_r, i, k, pl, pr)
                stalled = True
                break
            target_l = pl + seg_l[i, j]
            target_r = pr + seg_r[i, j]
            sl = vl * dt / p[12]
            sr = vr * dt / p[13]
            done_l = seg_l[i, j] == 0 or sl == 0.0
            done_r = seg_r[i, j] == 0 or sr == 0.0
            while not (done_l and done_r):
                dl = 0.0
                dr = 0.0
                if not done_l:
                    nl, done_l = _toward(pl, sl, target_l)
                    dl = nl - pl
                    pl = nl
                if not done_r:
                    nr, done_r = _toward(pr, sr, target_r)
                    dr = nr - pr
                    pr = nr
                zl = rng.standard_normal() if p[6] != 0.0 else 0.0
                zr = rng.standard_normal() if p[7] != 0.0 else 0.0
                zs = rng.standard_normal() if p[8] != 0.0 else 0.0
                x, y, h = _step(x, y, h, dl * p[12], dr * p[13], dt, p, zl, zr, zs)
                phase += 1
                if phase == spr:
                    phase = 0
                    k = _report(out_l, out_r, i, k, pl, pr)
            x, y, h = _slide(x, y, h, vl, vr, p)
            if phase != 0:
                phase = 0
                k = _report(out_l, out_r, i, k, pl, pr)
        out_len[i] = k + 1
        out_pose[i, 0] = x
        out_pose[i, 1] = y
        out_pose[i, 2] = h
        out_stalled[i] = stalled
