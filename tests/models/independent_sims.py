"""Independent tracked / skid-steer simulators for issue 29's goals (pure numpy; no odolab.sim).

odolab's own virtual robot (:mod:`odolab.sim.physics`) was written by the same hands as the slip
model, so it cannot tell whether the model generalises. The simulators here are written from
the literature, with slip laws that are *not* in the slip model's basis (rational, saturating,
lagged), and share nothing with :mod:`odolab.sim` but the nominal robot of the
``jaguar-lite`` preset (track width 0.56 m, 0.0835 m radius, 380 ticks a revolution).

Common to every simulator (internal step ``DT`` = 5 ms, reports at 20 Hz):

- **Commands.** A command ``(v, w)`` becomes track speed commands ``u* = v -+ w b / 2``
  (``b`` = 0.56 m, the nominal track width: what the robot's driver does).
- **Drive lag.** The sprocket (encoder) speeds ``u_l, u_r`` follow the commands with a
  first-order lag, time constant ``tau`` (0.15 s): ``du/dt = (u* - u) / tau``.
- **Encoders.** The counts are ``floor(integral(u) / m + phase)`` per side, ``m`` the preset's
  metres per tick (2 pi 0.0835 / 380 = 1.381 mm), ``phase`` a seeded uniform start phase:
  quantised as a real quadrature counter counts (the increments in the log are the differences
  of these integers).
- **Track surface speed.** ``V = g u``, ``g`` the true effective radius over the nominal one per
  side (``gain_left``, ``gain_right``: a constant the kinematic models can fit).
- **Noise** (not seen by the encoders): each moving track's ground speed gets an
  Ornstein-Uhlenbeck speed noise of stationary standard deviation ``speed_noise`` (0.01 m/s)
  and correlation time ``noise_tau`` (0.2 s); the heading of a moving robot gets a random walk
  of ``heading_walk`` rad/sqrt(s) (0.005: 0.039 rad after 60 s). Both seeded. What no model can
  predict: the held-out runs' end points with and without the noise differ by 0.14-0.34 m on
  average over the four runs (seeds 1-2, both simulators; up to 0.85 m on the 21 m mixed run).

Simulator **"icr-speed"** (:class:`IcrSpeedSim`): a tracked robot, instantaneous centres of
rotation of the tracks after Martinez et al. 2005 ("Approximating kinematics for tracked mobile
robots", IJRR 24(10)) and Mandow et al. 2007 ("Experimental kinematics for wheeled skid-steer
mobile robots", IROS), with ICRs that move outward with the turn rate and a longitudinal slip
that grows with the track speed::

    w0 = (V_r - V_l) / b                                   (turn rate the tracks command)
    i_s = min(c |V_s|, 0.5)          V'_s = V_s (1 - i_s)  (slip ratio of side s)
    y_l = +(b_icr / 2)(1 + a |w0|)   y_r = -(b_icr / 2)(1 + a |w0|)
    w   = (V'_r - V'_l) / (y_l - y_r)
    v_x = (V'_r y_l - V'_l y_r) / (y_l - y_r)
    v_y = -x_icr w                                         (ICR x offset, body frame)

(the ICRs move with the commanded turn ``w0``, not the achieved ``w``, to keep the law
explicit). Defaults: ``b_icr`` 0.66 m, ``a`` 0.3 s/rad, ``x_icr`` 0.04 m, ``c`` 0.08 s/m,
gains 1.0 / 1.012. With ``a = c = 0`` (:func:`constant_slip`) the ICRs and radii are constant:
exactly the ICR model, the negative control.

Simulator **"skid-dynamic"** (:class:`SkidDynamicSim`): a four-wheel skid-steer robot whose body
slip comes from a friction law (after the Coulomb-friction skid-steer models of Yi et al. 2009,
"Kinematic modeling and analysis of skid-steered mobile robots", and Kozlowski & Pazderski
2004): the wheels' ground speeds differ forward and in reverse (``V = g_f u`` for ``u >= 0``,
``g_r u`` otherwise: different forward and reverse radii), the lateral friction lets the body
skid outward in proportion to the centripetal acceleration ``v w`` until it saturates, the yaw
rate is reduced by a factor that grows with ``|w|`` and the speed, and the body's yaw rate
follows its target with a lag (its inertia)::

    v0 = (V_l + V_r) / 2             w0 = (V_r - V_l) / b_eff
    v_x   = v0 (1 - k_x |w0|)                                  (turning costs forward speed)
    w*    = w0 / (1 + k_w |w0| + k_v |v0|)                     (rational, not polynomial)
    dw/dt = (w* - w) / tau_yaw
    v_y   = -a_sat tanh(k_lat v0 w / a_sat)                    (outward skid, saturating)

Defaults: ``b_eff`` 0.60 m, ``k_x`` 0.05 s/rad, ``k_w`` 0.2 s/rad, ``k_v`` 0.25 s/m,
``tau_yaw`` 0.08 s, ``k_lat`` 0.06 s, ``a_sat`` 0.08 m/s, forward / reverse gains left 1.0 /
0.97, right 1.01 / 0.975.

**Drives** (:func:`exploration`, :func:`held_out_runs`): a 60 s exploration of random commands
(``v``, ``w`` uniform within ``|v| <= 1`` m/s, ``|w| <= 2`` rad/s and both track speeds within
1 m/s, each held 1-3 s; beyond 3 m from the start (true pose) and moving outward it turns in
place toward the start at 1.5 rad/s, then draws a forward command), and four held-out runs at
other speeds: a square (2 m sides at 0.3 m/s, 90 degree turns in place at 0.8 rad/s), arcs
(0.6 m/s on a 1.5 m radius, a circle's worth each way), spins (1.5 rad/s both ways with 0.4 m/s
straights) and a mixed run at 0.8 m/s (straights, arcs of both signs, reverse).

:func:`write_run` writes a run as odolab reads it: ``<name>.csv`` (``t,dticks_left,dticks_right``)
and ``<name>_gt.csv`` (``t,x,y,theta``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

__all__ = [
    "DT",
    "METRES_PER_TICK",
    "REPORT_RATE",
    "TRACK_WIDTH",
    "IcrSpeedSim",
    "SimRun",
    "SkidDynamicSim",
    "constant_slip",
    "exploration",
    "held_out_runs",
    "simulate",
    "write_run",
]

#: nominal robot: odolab's ``jaguar-lite`` preset (written out, checked against it in the test)
TRACK_WIDTH = 0.56
METRES_PER_TICK = 2.0 * math.pi * 0.0835 / 380.0
DT = 0.005
REPORT_RATE = 20.0
_SUB = round(1.0 / (REPORT_RATE * DT))

#: a controller: (time s, true x, y, heading) -> command (v m/s, w rad/s)
Controller = Callable[[float, float, float, float], tuple[float, float]]


@dataclass(frozen=True)
class _Common:
    tau: float = 0.15
    speed_noise: float = 0.01
    noise_tau: float = 0.2
    heading_walk: float = 0.005


@dataclass(frozen=True)
class IcrSpeedSim(_Common):
    """Tracked robot: ICRs outward with the turn rate, slip ratio growing with speed."""

    name: str = "icr-speed"
    b_icr: float = 0.66
    a: float = 0.3
    x_icr: float = 0.04
    c: float = 0.08
    gain_left: float = 1.0
    gain_right: float = 1.012

    def track_speeds(self, ul: float, ur: float) -> tuple[float, float]:
        return self.gain_left * ul, self.gain_right * ur

    def body(self, vl: float, vr: float, w_prev: float, dt: float) -> tuple[float, float, float]:
        del w_prev, dt
        w0 = (vr - vl) / TRACK_WIDTH
        vl_e = vl * (1.0 - min(self.c * abs(vl), 0.5))
        vr_e = vr * (1.0 - min(self.c * abs(vr), 0.5))
        half = 0.5 * self.b_icr * (1.0 + self.a * abs(w0))
        w = (vr_e - vl_e) / (2.0 * half)
        vx = 0.5 * (vr_e + vl_e)  # (V'_r y_l - V'_l y_r) / (y_l - y_r) with y_l = -y_r
        return vx, -self.x_icr * w, w


@dataclass(frozen=True)
class SkidDynamicSim(_Common):
    """Skid-steer robot: friction-law skid, rational yaw reduction, yaw lag, fwd/rev radii."""

    name: str = "skid-dynamic"
    b_eff: float = 0.60
    k_x: float = 0.05
    k_w: float = 0.2
    k_v: float = 0.25
    tau_yaw: float = 0.08
    k_lat: float = 0.06
    a_sat: float = 0.08
    gain_left_fwd: float = 1.0
    gain_left_rev: float = 0.97
    gain_right_fwd: float = 1.01
    gain_right_rev: float = 0.975

    def track_speeds(self, ul: float, ur: float) -> tuple[float, float]:
        gl = self.gain_left_fwd if ul >= 0 else self.gain_left_rev
        gr = self.gain_right_fwd if ur >= 0 else self.gain_right_rev
        return gl * ul, gr * ur

    def body(self, vl: float, vr: float, w_prev: float, dt: float) -> tuple[float, float, float]:
        v0 = 0.5 * (vl + vr)
        w0 = (vr - vl) / self.b_eff
        vx = v0 * (1.0 - self.k_x * abs(w0))
        target = w0 / (1.0 + self.k_w * abs(w0) + self.k_v * abs(v0))
        w = w_prev + (target - w_prev) * (1.0 - math.exp(-dt / self.tau_yaw))
        vy = -self.a_sat * math.tanh(self.k_lat * v0 * w / self.a_sat) if self.a_sat > 0 else 0.0
        return vx, vy, w


Sim = IcrSpeedSim | SkidDynamicSim


def constant_slip(sim: IcrSpeedSim) -> IcrSpeedSim:
    """The negative control: the same robot and noise, ICRs and radii constant (no slip that
    grows with speed or turn rate)."""
    return replace(sim, name=f"{sim.name}-constant", a=0.0, c=0.0)


@dataclass(frozen=True)
class SimRun:
    """One run at 20 Hz: stamps, tick increments (first 0) and the true pose."""

    name: str
    t: np.ndarray
    dticks_left: np.ndarray
    dticks_right: np.ndarray
    x: np.ndarray
    y: np.ndarray
    heading: np.ndarray


def simulate(sim: Sim, controller: Controller, seconds: float, seed: int, name: str) -> SimRun:
    """Drive ``sim`` for ``seconds`` with ``controller`` (asked at every report, 20 Hz)."""
    rng = np.random.default_rng(seed)
    n_rep = round(seconds * REPORT_RATE)
    n = n_rep * _SUB
    # noise drawn up front (deterministic given the seed)
    a_ou = math.exp(-DT / sim.noise_tau)
    s_ou = sim.speed_noise * math.sqrt(1.0 - a_ou * a_ou)
    # as Python floats: the loop's arithmetic on them is the same IEEE doubles as on NumPy's
    # scalars (the runs are bit-identical), at half the cost
    white = rng.standard_normal((n, 3)).tolist()
    phase = rng.uniform(0.0, 1.0, 2)
    x = y = h = 0.0
    ul = ur = 0.0  # sprocket speeds (nominal m/s, what the encoders see)
    nl = nr = 0.0  # OU ground-speed noise
    w = 0.0
    sl = sr = 0.0  # sprocket travel (nominal m)
    rows = np.empty((n_rep + 1, 6))
    rows[0] = (0.0, sl, sr, x, y, h)
    lag = 1.0 - math.exp(-DT / sim.tau)
    walk = sim.heading_walk * math.sqrt(DT)
    half = 0.5 * TRACK_WIDTH
    cl = cr = 0.0
    track_speeds, body = sim.track_speeds, sim.body
    for k in range(n):
        if k % _SUB == 0:
            v_cmd, w_cmd = controller(k * DT, x, y, h)
            cl, cr = v_cmd - w_cmd * half, v_cmd + w_cmd * half
        ul += (cl - ul) * lag
        ur += (cr - ur) * lag
        sl += ul * DT
        sr += ur * DT
        noise = white[k]
        nl = a_ou * nl + s_ou * noise[0]
        nr = a_ou * nr + s_ou * noise[1]
        vl, vr = track_speeds(ul, ur)
        # the noise acts on a moving track only (a robot at rest does not creep)
        vl += nl * min(abs(ul) / 0.05, 1.0)
        vr += nr * min(abs(ur) / 0.05, 1.0)
        vx, vy, w = body(vl, vr, w, DT)
        m = h + 0.5 * w * DT
        x += (vx * math.cos(m) - vy * math.sin(m)) * DT
        y += (vx * math.sin(m) + vy * math.cos(m)) * DT
        h += w * DT + walk * noise[2] * min((abs(ul) + abs(ur)) / 0.05, 1.0)
        if (k + 1) % _SUB == 0:
            rows[(k + 1) // _SUB] = ((k + 1) * DT, sl, sr, x, y, h)
    counts_l = np.floor(rows[:, 1] / METRES_PER_TICK + phase[0])
    counts_r = np.floor(rows[:, 2] / METRES_PER_TICK + phase[1])
    return SimRun(
        name,
        np.round(rows[:, 0], 6),
        np.diff(counts_l, prepend=counts_l[0]),
        np.diff(counts_r, prepend=counts_r[0]),
        rows[:, 3],
        rows[:, 4],
        rows[:, 5],
    )


# ------------------------------------------------------------------------------------- drives


def _explorer(seed: int, fence: float = 3.0) -> Controller:
    """Random commands held 1-3 s; beyond ``fence`` m and moving outward, turn toward the start."""
    rng = np.random.default_rng(10_000 + seed)
    state = {"until": -1.0, "v": 0.0, "w": 0.0, "returning": False}

    def draw(forward: bool) -> None:
        while True:
            v, w = rng.uniform(-1.0, 1.0), rng.uniform(-2.0, 2.0)
            if forward:
                v = abs(v)
            if abs(v) + abs(w) * 0.5 * TRACK_WIDTH <= 1.0:
                break
        state["v"], state["w"] = float(v), float(w)

    def controller(t: float, x: float, y: float, h: float) -> tuple[float, float]:
        r = math.hypot(x, y)
        if state["returning"]:
            err = math.atan2(-y, -x) - h
            err = math.atan2(math.sin(err), math.cos(err))
            if abs(err) < 0.3:
                state["returning"] = False
                draw(forward=True)
                state["until"] = t + float(rng.uniform(1.0, 3.0))
            else:
                return 0.0, math.copysign(1.5, err)
        outward = (x * math.cos(h) + y * math.sin(h)) * float(state["v"]) > 0
        if r > fence and outward:
            state["returning"] = True
            return controller(t, x, y, h)
        if t >= float(state["until"]):
            draw(forward=False)
            state["until"] = t + float(rng.uniform(1.0, 3.0))
        return float(state["v"]), float(state["w"])

    return controller


def _schedule(legs: list[tuple[float, float, float]]) -> tuple[Controller, float]:
    """Open-loop legs ``(seconds, v, w)`` after 0.5 s at rest, then 1 s at rest."""
    edges = np.cumsum([0.5] + [d for d, _, _ in legs])
    cmds = [(v, w) for _, v, w in legs]

    def controller(t: float, x: float, y: float, h: float) -> tuple[float, float]:
        del x, y, h
        i = int(np.searchsorted(edges, t, side="right")) - 1
        return cmds[i] if 0 <= i < len(cmds) else (0.0, 0.0)

    return controller, float(edges[-1]) + 1.0


def exploration(sim: Sim, seed: int, seconds: float = 60.0) -> SimRun:
    """The 60 s exploration run of random commands (see the module)."""
    return simulate(sim, _explorer(seed), seconds, seed, "explore")


def held_out_runs(sim: Sim, seed: int) -> list[SimRun]:
    """Square (0.3 m/s), arcs (0.6 m/s, 1.5 m), spins (1.5 rad/s), mixed (0.8 m/s)."""
    turn = (0.5 * math.pi / 0.8, 0.0, 0.8)
    square = [(2.0 / 0.3, 0.3, 0.0), turn] * 4
    circle = 2.0 * math.pi * 1.5 / 0.6
    arcs = [(circle, 0.6, 0.4), (1.0, 0.6, 0.0), (circle, 0.6, -0.4)]
    rev = 2.0 * math.pi / 1.5
    spins = [(rev, 0.0, 1.5), (2.0, 0.4, 0.0), (rev, 0.0, -1.5), (2.0, -0.4, 0.0)] * 2
    mixed = [
        (3.0, 0.8, 0.0), (4.0, 0.8, 0.6), (2.0, 0.8, 0.0), (5.0, 0.8, -0.6),
        (3.0, -0.8, 0.0), (4.0, -0.8, 0.5), (3.0, 0.8, 0.0), (4.0, 0.8, -0.5),
    ]  # fmt: skip
    out = []
    for k, (name, legs) in enumerate(
        (("square", square), ("arcs", arcs), ("spins", spins), ("mixed", mixed))
    ):
        controller, seconds = _schedule(legs)
        out.append(simulate(sim, controller, seconds, 1000 * seed + k + 1, name))
    return out


def write_run(folder: Path, run: SimRun) -> Path:
    """``<folder>/<name>.csv`` and ``<name>_gt.csv`` as odolab's ``--format csv`` reads them;
    returns the log's path."""
    folder.mkdir(parents=True, exist_ok=True)
    log = folder / f"{run.name}.csv"
    np.savetxt(
        log,
        np.column_stack((run.t, run.dticks_left, run.dticks_right)),
        fmt=("%.6f", "%d", "%d"),
        delimiter=",",
        header="t,dticks_left,dticks_right",
        comments="",
    )
    theta = np.angle(np.exp(1j * run.heading))
    np.savetxt(
        folder / f"{run.name}_gt.csv",
        np.column_stack((run.t, run.x, run.y, theta)),
        fmt="%.9g",
        delimiter=",",
        header="t,x,y,theta",
        comments="",
    )
    return log
