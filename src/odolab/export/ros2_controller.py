"""A ready-to-load ``diff_drive_controller`` parameter file from a calibrated parameter set.

ROS 2's ``diff_drive_controller`` computes odometry with ``wheel_separation *
wheel_separation_multiplier`` and ``wheel_radius * left_wheel_radius_multiplier`` (and right).
odolab writes the nominal geometry (``--nominal``, default: the calibrated set's mean radius and
track) as the base values and the calibration as the multipliers, so that value x multiplier
equals the calibrated effective radii and track exactly, and a person reading the file sees how
far the calibration moved each one.

The controller publishes a *fixed* diagonal covariance. odolab derives it from the ``[noise]``
table (per-wheel slip ``var(ds) = k |ds|``) at a stated speed ``v`` (m/s), for a straight run,
for the controller's own estimate:

* twist (``vx``, ``wz``): the controller's velocity is the rolling mean of its last ``W``
  (``velocity_rolling_window_size``, default 10) per-cycle wheel-speed estimates at its update
  rate ``f`` (Hz), i.e. the displacement over ``W / f`` seconds divided by that time; each wheel
  rolls ``v W / f`` m in it, so a wheel speed has variance ``k v f / W``:
  ``var(vx) = (k_l + k_r) v f / (4 W)``, ``var(wz) = (k_l + k_r) v f / (W b^2)``
  (``k_scrub`` does not enter a straight run); ``vy`` gets ``var(vx)`` (tracks and skid-steer
  bases do slip sideways; a wheeled base may lower it);
* pose: the covariance of a straight run of ``horizon`` metres (default 1 m;
  :func:`odolab.core.uncertainty.straight_line_covariance`): ``var x = k d / 4``,
  ``var y = k d^3 / (3 b^2)``, ``var yaw = k d / b^2`` with ``k = k_l + k_r``;
* ``z``, ``roll``, ``pitch`` (not observed by planar odometry): :data:`UNOBSERVED` (1e6).

The fixed values can only describe one motion; the propagated covariance
(:func:`odolab.core.uncertainty.propagate_covariance`, the ``/odom`` messages of ``odolab export
mcap``) grows with the path as it should.

Keys: exactly those of the chosen ROS 2 distribution's ``diff_drive_controller`` parameter
schema (:data:`DISTRO_KEYS`; ``wheels_per_side`` left ros2_controllers in 4.5.0, after Humble,
``publish_rate`` in 6.7.0, Rolling), since a key the controller does not declare is ignored
without a word. Floats are written so that YAML 1.1 loaders (PyYAML, as ROS 2 launch files use)
read them as floats: ``5.0e-05``, never ``5e-05`` (a string there).

Models the controller cannot express (``extended`` with unequal weights, ``icr``, ``slip``): the
file says so and gives the best differential-drive equivalent (:func:`_equivalent`): straight
runs (distance and heading drift) and turns in place match; the forward motion during a turn in
place and the sideways motion (``x_icr``) are lost. The slip model's equivalent is taken at
``speed`` (its slip changes with the speed; the note says by how much), and its covariance
diagonals are its own predictive variance of that straight run (:mod:`odolab.core.slip_uncertainty`;
:func:`odolab.core.params.covariance_source`, the rule every face uses).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from odolab.core.errors import NEUTRAL, ParamsError, Wording, opt
from odolab.core.models import own_covariance, timed_model
from odolab.core.params import RobotParams, covariance_source
from odolab.core.text import safe_terminal

__all__ = [
    "DEFAULT_CONTROLLER",
    "DEFAULT_DISTRO",
    "DEFAULT_HORIZON",
    "DEFAULT_LEFT_WHEELS",
    "DEFAULT_RATE",
    "DEFAULT_RIGHT_WHEELS",
    "DEFAULT_SPEED",
    "DEFAULT_WINDOW",
    "DISTRO_KEYS",
    "LIMITS",
    "ROS_DISTROS",
    "UNOBSERVED",
    "ControllerExport",
    "controller_numbers",
    "diff_drive_controller_yaml",
]

#: Steps the slip model's covariance is propagated over, at most (:func:`_slip_diagonals`).
_SLIP_STEPS = 2000
#: Variance written for the terms planar odometry does not observe (z, roll, pitch).
UNOBSERVED = 1e6

#: The ``diff_drive_controller`` parameters (top level of ``ros__parameters``; ``linear`` and
#: ``angular`` are groups of limits) of each ROS 2 distribution, from ros-controls/
#: ros2_controllers ``diff_drive_controller/src/diff_drive_controller_parameter.yaml`` on the
#: branches humble (ad559d9c), jazzy (ed360c97), kilted (0f8eb14e) and master (94e74de3, for
#: rolling), read 2026-11. ``wheels_per_side`` was removed in 4.5.0 (jazzy has none),
#: ``use_stamped_vel`` after humble, ``publish_rate`` in 6.7.0 (rolling). The schemas are kept
#: in tests/export/ros2_schemas/, and a test checks these lists against them.
_COMMON_KEYS = (
    "left_wheel_names",
    "right_wheel_names",
    "wheel_separation",
    "wheel_radius",
    "wheel_separation_multiplier",
    "left_wheel_radius_multiplier",
    "right_wheel_radius_multiplier",
    "tf_frame_prefix_enable",
    "tf_frame_prefix",
    "odom_frame_id",
    "base_frame_id",
    "pose_covariance_diagonal",
    "twist_covariance_diagonal",
    "open_loop",
    "position_feedback",
    "enable_odom_tf",
    "cmd_vel_timeout",
    "publish_limited_velocity",
    "velocity_rolling_window_size",
    "linear",
    "angular",
)
DISTRO_KEYS: dict[str, frozenset[str]] = {
    "humble": frozenset((*_COMMON_KEYS, "wheels_per_side", "use_stamped_vel", "publish_rate")),
    "jazzy": frozenset((*_COMMON_KEYS, "publish_rate")),
    "kilted": frozenset((*_COMMON_KEYS, "publish_rate")),
    "rolling": frozenset(_COMMON_KEYS),
}
ROS_DISTROS = tuple(DISTRO_KEYS)
#: The newest long-term-support distribution (Jazzy Jalisco, May 2024 - May 2029).
DEFAULT_DISTRO = "jazzy"
#: The controller's ``velocity_rolling_window_size`` default (every distribution).
DEFAULT_WINDOW = 10
#: The controller's name (the YAML's top key) unless told otherwise.
DEFAULT_CONTROLLER = "diff_drive_controller"
#: The speed (m/s) the covariance is stated at, the controller's update rate (Hz) and the
#: straight path (m) the pose covariance is stated after, unless told otherwise.
DEFAULT_SPEED = 0.5
DEFAULT_RATE = 50.0
DEFAULT_HORIZON = 1.0
#: The wheel joints' names unless told otherwise (one wheel a side).
DEFAULT_LEFT_WHEELS = ("left_wheel_joint",)
DEFAULT_RIGHT_WHEELS = ("right_wheel_joint",)
#: Largest ``speed`` (m/s), ``rate`` (Hz) and ``horizon`` (m) accepted: far beyond any
#: wheeled robot, small enough that every covariance term stays a finite number.
LIMITS = {"speed": 100.0, "rate": 100_000.0, "horizon": 100_000.0}


@dataclass(frozen=True)
class ControllerExport:
    """The numbers written into the YAML (SI units)."""

    wheel_separation: float
    wheel_radius: float
    wheel_separation_multiplier: float
    left_wheel_radius_multiplier: float
    right_wheel_radius_multiplier: float
    pose_covariance_diagonal: tuple[float, ...]
    twist_covariance_diagonal: tuple[float, ...]
    exact: bool
    notes: tuple[str, ...]
    #: where the covariance diagonals came from: "noise" (the ``[noise]`` table), "slip" (the
    #: slip model's predictive variance) or None (placeholders)
    covariance_source: str | None = None

    @property
    def effective_left_radius(self) -> float:
        """The left wheel radius the controller uses (m): base value x multiplier."""
        return self.wheel_radius * self.left_wheel_radius_multiplier

    @property
    def effective_right_radius(self) -> float:
        """The right wheel radius the controller uses (m): base value x multiplier."""
        return self.wheel_radius * self.right_wheel_radius_multiplier

    @property
    def effective_separation(self) -> float:
        """The wheel separation the controller uses (m): base value x multiplier."""
        return self.wheel_separation * self.wheel_separation_multiplier


def _check_positive(name: str, value: float) -> float:
    limit = LIMITS[name]
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not math.isfinite(value)
        or not 0 < value <= limit
    ):
        raise ParamsError(option=name, value=value, allowed=f"a positive number up to {limit:g}")
    return float(value)


def _check_window(window: int) -> int:
    if isinstance(window, bool) or not isinstance(window, int) or not 1 <= window <= 100_000:
        raise ParamsError(
            option="window",
            value=window,
            allowed="a whole number of cycles from 1 to 100000 (the controller's "
            "velocity_rolling_window_size)",
        )
    return window


def yaml_float(value: float) -> str:
    """``value`` as a YAML 1.1 float: a mantissa with a dot (``5.0e-05``, ``1000000.0``), which
    PyYAML reads as a float where ``5e-05`` would be a string; shortest round-trip digits."""
    text = repr(float(value))
    if not math.isfinite(value):
        return {"inf": ".inf", "-inf": "-.inf"}.get(text, ".nan")
    mantissa, e, exponent = text.partition("e")
    if "." not in mantissa:
        mantissa += ".0"
    return mantissa + (e + exponent if e else "")


def _motion(
    params: RobotParams, ds_left: float, ds_right: float, speed: float
) -> tuple[float, ...]:
    """(forward, lateral, heading) the model gives for wheel displacements (m) rolled at the wheel
    speed ``speed`` (m/s): the slip model depends on the speed, the kinematic models do not."""
    model = timed_model(params.model)
    if model is not None:
        dt = max(abs(ds_left), abs(ds_right)) / speed
        return model.body_motion(ds_left, ds_right, dt, params.track_width)
    return params.coefficients.body_motion(ds_left, ds_right)


def _equivalent(params: RobotParams, speed: float) -> tuple[float, float, float, bool]:
    """The differential drive (left and right radius multipliers of the ``[robot]`` radii, and
    the separation, m) that matches the model on a straight run (its distance and its heading
    drift) and on turns in place (the mean of both directions), with the wheels at ``speed``;
    and whether it is the model itself (every motion the same).

    A differential drive with radius multipliers ``u_l``, ``u_r`` and separation ``B`` moves
    ``(u_l ds_l + u_r ds_r) / 2`` forward and turns ``(u_r ds_r - u_l ds_l) / B``. With the
    model's straight run (``ds_l = ds_r = 1 m``) going ``F`` forward and turning ``T``, and its
    turn in place (``ds_r = -ds_l = 1 m``) turning ``G`` on average: ``u_l + u_r = 2F``, ``B =
    2F / G`` and ``u_r - u_l = T B``. For the differential drive, the extended model and the ICR
    model this is their rotation terms scaled to their forward weights (their own numbers when
    those agree)."""
    fwd, lat, straight_turn = _motion(params, 1.0, 1.0, speed)
    _, lat_left, turn_left = _motion(params, -1.0, 1.0, speed)
    _, lat_right, turn_right = _motion(params, 1.0, -1.0, speed)
    turn = 0.5 * (turn_left - turn_right)
    if not (fwd > 0.0 and turn > 0.0):
        raise ParamsError(
            f"the parameters' model ({params.model.kind}) moves {fwd:.6g} m forward per metre of "
            f"straight driving and turns {turn:.6g} rad per metre of turning in place at "
            f"{speed:g} m/s; a differential drive needs both positive"
        )
    separation = 2.0 * fwd / turn
    u_left = fwd - 0.5 * straight_turn * separation
    u_right = fwd + 0.5 * straight_turn * separation
    model = timed_model(params.model)
    linear = model is None or model.is_linear
    exact = linear and lat == lat_left == lat_right == 0.0
    if exact:  # every wheel motion: the two unit motions above and one on one wheel
        for dl, dr in ((1.0, 0.0), (0.0, 1.0), (-1.0, 1.0)):
            f_m, _, h_m = _motion(params, dl, dr, speed)
            f_d, h_d = 0.5 * (u_left * dl + u_right * dr), (u_right * dr - u_left * dl) / separation
            exact = exact and math.isclose(f_m, f_d, rel_tol=1e-9, abs_tol=1e-12)
            exact = exact and math.isclose(h_m, h_d, rel_tol=1e-9, abs_tol=1e-12)
    return u_left, u_right, separation, exact


def _slip_note(params: RobotParams, speed: float) -> str:
    """What the file loses of a slip model: how its straight distance and its turn change with
    the wheel speed, which a differential drive cannot follow."""

    def factors(v: float) -> tuple[float, float]:
        f = _motion(params, 1.0, 1.0, v)[0]
        g = 0.5 * (_motion(params, -1.0, 1.0, v)[2] - _motion(params, 1.0, -1.0, v)[2])
        return f, g * 0.5 * params.track_width

    lo, hi = 0.5 * speed, 2.0 * speed
    (f_lo, g_lo), (f_hi, g_hi) = factors(lo), factors(hi)
    drift = _motion(params, 1.0, 1.0, speed)[2]
    own = own_covariance(params.model)
    sd = own.straight_turn_sd(speed) if own is not None else None
    # the straight run's heading rate and its posterior sd, per metre
    spread = "" if sd is None else f" +- {sd:.2g}"
    return (
        "the slip model's slip changes with speed and turn rate, which diff_drive_controller "
        f"cannot express: these values are its differential-drive equivalent at {opt('speed')} {speed:g}"
        " m/s (straight runs and turns in place at that wheel speed match, turns averaged over "
        f"both directions). Its distance per metre of track is {f_lo:.4g} at {lo:g} m/s and "
        f"{f_hi:.4g} at {hi:g} m/s, its turn per commanded radian in place {g_lo:.4g} and "
        f"{g_hi:.4g}; a straight run turns {drift:.3g}{spread} rad per metre (the "
        "coefficients' posterior standard deviation), which the radius multipliers carry; "
        "sideways slip is lost. Give {{speed}} the speed the robot mostly drives at, "
        "or use odolab's own odometry where that matters."
    )


def _slip_diagonals(
    params: RobotParams, speed: float, rate: float, horizon: float, window: int
) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The slip model's predictive variance (:mod:`odolab.core.slip_uncertainty`, with its
    coefficients' posterior) for straight driving at ``speed``: the pose after ``horizon`` m,
    and the controller's velocity, its displacement over ``window`` cycles at ``rate`` Hz over
    that time. Propagated over at most :data:`_SLIP_STEPS` steps (on a straight run at one
    speed the step does not change the variance, only how finely the heading's share is
    summed)."""
    import numpy as np

    model = own_covariance(params.model)
    assert model is not None

    def end_variance(seconds: float, cycles: int) -> tuple[float, float, float]:
        n = max(1, min(cycles, _SLIP_STEPS))
        t = np.linspace(0.0, seconds, n + 1)
        ds = np.full(n + 1, speed * seconds / n)
        ds[0] = 0.0
        cov = model.pose_covariance(t, ds, ds, params, (0.0, 0.0, 0.0))[-1]
        return float(cov[0, 0]), float(cov[1, 1]), float(cov[2, 2])

    px, py, ph = end_variance(horizon / speed, math.ceil(horizon / speed * rate))
    span = window / rate
    tx, ty, th = end_variance(span, window)
    pose = (px, py, UNOBSERVED, UNOBSERVED, UNOBSERVED, ph)
    twist = (tx / span**2, ty / span**2, UNOBSERVED, UNOBSERVED, UNOBSERVED, th / span**2)
    return pose, twist


