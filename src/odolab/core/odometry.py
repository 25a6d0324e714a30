"""Odometry: encoder counts to pose, streaming (one update per control cycle) and batch.

Both implement the lab's control loop (Figs. 6-8): per cycle, the counter increments (rollover
corrected), eqs. (3.1)-(3.4) for the wheel and body motion, (3.5)/(3.6) for the position step,
then the heading update. Both keep the unwrapped ``heading`` as state and report ``theta`` as
its wrap to (-pi, pi]; they perform the same floating-point operations in the same order, so
their poses agree to rounding (far better than 1e-9).

The batch version is compiled (numba, :mod:`odolab.core._odometry_kernels`): see :func:`integrate`
for its three passes. A log shorter than ``NUMPY_MAX_SAMPLES`` takes the same passes in numpy
instead, so that a short run (a command on a small file) never loads numba (about half a second);
the two agree to rounding (tests/core/test_odometry_numpy_path.py).
"""

from __future__ import annotations

import math
import threading
from typing import TYPE_CHECKING, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odolab.core import _step_kernels
from odolab.core.arrays import FloatArray as F64
from odolab.core.arrays import IntArray as I64
from odolab.core.encoders import EncoderUnwrapper, as_tick_array, counter_delta, default_max_dticks
from odolab.core.errors import EncoderJumpError, LogFormatError, OdolabError
from odolab.core.kinematics import Method, chord_factors, wrap_angle
from odolab.core.models import own_covariance, timed_model
from odolab.core.params import NoiseParams, RobotParams
from odolab.core.trajectory import Pose, Trajectory, check_times

if TYPE_CHECKING:
    from odolab.core.models import CovarianceStepperLike
    from odolab.core.uncertainty import CovarianceStepper

__all__ = [
    "Odometry",
    "integrate",
    "integrate_increments",
    "integrate_with_covariance",
    "warm_up",
]

_NO_LIMIT = -1
A = TypeVar("A", np.float64, np.int64)


def _check_max_dticks(max_dticks: int | None) -> None:
    """A limit must be a positive whole count (a negative one would silently mean no limit)."""
    if max_dticks is None:
        return
    if isinstance(max_dticks, bool) or int(max_dticks) != max_dticks or max_dticks < 1:
        raise OdolabError(
            f"max_dticks is {max_dticks!r}; expected a whole number of counts per cycle >= 1 "
            "(or none for the default)"
        )


#: From this many samples on, the position pass runs on several threads.
PARALLEL_MIN_SAMPLES = 200_000
#: Logs shorter than this are integrated in numpy (no compiled kernel to load: numba and the
#: cached kernels cost about 0.5 s per process), longer ones by the compiled passes. Chosen by
#: size alone, so that one log always takes the same path.
NUMPY_MAX_SAMPLES = 2048
#: Logs of at least this many samples (compiled, no sideways motion, two threads allowed) are
#: integrated by a two-stage pipeline: phase A on one thread, phases B and C on another, in
#: blocks of ``PIPELINE_BLOCK`` samples (a block's arrays stay in cache between the stages).
PIPELINE_MIN_SAMPLES = 200_000
PIPELINE_BLOCK = 65_536


def _model_arrays(params: RobotParams, n: int) -> tuple[F64, F64]:
    """The model's six coefficients, and the lateral-chord array (empty without sideways motion)."""
    c = np.array(params.coefficients, dtype=np.float64)
    return c, np.empty(n if c[5] != 0.0 else 0)


