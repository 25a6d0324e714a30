"""Physics of the virtual robot: a skid-steer robot whose true behaviour is not its nominal model.

The motors turn each sprocket at the commanded rate, so the encoders count exactly what the
nominal model asked for. The ground decides what the robot does with that: per physics step of
``dt`` seconds, a wheel that turned by the nominal surface distance ``dn`` (m) moves its side of
the robot by::

    ds = dn * rho(side, direction) * (1 - speed_slip * |v|)  +  sqrt(k_side * |ds|) * N(0, 1)

where ``rho = true effective radius / nominal radius`` for that side and direction of travel
(times the terrain's ``radius_scale``), ``v`` the wheel surface speed and ``k_side`` the per-wheel
slip constant (Chong & Kleeman; Siegwart et al.: variance ``k * |ds|``). The body then moves by
the exact circular arc with the true kinematic model (``TrueParams.model``, the differential drive
of ``track_width_true`` unless told; :mod:`odolab.core.models`)::

    ds_body = w_l ds_l + w_r ds_r                      (= (ds_r + ds_l) / 2 for a diff drive)
    dtheta  = (e_r ds_r - e_l ds_l) / (denominator * (1 - turn_slip * (1 - s)))
              +  sqrt(k_scrub * |dn_r - dn_l| / b_nom) * N(0, 1)
    lateral = model lateral * dtheta                   (-x_icr for an ICR vehicle)

where ``s = |dn_r - dn_l| / (|dn_r| + |dn_l|)`` is the commanded turn ratio (1 in place).

The last term is turn scrub: when the tracks are driven differentially the track ends skid
sideways, which adds heading noise per commanded radian of turning (zero on a straight run).
At an abrupt stop each side slides on by ``stop_slide * v**2`` (no encoder counts). On a terrain
that cannot turn in place, wheels commanded in opposite directions do not move at all (stall).

A run also starts misaligned: the person who put the robot on the tape frame got its heading
wrong by ``N(0, align_sigma)``; the true pose is reported in that tape frame. Optionally the
effective track width of a run differs from ``track_width`` by a factor ``1 + N(0, track_sigma)``
(the ground under the robot changes between runs): rotation error proportional to the angle.

:class:`VirtualRobot` steps one robot in time (for the live control loop and the virtual Jaguar
server). :func:`simulate_batch` runs many scripted trials at once (compiled loop over trials and
steps, one random generator) with the very same step function. The step is written once, as
plain Python (:mod:`odolab.sim._physics_kernels`); numba compiles it
(:mod:`odolab.sim._physics_jit`, imported on first use), and a robot made with
``compiled=False`` (the real-time ``odolab robot sim-server`` board) runs the source itself.
"""

from __future__ import annotations

import math
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from types import ModuleType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from odolab.core.defaults import DEFAULT_TERRAIN
from odolab.core.errors import SimError
from odolab.core.params import RobotParams
from odolab.core.trajectory import Pose
from odolab.sim.terrains import Terrain, get_terrain
from odolab.sim.truth import TrueParams

__all__ = [
    "BatchResult",
    "TrueParams",
    "VirtualRobot",
    "kernel_params",
    "simulate_batch",
]

# Layout of the per-trial parameter vector used by the compiled kernels.
_RHO_LF, _RHO_LR, _RHO_RF, _RHO_RR = 0, 1, 2, 3
_TRACK, _TRACK_NOM, _K_L, _K_R, _K_SCRUB = 4, 5, 6, 7, 8
_SPEED_SLIP, _STOP_SLIDE, _CAN_TURN, _MPT_L, _MPT_R = 9, 10, 11, 12, 13
# the true kinematic model's coefficients (odolab.core.models.ModelCoefficients); its denominator
# is _TRACK, so that a per-run track factor scales it
_W_L, _W_R, _E_L, _E_R, _LATERAL = 14, 15, 16, 17, 18
#: no noise draws (a noiseless or a stalled step)
_NO_DRAWS = np.empty(0)
#: most steps per kernel call in VirtualRobot.advance (their draws: 1.5 MB)
_STEPS_PER_CALL = 65_536
# turn slip: the true model's denominator (ICR spread) shrinks away from turns in place
_TURN_SLIP = 19
_NPARAM = 20