def controller_numbers(
    params: RobotParams,
    *,
    nominal: RobotParams | None = None,
    speed: float = DEFAULT_SPEED,
    rate: float = DEFAULT_RATE,
    horizon: float = DEFAULT_HORIZON,
    window: int = DEFAULT_WINDOW,
) -> ControllerExport:
    """What :func:`diff_drive_controller_yaml` writes, as numbers. ``rate``: the controller's
    update rate (Hz); ``window``: its ``velocity_rolling_window_size`` (cycles)."""
    v = _check_positive("speed", speed)
    f = _check_positive("rate", rate)
    d = _check_positive("horizon", horizon)
    w = _check_window(window)
    notes: list[str] = []
    # the best differential-drive equivalent, as multipliers of the [robot] radii
    u_left, u_right, separation, exact = _equivalent(params, v)
    r_left = params.left_wheel_radius * u_left
    r_right = params.right_wheel_radius * u_right
    if timed_model(params.model) is not None and not exact:
        notes.append(_slip_note(params, v))
    elif not exact:
        notes.append(
            f"the robot's kinematic model ({params.model.kind}) is not a differential drive: "
            "diff_drive_controller cannot express it. These values are its best "
            "differential-drive equivalent (straight runs and turns in place match; the forward "
            "motion during a turn in place and any sideways slip are lost). Use odolab's own "
            "odometry, or a controller that takes an ICR model, where that matters."
        )
    if nominal is None:
        base_r = 0.5 * (r_left + r_right)
        base_b = separation
    else:
        base_r = 0.5 * (nominal.left_wheel_radius + nominal.right_wheel_radius)
        base_b = nominal.track_width
    noise = params.noise
    source = covariance_source(params)
    if own_covariance(params.model) is not None:
        pose, twist = _slip_diagonals(params, v, f, d, w)
    elif noise is None:
        notes.append(
            "the parameters have no [noise] table: the covariance diagonals are placeholders "
            "(1e-3); measure k_left, k_right with `odolab analyze` or `odolab calibrate noise`"
        )
        twist = (1e-3, 1e-3, UNOBSERVED, UNOBSERVED, UNOBSERVED, 1e-3)
        pose = (1e-3, 1e-3, UNOBSERVED, UNOBSERVED, UNOBSERVED, 1e-3)
    else:
        assert noise is not None
        k = noise.k_left + noise.k_right
        b = separation
        var_vx = k * v * f / (4.0 * w)
        twist = (var_vx, var_vx, UNOBSERVED, UNOBSERVED, UNOBSERVED, k * v * f / (w * b**2))
        pose = (
            k * d / 4.0, k * d**3 / (3.0 * b**2), UNOBSERVED, UNOBSERVED, UNOBSERVED, k * d / b**2
        )  # fmt: skip
        from odolab.core.uncertainty import SECOND_ORDER_LIMIT

        # second-order index of the straight horizon (odolab.core.uncertainty.second_order_index):
        # shortening 1/2 integral of var(h) = d var(h_end) / 4 over the along-track deviation
        rho = (d * (k * d / b**2) / 4.0) / math.sqrt(k * d / 4.0) if k > 0 else 0.0
        if rho > SECOND_ORDER_LIMIT:
            notes.append(
                f"after {opt('horizon')} {d:g} m the first-order pose covariance understates the spread "
                f"(heading variance {k * d / b**2:.3g} rad^2, second-order index {rho:.3g} > "
                f"{SECOND_ORDER_LIMIT:g}): state it over a shorter horizon, or treat it as a "
                "lower bound"
            )
    return ControllerExport(
        wheel_separation=base_b,
        wheel_radius=base_r,
        wheel_separation_multiplier=separation / base_b,
        left_wheel_radius_multiplier=r_left / base_r,
        right_wheel_radius_multiplier=r_right / base_r,
        pose_covariance_diagonal=tuple(pose),
        twist_covariance_diagonal=tuple(twist),
        exact=exact,
        notes=tuple(notes),
        covariance_source=source,
    )