def _slip_steps(
    t: F64,
    dl: F64,
    dr: F64,
    params: RobotParams,
    arc: bool,
    h0: float,
    heading: F64,
    step: F64,
    lat: F64,
    mid: F64,
) -> float:
    """Phase A for the slip model (:mod:`odolab.core.models.slip`), whose body motion depends on
    each cycle's duration: the same arrays as the compiled phase A (``dl[0]``, ``dr[0]``
    ignored). Agrees with :class:`Odometry` to rounding."""
    model = timed_model(params.model)
    assert model is not None
    n = dl.size
    if n == 0:
        return 0.0
    dsl = dl * params.left_metres_per_tick
    dsr = dr * params.right_metres_per_tick
    dt = np.diff(t, prepend=t[0])
    fwd, side, dth = model.body_motion_arrays(dsl, dsr, dt, params.track_width)
    fwd[0] = side[0] = dth[0] = 0.0
    ch = chord_factors(dth, arc)
    dth[0] = h0
    heading[:] = np.cumsum(dth)  # the streaming order: h0 + d1 + d2 + ...
    mid[0] = h0
    mid[1:] = heading[:-1] + 0.5 * dth[1:]
    step[:] = fwd * ch
    lat[:] = side * ch
    step[0] = lat[0] = 0.0
    return float(np.max(np.abs(mid)))


def _pipelines(n: int, lat: F64, params: RobotParams, parallel: int | None) -> bool:
    """Whether a log of ``n`` samples is integrated by the two-thread pipeline
    (:func:`odolab.core._odometry_kernels.pipelined_ticks`): a long log, no sideways motion, a
    model that does not depend on time, and two threads or more allowed."""
    if n < PIPELINE_MIN_SAMPLES or lat.size or timed_model(params.model) is not None:
        return False
    from odolab.core import _jit

    threads = _jit.get_num_threads() if parallel is None else int(parallel)
    return _jit.HAVE_NUMBA and threads > 1


def _use_kernels(n: int) -> bool:
    """Whether a log of ``n`` samples takes the compiled passes (else the numpy ones)."""
    return n >= NUMPY_MAX_SAMPLES


def _check_ticks(t: F64, left: I64, right: I64, modulus: int, max_d: int) -> tuple[int, int, int]:
    """The compiled phase A's checks in numpy: (code, index, counts) of the first problem in
    sample order, the same codes (0 ok, 1/2 left/right jump, 3 time not finite, 4 time goes
    backwards) and, at one sample, the same order of checks."""
    n = left.size
    if n == 0:
        return 0, -1, 0
    dl, dr = np.diff(left), np.diff(right)
    if modulus > 0:
        dl, dr = counter_delta(dl, modulus), counter_delta(dr, modulus)
    first: tuple[int, int, int] | None = None
    flags = (
        (3, ~np.isfinite(t), None),
        (4, np.concatenate(([False], t[1:] < t[:-1])), None),
        (1, np.concatenate(([False], np.abs(dl) > max_d)) if max_d >= 0 else None, dl),
        (2, np.concatenate(([False], np.abs(dr) > max_d)) if max_d >= 0 else None, dr),
    )
    for code, flag, d in flags:
        if flag is None or not flag.any():
            continue
        i = int(np.argmax(flag))
        if first is None or i < first[1]:  # ties: the earlier check wins, as in the loop
            first = (code, i, 0 if d is None else int(d[i - 1]))
    return first if first is not None else (0, -1, 0)


def _numpy_steps(
    dl: F64,
    dr: F64,
    params: RobotParams,
    coef: F64,
    arc: bool,
    h0: float,
    heading: F64,
    step: F64,
    lat: F64,
    mid: F64,
) -> None:
    """The compiled phase A (without its checks) in numpy: the same operations in the same
    order (``dl[0]``, ``dr[0]`` ignored; the heading summed in sample order)."""
    n = dl.size
    if n == 0:
        return
    w_l, w_r, e_l, e_r, den, lateral = (float(v) for v in coef)
    dsl = dl * params.left_metres_per_tick
    dsr = dr * params.right_metres_per_tick
    dth = (e_r * dsr - e_l * dsl) / den
    fwd = w_l * dsl + w_r * dsr
    ch = chord_factors(dth, arc)
    dth[0] = h0
    heading[:] = np.cumsum(dth)
    mid[0] = h0
    mid[1:] = heading[:-1] + 0.5 * dth[1:]
    step[:] = fwd * ch
    step[0] = 0.0
    if lat.size:
        lat[:] = (lateral * dth) * ch
        lat[0] = 0.0