def kernel_params(truth: TrueParams, nominal: RobotParams, terrain: Terrain) -> NDArray[np.float64]:
    """The parameter vector of the compiled step, shape (20,), for one robot on one terrain."""
    p = np.zeros(_NPARAM)
    s = terrain.radius_scale * truth.radius_scale_on(terrain.name)
    p[_RHO_LF] = truth.left_radius_forward / nominal.left_wheel_radius * s
    p[_RHO_LR] = truth.left_radius_reverse / nominal.left_wheel_radius * s
    p[_RHO_RF] = truth.right_radius_forward / nominal.right_wheel_radius * s
    p[_RHO_RR] = truth.right_radius_reverse / nominal.right_wheel_radius * s
    coef = truth.model.coefficients(truth.track_width)
    p[_TRACK] = coef.denominator
    p[_W_L], p[_W_R], p[_E_L], p[_E_R], p[_LATERAL] = (
        coef.w_left, coef.w_right, coef.e_left, coef.e_right, coef.lateral,
    )  # fmt: skip
    p[_TRACK_NOM] = nominal.track_width
    p[_K_L] = truth.k_left * terrain.slip_scale
    p[_K_R] = truth.k_right * terrain.slip_scale
    p[_K_SCRUB] = truth.k_scrub * terrain.scrub_scale
    p[_SPEED_SLIP] = truth.speed_slip
    p[_STOP_SLIDE] = truth.stop_slide
    p[_CAN_TURN] = 1.0 if terrain.can_turn_in_place else 0.0
    p[_MPT_L] = nominal.left_metres_per_tick
    p[_MPT_R] = nominal.right_metres_per_tick
    p[_TURN_SLIP] = truth.turn_slip
    return p


# --------------------------------------------------------------------------- batch API


@dataclass(frozen=True, eq=False)
class BatchResult:
    """What :func:`simulate_batch` returns for n trials.

    ``ticks_left``/``ticks_right``: shape (n, m) int64, continuous wheel counts (not wrapped,
    starting at 0) at the report instants ``k / report_rate``; only the first ``n_samples[i]``
    entries of row i are valid. ``final_pose``: (n, 3) true x, y, heading in the tape frame.
    ``start_heading``: (n,) the start misalignment. ``stalled``: (n,) bool.
    ``track_width``: (n,) the effective track width of each run.
    """

    ticks_left: NDArray[np.int64]
    ticks_right: NDArray[np.int64]
    n_samples: NDArray[np.int64]
    final_pose: NDArray[np.float64]
    start_heading: NDArray[np.float64]
    stalled: NDArray[np.bool_]
    track_width: NDArray[np.float64]
    report_rate: float


def _physics_jit() -> ModuleType:
    """The compiled physics (:mod:`odolab.sim._physics_jit`; importing it imports numba)."""
    from odolab.sim import _physics_jit

    return _physics_jit


#: The signals whose handlers :func:`_signals_held` holds back.
_HELD_SIGNALS = (signal.SIGINT, signal.SIGTERM)