def _comment(text: str) -> list[str]:
    words = text.split()
    lines: list[str] = []
    line = "#"
    for w in words:
        if len(line) + 1 + len(w) > 96:
            lines.append(line)
            line = "#"
        line += " " + w
    lines.append(line)
    return lines


def _scalar(value: object) -> str:
    """Text for one comment line: numbers by repr; line breaks and every other control or
    invisible character shown as an escape (``\\x0a``), so that nothing ends the comment."""
    if isinstance(value, float):
        return repr(value)
    return safe_terminal(value, limit=200)


def _yaml_name(name: str, what: str = "controller_name", kind: str = "node") -> str:
    """``name`` if it is a ROS 2 node name (or, ``kind="joint"``, a URDF joint name that also
    allows ``-`` and ``.``); otherwise one sentence naming the setting ``what`` (its
    ``option``)."""
    extra = "_/" if kind == "node" else "_/-."
    if (
        not name
        or not all(ch.isascii() and (ch.isalnum() or ch in extra) for ch in name)
        or name[0].isdigit()
    ):
        allowed = ", ".join(repr(ch) for ch in extra)
        raise ParamsError(
            f"{opt(what)} {safe_terminal(repr(name), limit=80)} is not a ROS 2 {kind} name; "
            f"expected ASCII letters, digits and {allowed}, not starting with a digit",
            option=what,
            value=name,
            allowed=f"a ROS 2 {kind} name",
        )
    return name