def _positions(
    x: F64,
    y: F64,
    lat: F64,
    heading: F64,
    theta: F64,
    x0: float,
    y0: float,
    largest_mid: float,
    parallel: int | None,
    kernels: bool,
) -> None:
    """Phases B and C: chord lengths (in x; sideways ones in lat) at mid headings (in y) into
    positions, compiled or in numpy (the same operations, numpy's sin and cos)."""
    if kernels:
        from odolab.core._odometry_kernels import _finish

        _finish(x, y, lat, heading, theta, x0, y0, largest_mid, parallel, PARALLEL_MIN_SAMPLES)
        return
    if x.size == 0:
        return
    sn, cs = np.sin(y), np.cos(y)
    if lat.size:
        dx, dy = x * cs - lat * sn, x * sn + lat * cs
    else:
        dx, dy = x * cs, x * sn
    theta[:] = wrap_angle(heading)
    dx[0], dy[0] = x0, y0
    np.cumsum(dx, out=x)
    np.cumsum(dy, out=y)


def _unwrapped(ticks: I64, modulus: int | None) -> F64:
    """Per-sample counter increments (``[0]`` = 0), rollover corrected as the compiled pass
    does (call after it has checked the jumps)."""
    d = np.diff(ticks, prepend=ticks[:1]).astype(np.int64)
    if modulus:
        d = counter_delta(d, modulus)
    return d.astype(np.float64)


def _start_pose(start: tuple[float, float, float] | None) -> tuple[float, float, float]:
    if start is None:
        return 0.0, 0.0, 0.0
    x0, y0, h0 = (float(v) for v in start)
    if not all(math.isfinite(v) for v in (x0, y0, h0)):
        raise LogFormatError(f"start pose must be finite numbers, got {start!r}")
    return x0, y0, h0


def _one_layout(a: NDArray[A]) -> NDArray[A]:
    """``a`` as the compiled passes take their arrays: contiguous and read-only (a view of ``a``
    where it is contiguous, else a contiguous copy). numba compiles a pass once for each layout
    and write flag it meets: a writable array, a read-only one (a column polars or pyarrow lent)
    and a strided one were three compilations of each pass, 2-2.5 s each the first time."""
    view = np.ascontiguousarray(a).view()
    view.flags.writeable = False
    return view


def _times(t: ArrayLike, n: int, source: str) -> NDArray[np.float64]:
    tt = np.array(t, dtype=np.float64)  # a copy: the trajectory owns its arrays
    if tt.ndim != 1 or tt.size != n:
        raise LogFormatError(f"{source}: t has {tt.size} samples but the ticks have {n}")
    check_times(tt, source, what="index")  # arrays: a 0-based index, not a file line
    return tt


def integrate(
    t: ArrayLike,
    left_ticks: ArrayLike,
    right_ticks: ArrayLike,
    params: RobotParams,
    method: Method | str = Method.MIDPOINT,
    *,
    start: tuple[float, float, float] | None = None,
    max_dticks: int | None = None,
    source: str = "encoder log",
    parallel: int | None = None,
) -> Trajectory:
    """Batch odometry from raw (possibly wrapping) counters; one pose per sample.

    ``t``, ``left_ticks``, ``right_ticks``: shape (n,). The first pose is ``start``
    (x, y, heading; default the origin) at ``t[0]``. ``max_dticks`` defaults to a quarter of
    the counter range (see :func:`odolab.core.encoders.default_max_dticks`).

    Three compiled passes: (A) sequentially, time check, rollover, eqs. (3.1)-(3.4) and the
    heading; (B) independently per sample, the position step (3.5)/(3.6), on ``parallel``
    threads for long logs (default numba's thread count; ``PARALLEL_MIN_SAMPLES`` or more);
    (C) the running sums of the steps, in the streaming order. A log of
    ``PIPELINE_MIN_SAMPLES`` or more without sideways motion, with two threads or more allowed,
    runs A on the calling thread and B and C on a second one, block by block
    (:func:`odolab.core._odometry_kernels.pipelined_ticks`; bit-identical to the passes in turn,
    ``parallel=1``). A log shorter than ``NUMPY_MAX_SAMPLES`` takes the same passes in numpy (no
    compiled code to load). Results equal :class:`Odometry`'s to rounding.
    """
    return _integrate(
        t, left_ticks, right_ticks, params, method, start=start, max_dticks=max_dticks,
        source=source, parallel=parallel, compiled=None,
    )  # fmt: skip