@contextmanager
def _signals_held() -> Iterator[None]:
    """Ctrl-C and SIGTERM wait until the batch kernel has returned, then act as they would have.

    The kernel takes a Generator, which numba unboxes with Python code (ctypes); an exception
    that a signal handler raises there crashes numba (a segfault). The compiled loop itself
    cannot be interrupted anyway, so only that instant moves. Signal handlers run in the main
    thread only, so a call from any other thread has nothing to hold."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    before: dict[int, Any] = {}
    try:
        for sig in _HELD_SIGNALS:
            old = signal.getsignal(sig)
            if old is not signal.SIG_IGN and old is not None:
                before[sig] = signal.signal(sig, lambda signum, _frame: caught.append(signum))
        yield
    finally:
        raised: BaseException | None = None
        for held, handler in before.items():  # every handler back, even if a signal lands now
            try:
                signal.signal(held, handler)
            except BaseException as exc:  # re-raised below, once every handler is back
                raised = raised or exc
        # the handlers the program had, now: SIGTERM first (Ctrl-C's KeyboardInterrupt would
        # end the replay), each once
        for signum in sorted(set(caught), key=lambda s: s != signal.SIGTERM):
            signal.raise_signal(signum)
        if raised is not None:
            raise raised


def simulate_batch(
    params: NDArray[np.float64],
    seg_ticks_left: NDArray[np.int64],
    seg_ticks_right: NDArray[np.int64],
    seg_speed_left: NDArray[np.float64],
    seg_speed_right: NDArray[np.float64],
    n_segments: NDArray[np.int64],
    *,
    align_sigma: NDArray[np.float64] | float = 0.0,
    track_sigma: float = 0.0,
    report_rate: float = 20.0,
    dt: float = 0.025,
    stall_time: float = 2.0,
    rng: np.random.Generator,
) -> BatchResult:
    """Run n scripted trials at once (compiled; no Python loop per trial).

    ``params``: (n, 20) from :func:`kernel_params`. ``seg_*``: (n, s) per-segment wheel tick
    changes (signed integers) and wheel surface speeds (m/s, same signs); ``n_segments``: (n,).
    ``dt`` must divide the report period. A trial whose wheels are told to turn in opposite
    directions on a terrain that cannot turn in place stalls: its counters stand still for
    ``stall_time`` seconds of reports, then it is abandoned.
    """
    P = np.ascontiguousarray(params, dtype=np.float64)
    n = P.shape[0]
    spr_f = 1.0 / (report_rate * dt)
    spr = round(spr_f)
    if spr < 1 or abs(spr - spr_f) > 1e-6:
        raise SimError(
            f"physics step dt={dt} s must divide the report period 1/{report_rate} s exactly"
        )
    seg_l = np.ascontiguousarray(seg_ticks_left, dtype=np.float64)
    seg_r = np.ascontiguousarray(seg_ticks_right, dtype=np.float64)
    vl = np.ascontiguousarray(seg_speed_left, dtype=np.float64)
    vr = np.ascontiguousarray(seg_speed_right, dtype=np.float64)
    nseg = np.ascontiguousarray(n_segments, dtype=np.int64)
    if (np.sign(seg_l) * np.sign(vl) < 0).any() or (np.sign(seg_r) * np.sign(vr) < 0).any():
        raise SimError("segment tick changes and wheel speeds must have the same signs")
    moving = (seg_l != 0) & (vl == 0) | (seg_r != 0) & (vr == 0)
    if moving.any():
        raise SimError("a segment asks a wheel to turn at zero speed")
    # upper bound of report samples per trial
    mpt = np.stack([P[:, _MPT_L], P[:, _MPT_R]], axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        steps_l = np.where(vl != 0, np.abs(seg_l) * mpt[:, :1] / np.abs(vl) / dt, 0.0)
        steps_r = np.where(vr != 0, np.abs(seg_r) * mpt[:, 1:] / np.abs(vr) / dt, 0.0)
    steps = np.ceil(np.maximum(steps_l, steps_r)) + 2
    cols = np.arange(seg_l.shape[1])[None, :] < nseg[:, None]
    reports = np.where(cols, np.ceil(steps / spr) + 1, 0).sum(axis=1)
    stall_reports = max(1, round(stall_time * report_rate))
    m = int(reports.max(initial=0)) + stall_reports + 2
    h0 = np.broadcast_to(np.asarray(align_sigma, dtype=np.float64), (n,)) * rng.standard_normal(n)
    h0 = np.ascontiguousarray(h0)
    if track_sigma > 0:
        P = P.copy()
        P[:, _TRACK] *= np.maximum(1.0 + track_sigma * rng.standard_normal(n), 0.05)
    out_l = np.zeros((n, m), dtype=np.int64)
    out_r = np.zeros((n, m), dtype=np.int64)
    out_len = np.zeros(n, dtype=np.int64)
    out_pose = np.zeros((n, 3))
    out_stalled = np.zeros(n, dtype=np.bool_)
    from odolab.sim._physics_jit import _batch

    with _signals_held():
        _batch(
            P, seg_l, seg_r, vl, vr, nseg, h0, spr, float(dt), stall_reports, rng,
            out_l, out_r, out_len, out_pose, out_stalled,
        )  # fmt: skip
    return BatchResult(
        out_l, out_r, out_len, out_pose, h0, out_stalled, P[:, _TRACK].copy(), float(report_rate)
    )


# --------------------------------------------------------------------------- one robot in time


class VirtualRobot:
    """One virtual robot stepped in time, with the same physics as :func:`simulate_batch`.

    ``set_wheel_speeds(left, right)`` commands wheel surface speeds (m/s, as the nominal model
    understands them); ``advance(duration)`` integrates at ``dt``; ``encoder_counts()`` returns the
    raw counters (wrapped at ``nominal.encoder_modulus``); ``true_pose`` is the true pose in the
    tape frame (heading unwrapped). ``reset`` puts the robot at ``start`` with the start
    misalignment drawn from ``truth.align_sigma`` (pass ``misalign=False`` to place it exactly).
    """

    def __init__(
        self,
        truth: TrueParams,
        nominal: RobotParams,
        terrain: str | Terrain = DEFAULT_TERRAIN,
        *,
        seed: int = 0,
        dt: float = 0.001,
        compiled: bool = True,
    ) -> None:
        if not (isinstance(dt, int | float) and math.isfinite(dt) and dt > 0):
            raise SimError(f"physics step dt must be a positive number of seconds, got {dt!r}")
        self.truth = truth
        self.nominal = nominal
        self.terrain = get_terrain(terrain)
        self.dt = float(dt)
        self._p = kernel_params(truth, nominal, self.terrain)
        self._base_track = float(self._p[_TRACK])
        self._rng = np.random.default_rng(seed)
        m = nominal.encoder_modulus
        self._offset_l = int(self._rng.integers(0, m)) if m else 0
        self._offset_r = int(self._rng.integers(0, m)) if m else 0
        self._state = np.zeros(5)
        self._vl = 0.0
        self._vr = 0.0
        self._time = 0.0
        self._stalled = False
        self.compiled = compiled
        self.reset()

    def _kernels(self) -> ModuleType:
        """The step's kernels: numba's (:mod:`odolab.sim._physics_jit`, loaded on first use), or
        with ``compiled=False`` their plain-Python source (:mod:`odolab.sim._physics_kernels`:
        the same numbers; for a robot stepped in real time, whose process then loads no numba)."""
        if self.compiled:
            return _physics_jit()
        from odolab.sim import _physics_kernels

        return _physics_kernels

    def reset(
        self, start: tuple[float, float, float] = (0.0, 0.0, 0.0), *, misalign: bool = True
    ) -> None:
        """Stop, put the robot at ``start`` (x, y, heading) plus the start misalignment.

        The time and the encoder counters keep running (a real robot's counters do)."""
        x0, y0, h0 = (float(v) for v in start)
        if not all(math.isfinite(v) for v in (x0, y0, h0)):
            raise SimError(f"start pose must be finite numbers, got {start!r}")
        if misalign and self.truth.align_sigma > 0:
            h0 += self.truth.align_sigma * float(self._rng.standard_normal())
        if self.truth.track_sigma > 0:
            factor = max(1.0 + self.truth.track_sigma * float(self._rng.standard_normal()), 0.05)
            self._p[_TRACK] = self._base_track * factor
        self._state[0:3] = (x0, y0, h0)
        self._vl = 0.0
        self._vr = 0.0
        self._stalled = False

    @property
    def time(self) -> float:
        """Simulated time (s)."""
        return self._time

    @property
    def stalled(self) -> bool:
        """True while the commanded wheel speeds cannot move the robot (turn in place outdoors)."""
        return self._stalled

    @property
    def wheel_speeds(self) -> tuple[float, float]:
        """The commanded (left, right) wheel surface speeds (m/s)."""
        return self._vl, self._vr

    def set_wheel_speeds(self, left: float, right: float) -> None:
        """Command wheel surface speeds (m/s). Going to (0, 0) from motion is an abrupt stop."""
        vl, vr = float(left), float(right)
        if not (math.isfinite(vl) and math.isfinite(vr)):
            raise SimError(f"wheel speeds must be finite, got {left!r}, {right!r}")
        if vl == 0.0 and vr == 0.0 and (self._vl != 0.0 or self._vr != 0.0) and not self._stalled:
            x, y, h = self._kernels()._slide(
                self._state[0], self._state[1], self._state[2], self._vl, self._vr, self._p
            )
            self._state[0:3] = (x, y, h)
        self._vl, self._vr = vl, vr
        self._stalled = (not self.terrain.can_turn_in_place) and vl * vr < 0.0

    def advance(self, duration: float) -> None:
        """Integrate ``duration`` seconds at the fixed step (a shorter last step if needed)."""
        d, n, rest = self._steps_of(duration)
        advance = self._kernels()._advance
        while n > 0:  # in blocks: the draws of one block in memory at a time
            k = min(n, _STEPS_PER_CALL)
            self._stalled = bool(
                advance(self._state, self._p, self._vl, self._vr, self.dt, k, self._normals(k))
            )
            n -= k
        if rest > 0.0:
            self._stalled = bool(
                advance(self._state, self._p, self._vl, self._vr, rest, 1, self._normals(1))
            )
        self._time += d

    def run_schedule(
        self, left: NDArray[np.float64], right: NDArray[np.float64], period: float
    ) -> NDArray[np.float64]:
        """For each report k: :meth:`set_wheel_speeds` (``left[k]``, ``right[k]``), then
        :meth:`advance` (``period``); returns the rows (time, wheel ticks left and right as
        :meth:`wheel_ticks`, x, y, unwrapped heading) after each, shape (reports, 6). The same
        numbers as those calls one by one (the draws taken from the same generator in the same
        order), in one compiled loop instead of a few microseconds of Python per report."""
        vl = np.ascontiguousarray(left, dtype=np.float64)
        vr = np.ascontiguousarray(right, dtype=np.float64)
        if vl.shape != vr.shape or vl.ndim != 1:
            raise SimError(
                f"a schedule needs as many left as right speeds, got {vl.shape}, {vr.shape}"
            )
        if not (np.isfinite(vl).all() and np.isfinite(vr).all()):
            raise SimError("wheel speeds must be finite")
        d, n, rest = self._steps_of(period)
        p = self._p
        per_step = self._draws_per_step()
        moving = int(np.count_nonzero(~((p[_CAN_TURN] == 0.0) & (vl * vr < 0.0))))
        total = moving * (n + (1 if rest > 0.0 else 0)) * per_step
        z = self._rng.standard_normal(total) if total else _NO_DRAWS
        out = np.empty((vl.size, 6))
        if vl.size == 0:
            return out
        self._stalled = bool(
            _physics_jit()._run_schedule(
                self._state, p, vl, vr, self._vl, self._vr, self._stalled, d, self.dt, n, rest,
                z, self._time, out,
            )
        )  # fmt: skip
        self._vl, self._vr = float(vl[-1]), float(vr[-1])
        self._time = float(out[-1, 0])
        return out

    def _normals(self, steps: int) -> NDArray[np.float64]:
        """The standard normal draws of ``steps`` steps, in the order the kernel uses them.

        They are drawn here, not by the kernel from the Generator: a Generator passed into
        compiled code is unboxed by Python code (ctypes), and an exception raised there by a
        signal handler (Ctrl-C, the board's SIGTERM) crashed numba (a segfault, 1 board run in
        60). The same Generator gives the same draws, so the motion is unchanged."""
        if self._stalled:  # set by set_wheel_speeds with the kernel's rule: it draws nothing
            return _NO_DRAWS
        per_step = self._draws_per_step()
        return self._rng.standard_normal(steps * per_step) if per_step else _NO_DRAWS

    def _draws_per_step(self) -> int:
        """The standard normal draws one moving step uses (left, right, scrub: those whose
        sigma is set; the kernels' ``_draws_per_step``)."""
        p = self._p
        return int(p[_K_L] != 0.0) + int(p[_K_R] != 0.0) + int(p[_K_SCRUB] != 0.0)

    def _steps_of(self, duration: object) -> tuple[float, int, float]:
        """``duration`` (s) checked, as (duration, whole steps of ``dt``, the shorter last
        step, 0 when there is none)."""
        d = float(duration)  # type: ignore[arg-type]
        if not math.isfinite(d) or d < 0:
            raise SimError(f"advance duration must be a finite number >= 0, got {duration!r}")
        n = math.floor(d / self.dt + 1e-9)
        rest = d - n * self.dt
        return d, n, rest if rest > 1e-12 * self.dt else 0.0

    def wheel_ticks(self) -> tuple[float, float]:
        """Continuous (unwrapped, fractional) wheel positions in counts since construction."""
        return float(self._state[3]), float(self._state[4])

    def encoder_counts(self) -> tuple[int, int]:
        """Raw counters (left, right), wrapped at the nominal encoder modulus."""
        left = self._offset_l + math.floor(self._state[3] + 0.5)
        right = self._offset_r + math.floor(self._state[4] + 0.5)
        m = self.nominal.encoder_modulus
        if m:
            return left % m, right % m
        return left, right

    @property
    def true_pose(self) -> Pose:
        """The true pose now (tape frame; heading unwrapped)."""
        x, y, h = (float(v) for v in self._state[0:3])
        a = h + math.pi
        theta = a - 2.0 * math.pi * math.floor(a / (2.0 * math.pi)) - math.pi
        if theta <= -math.pi:
            theta += 2.0 * math.pi
        return Pose(self._time, x, y, theta, h)