# long: most of it is the YAML's table of keys and its comment header, one line each; the checks
# of the distro and the wheel names come first
def diff_drive_controller_yaml(
    params: RobotParams,
    *,
    nominal: RobotParams | None = None,
    controller: str = DEFAULT_CONTROLLER,
    speed: float = DEFAULT_SPEED,
    rate: float = DEFAULT_RATE,
    horizon: float = DEFAULT_HORIZON,
    window: int = DEFAULT_WINDOW,
    distro: str = DEFAULT_DISTRO,
    left_wheel_names: tuple[str, ...] = DEFAULT_LEFT_WHEELS,
    right_wheel_names: tuple[str, ...] = DEFAULT_RIGHT_WHEELS,
    provenance: dict[str, object] | None = None,
    words: Wording = NEUTRAL,
) -> str:
    """The YAML text: ``<controller>: ros__parameters: ...`` with provenance as comments, with
    exactly the keys ``distro``'s ``diff_drive_controller`` declares (:data:`DISTRO_KEYS`).
    ``words``: how its comments name the settings (the face's: the CLI's flags)."""
    if distro not in DISTRO_KEYS:
        raise ParamsError(
            option="ros_distro", value=distro, allowed=f"one of {', '.join(ROS_DISTROS)}"
        )
    keys = DISTRO_KEYS[distro]
    name = _yaml_name(controller)
    if len(left_wheel_names) != len(right_wheel_names):
        raise ParamsError(
            f"{opt('left_wheel')} given {len(left_wheel_names)} times and {opt('right_wheel')} "
            f"{len(right_wheel_names)} times; expected as many wheels on each side",
            option="right_wheel",
            value=len(right_wheel_names),
            allowed=f"{len(left_wheel_names)} wheels, as many as on the left",
        )
    for side, joints in (("left_wheel", left_wheel_names), ("right_wheel", right_wheel_names)):
        for joint in joints:
            _yaml_name(joint, side, "joint")
    n = controller_numbers(
        params, nominal=nominal, speed=speed, rate=rate, horizon=horizon, window=window
    )
    head = [
        f"# diff_drive_controller parameters written by odolab from {_scalar(repr(params.name))}"
        f" for ROS 2 {distro}.",
        "# Effective values (value x multiplier) are the calibrated ones:",
        f"#   left wheel radius  {n.effective_left_radius!r} m",
        f"#   right wheel radius {n.effective_right_radius!r} m",
        f"#   wheel separation   {n.effective_separation!r} m",
        f"# Twist covariance: the controller's own velocity estimate, the rolling mean over "
        f"velocity_rolling_window_size = {window} cycles at its update rate {rate!r} Hz (the "
        "controller_manager's update_rate; give it as {{rate}}), straight driving at "
        f"{speed!r} m/s.",
        f"# Pose covariance: after {horizon!r} m of straight driving. Both from "
        + {
            "noise": "[noise] (see odolab docs/ros2.md for the formulas).",
            "slip": "the slip model's predictive variance (docs/ros2.md).",
            None: "nothing: placeholders (see the note below).",
        }[n.covariance_source],
    ]
    for note in n.notes:
        head += _comment("NOTE: " + note)
    if provenance:
        head.append("# provenance:")
        for key, value in provenance.items():
            head.append(f"#   {_scalar(key)}: {_scalar(value)}")

    def flist(values: tuple[float, ...]) -> str:
        return "[" + ", ".join(yaml_float(v) for v in values) + "]"

    def slist(values: tuple[str, ...]) -> str:
        return "[" + ", ".join(f'"{v}"' for v in values) + "]"

    lines = [
        ("left_wheel_names", slist(left_wheel_names)),
        ("right_wheel_names", slist(right_wheel_names)),
        ("wheels_per_side", str(len(left_wheel_names))),
        ("wheel_separation", yaml_float(n.wheel_separation)),
        ("wheel_radius", yaml_float(n.wheel_radius)),
        ("wheel_separation_multiplier", yaml_float(n.wheel_separation_multiplier)),
        ("left_wheel_radius_multiplier", yaml_float(n.left_wheel_radius_multiplier)),
        ("right_wheel_radius_multiplier", yaml_float(n.right_wheel_radius_multiplier)),
        ("publish_rate", yaml_float(rate)),
        ("velocity_rolling_window_size", str(window)),
        ("pose_covariance_diagonal", flist(n.pose_covariance_diagonal)),
        ("twist_covariance_diagonal", flist(n.twist_covariance_diagonal)),
        ("odom_frame_id", "odom"),
        ("base_frame_id", "base_link"),
        ("open_loop", "false"),
        ("position_feedback", "true"),
        ("enable_odom_tf", "true"),
    ]
    body = [f"{name}:", "  ros__parameters:"]
    body += [f"    {key}: {value}" for key, value in lines if key in keys]
    return words.say("\n".join(head + body) + "\n")