# long: the one odometry step's checks (ticks, times, jumps, the start) and its plain and compiled
# paths side by side, so that both read the same checks in one place
def _integrate(
    t: ArrayLike,
    left_ticks: ArrayLike,
    right_ticks: ArrayLike,
    params: RobotParams,
    method: Method | str,
    *,
    start: tuple[float, float, float] | None,
    max_dticks: int | None,
    source: str,
    parallel: int | None,
    compiled: bool | None,
) -> Trajectory:
    """:func:`integrate`; ``compiled`` None: the compiled passes for long logs (see
    :func:`_use_kernels`), True: always (:func:`warm_up`), False: never (tests)."""
    m = Method(method)
    left = _one_layout(as_tick_array(left_ticks, "left_ticks"))
    right = _one_layout(as_tick_array(right_ticks, "right_ticks"))
    if left.size != right.size:
        raise LogFormatError(f"{source}: left has {left.size} samples, right has {right.size}")
    tin = np.asarray(t, dtype=np.float64)
    if tin.ndim != 1 or tin.size != left.size:
        raise LogFormatError(f"{source}: t has {tin.size} samples but the ticks have {left.size}")
    tin = _one_layout(tin)
    _check_max_dticks(max_dticks)
    if max_dticks is None:
        max_dticks = default_max_dticks(params.encoder_modulus)
    x0, y0, h0 = _start_pose(start)
    n = left.size
    tt, x, y, theta, heading = (np.empty(n) for _ in range(5))
    coef, lat = _model_arrays(params, n)
    kernels = _use_kernels(n) if compiled is None else compiled
    limit = _NO_LIMIT if max_dticks is None else int(max_dticks)
    if not kernels:
        code, i, d = _check_ticks(tin, left, right, params.encoder_modulus or 0, limit)
        if code == 0:
            tt[:] = tin
            if timed_model(params.model) is None:
                _numpy_steps(
                    _unwrapped(left, params.encoder_modulus),
                    _unwrapped(right, params.encoder_modulus), params, coef,
                    m is Method.ARC, h0, heading, x, lat, y,
                )  # fmt: skip
        largest = 0.0
    elif _pipelines(n, lat, params, parallel):
        from odolab.core._odometry_kernels import pipelined_ticks

        counts = (params.encoder_modulus or 0, limit, params.left_metres_per_tick,
                  params.right_metres_per_tick)  # fmt: skip
        code, i, d = pipelined_ticks(
            tin, left, right, counts, coef, m is Method.ARC, (x0, y0, h0),
            (tt, x, y, theta, heading), PIPELINE_BLOCK,
        )  # fmt: skip
        if code == 0:
            return Trajectory(tt, x, y, theta, heading)
        largest = 0.0
    else:
        from odolab.core._odometry_kernels import _steps_from_ticks

        code, i, d, largest, _ = _steps_from_ticks(
            tin, left, right, params.encoder_modulus or 0, limit,
            params.left_metres_per_tick, params.right_metres_per_tick, coef,
            m is Method.ARC, h0, 0, n, tt, heading, x, lat, y,
        )  # fmt: skip
    if code == 0 and timed_model(params.model) is not None:
        lat = np.empty(n)
        largest = _slip_steps(
            tt, _unwrapped(left, params.encoder_modulus), _unwrapped(right, params.encoder_modulus),
            params, m is Method.ARC, h0, heading, x, lat, y,
        )  # fmt: skip
    if code == 0:
        _positions(x, y, lat, heading, theta, x0, y0, largest, parallel, kernels)
    if code in (1, 2):
        name = ("left_ticks", "right_ticks")[code - 1]
        raise EncoderJumpError(
            f"{source}: {name} jumps by {d} counts between samples {i - 1} and {i} "
            f"(t={tin[i]:g} s), more than the {max_dticks} counts per cycle that a wrap or "
            "plausible motion allows"
        )
    if code in (3, 4):
        check_times(tin, source, what="index")  # raises with the message
    return Trajectory(tt, x, y, theta, heading)


def integrate_with_covariance(
    t: ArrayLike,
    left_ticks: ArrayLike,
    right_ticks: ArrayLike,
    params: RobotParams,
    method: Method | str = Method.MIDPOINT,
    *,
    start: tuple[float, float, float] | None = None,
    cov0: ArrayLike | None = None,
    noise: NoiseParams | None = None,
    max_dticks: int | None = None,
    source: str = "encoder log",
    parallel: int | None = None,
) -> tuple[Trajectory, NDArray[np.float64]]:
    """:func:`integrate`, and the covariance of every pose: shape (n, 6) in
    ``odolab.core.uncertainty.COV_COLUMNS``, starting from ``cov0`` (3x3 or six terms; default zero)
    and propagated with ``noise`` (default ``params.noise``; see :mod:`odolab.core.uncertainty`).

    The covariance reuses the poses' headings and positions, so it costs one more compiled
    pass (on ``parallel`` threads for long logs). Equal to :class:`Odometry` with
    ``covariance=True`` to rounding."""
    from odolab.core.uncertainty import covariance_along, noise_of

    chosen = noise_of(params, noise)  # a missing [noise] table stops before the work
    traj = integrate(
        t, left_ticks, right_ticks, params, method, start=start, max_dticks=max_dticks,
        source=source, parallel=parallel,
    )  # fmt: skip
    cov = covariance_along(
        traj, left_ticks, right_ticks, params, method, noise=chosen, cov0=cov0, parallel=parallel
    )
    return traj, cov


def integrate_increments(
    t: ArrayLike,
    dticks_left: ArrayLike,
    dticks_right: ArrayLike,
    params: RobotParams,
    method: Method | str = Method.MIDPOINT,
    *,
    start: tuple[float, float, float] | None = None,
    source: str = "encoder log",
    parallel: int | None = None,
) -> Trajectory:
    """Batch odometry from per-cycle increments (``dticks[i]`` = counts from sample i-1 to i).

    ``dticks[0]`` is ignored (the first pose is ``start``). Increments may be fractional.
    """
    m = Method(method)
    dl = np.asarray(dticks_left, dtype=np.float64)
    dr = np.asarray(dticks_right, dtype=np.float64)
    if dl.shape != dr.shape or dl.ndim != 1:
        raise LogFormatError(f"{source}: left and right increments differ in shape")
    for name, arr in (("dticks_left", dl), ("dticks_right", dr)):
        bad = ~np.isfinite(arr)
        if bad.any():
            i = int(np.argmax(bad))
            raise LogFormatError(f"{source}: {name}[{i}] is {arr[i]}, expected a finite number")
    tt = _times(t, dl.size, source)
    x0, y0, h0 = _start_pose(start)
    n = dl.size
    x, y, theta, heading = (np.empty(n) for _ in range(4))
    coef, lat = _model_arrays(params, n)
    kernels = _use_kernels(n)
    if timed_model(params.model) is not None:
        lat = np.empty(n)
        largest = _slip_steps(tt, dl, dr, params, m is Method.ARC, h0, heading, x, lat, y)
    elif not kernels:
        _numpy_steps(dl, dr, params, coef, m is Method.ARC, h0, heading, x, lat, y)
        largest = 0.0
    else:
        from odolab.core._odometry_kernels import _steps_from_dticks

        largest = _steps_from_dticks(
            dl,
            dr,
            params.left_metres_per_tick,
            params.right_metres_per_tick,
            coef,
            m is Method.ARC,
            h0,
            heading,
            x,
            lat,
            y,
        )
    _positions(x, y, lat, heading, theta, x0, y0, largest, parallel, kernels)
    return Trajectory(tt, x, y, theta, heading)


def warm_up(
    params: RobotParams, method: Method | str = Method.MIDPOINT, *, covariance: bool = False
) -> threading.Thread:
    """Load (or compile) the batch kernels for these parameters on a background thread.

    Numba's first call costs about half a second (its own imports and the cached machine code);
    a command that reads a long log (``NUMPY_MAX_SAMPLES`` or more: a shorter one is integrated
    in numpy and needs no kernel) first can start this, read (the readers release the lock Python
    holds), and integrate when the read is done. Errors are left to the real call, which meets
    them again."""

    def run() -> None:
        t = np.array([0.0, 0.05])
        ticks = np.array([0, 1], dtype=np.int64)
        try:
            _integrate(
                t, ticks, ticks, params, method, start=None, max_dticks=None,
                source="warm-up", parallel=None, compiled=True,
            )  # fmt: skip
            if covariance:
                integrate_with_covariance(t, ticks, ticks, params, method)
        except Exception:  # the real call meets it again and reports it
            pass

    thread = threading.Thread(target=run, name="odolab-warm-up", daemon=True)
    thread.start()
    return thread


class Odometry:
    """Streaming odometry: call :meth:`update` once per control cycle with the raw counters.

    The first update sets the reference counts and returns the start pose. Each later update
    returns the pose after that cycle, exactly as :func:`integrate` would for the same samples.
    """

    def __init__(
        self,
        params: RobotParams,
        method: Method | str = Method.MIDPOINT,
        *,
        start: tuple[float, float, float] | None = None,
        max_dticks: int | None = None,
        covariance: bool = False,
    ) -> None:
        self.params = params
        self.method = Method(method)
        self._arc = self.method is Method.ARC
        self._start = _start_pose(start)
        _check_max_dticks(max_dticks)
        if max_dticks is None:
            max_dticks = default_max_dticks(params.encoder_modulus)
        self.max_dticks = max_dticks
        self._kl = params.left_metres_per_tick
        self._kr = params.right_metres_per_tick
        self._coef = params.coefficients
        self._slip = timed_model(params.model)
        own = own_covariance(params.model)
        self._own_cov = own is not None
        self._cov: CovarianceStepper | CovarianceStepperLike | None = None
        if covariance:  # imported here: the plain path stays as it was
            if own is not None:  # the model's own predictive variance (the slip model's)
                self._cov = own.covariance_stepper(params)
            else:  # needs params.noise
                from odolab.core.uncertainty import CovarianceStepper

                self._cov = CovarianceStepper(params, self.method)
        self._left = EncoderUnwrapper(params.encoder_modulus, max_dticks, "left_ticks")
        self._right = EncoderUnwrapper(params.encoder_modulus, max_dticks, "right_ticks")
        self.reset()

    def reset(self, start: tuple[float, float, float] | None = None) -> None:
        """Forget the counters and go back to the start pose (or a new one)."""
        if start is not None:
            self._start = _start_pose(start)
        self._x, self._y, self._h = self._start
        self._t: float | None = None
        self._left.reset()
        self._right.reset()
        self.cycles = 0
        if self._cov is not None:
            self._cov.reset()

    def warm_up(self) -> None:
        """Load (or compile) what this odometry's cycles call, now, on a throwaway copy.

        The pose step runs as plain Python (:mod:`odolab.core._step_kernels`, the source of the
        batch passes' compiled twins) and loads nothing; the covariance's step is numba's, and a
        dispatcher loads or compiles its machine code on its first call: 0.3 s to several
        seconds. A control loop calls this before its first command so that no cycle pays for
        a first call. This odometry's own state is untouched."""
        twin = Odometry(
            self.params, self.method, max_dticks=self.max_dticks, covariance=self._cov is not None
        )
        for k, ticks in enumerate((0, 1, 0)):  # a move of one count (<= any max_dticks), back
            twin.update(0.05 * k, ticks, ticks)
            twin.update_increments(0.05 * k + 0.01, 1.0, -1.0)

    @property
    def covariance(self) -> tuple[float, float, float, float, float, float]:
        """The propagated covariance now, six terms in ``odolab.core.uncertainty.COV_COLUMNS``.

        Only with ``covariance=True`` (and a ``[noise]`` table in the parameters, or a slip
        model: its own predictive variance, :mod:`odolab.core.slip_uncertainty`)."""
        if self._cov is None:
            raise OdolabError("this Odometry was made without covariance=True")
        return self._cov.terms

    @property
    def pose(self) -> Pose:
        """The current pose (t is nan before the first update)."""
        t = math.nan if self._t is None else self._t
        return Pose(t, self._x, self._y, _wrap_py(self._h), self._h)

    def _check_time(self, t: float) -> float:
        tf = float(t)
        if not math.isfinite(tf):
            raise LogFormatError(f"update time is {t!r}, expected a finite number of seconds")
        if self._t is not None and tf < self._t:
            raise LogFormatError(
                f"update time goes backwards ({tf} after {self._t}); expected non-decreasing times"
            )
        return tf

    def update(self, t: float, left_ticks: int, right_ticks: int) -> Pose:
        """One control cycle from raw counter values; returns the new pose."""
        tf = self._check_time(t)
        dl = self._left.update(left_ticks)
        try:
            dr = self._right.update(right_ticks)
        except EncoderJumpError:
            self._left._index -= 1  # keep both counters' sample indexes in step
            raise
        return self._advance(tf, dl, dr)

    def update_increments(self, t: float, dticks_left: float, dticks_right: float) -> Pose:
        """One control cycle from counter increments since the last cycle.

        A non-finite increment is refused (:class:`LogFormatError`, the odometry unchanged), as
        :func:`integrate_increments` refuses it in a log: a NaN would make every later pose NaN."""
        tf = self._check_time(t)
        dl, dr = float(dticks_left), float(dticks_right)
        for name, value in (("dticks_left", dl), ("dticks_right", dr)):
            if not math.isfinite(value):
                raise LogFormatError(
                    f"{name} is {value!r} at t = {tf:g} s, expected a finite number of counts"
                )
        if self._t is None:
            return self._advance(tf, 0.0, 0.0)
        return self._advance(tf, dl, dr)

    def _advance(self, t: float, dl: float, dr: float) -> Pose:
        first = self._t is None
        dt = 0.0 if self._t is None else t - self._t
        self._t = t
        if not first:
            dsl = dl * self._kl
            dsr = dr * self._kr
            if self._cov is not None:
                if self._own_cov:
                    self._cov.step(self._h, dsl, dsr, dt)  # type: ignore[call-arg]
                else:
                    self._cov.step(self._h, dsl, dsr)  # type: ignore[call-arg]
            if self._slip is None:
                # the compiled passes' own source, run as Python: no numba for a cycle's pose
                fwd, side, dth = _step_kernels.body_motion(*self._coef, dsl, dsr)
            else:
                fwd, side, dth = self._slip.body_motion(dsl, dsr, dt, self.params.track_width)
            self._x, self._y, self._h = _step_kernels.step_pose(
                self._x, self._y, self._h, fwd, side, dth, self._arc
            )
            self.cycles += 1
        return Pose(t, self._x, self._y, _wrap_py(self._h), self._h)


def _wrap_py(h: float) -> float:
    return float(wrap_angle(h))
