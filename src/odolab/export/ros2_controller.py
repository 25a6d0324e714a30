"""A ready-to-load ``diff_drive_controller`` parameter file from a calibrated parameter set.

ROS 2's ``diff_drive_controller`` computes odometry with ``wheel_separation *
wheel_separation_multiplier`` and ``wheel_radius * left_wheel_radius_multiplier`` (and right).
odolab writes the nominal geometry (``--nominal``, default: the calibrated set's mean radius and
track) as the base values and the calibration as the multipliers, so that value x multiplier
equals the calibrated effective radii and track exactly, and a person reading the file sees how
far the calibration moved each one.

The controller publishes a *fixed* diagonal covariance. odolab derives it from the ``[noise]``
table (per-wheel slip ``var(ds) = k |ds|``) at a stated speed ``v`` (m/s) and odometry rate ``f``
(Hz), for a straight run:

* twist (``vx``, ``wz``; per cycle of ``1/f`` s each wheel rolls ``v/f`` m, so a wheel speed has
  variance ``k v f``): ``var(vx) = (k_l + k_r) v f / 4``, ``var(wz) = (k_l + k_r) v f / b^2``
  (+ ``k_scrub`` does not enter a straight run); ``vy`` gets ``var(vx)`` (tracks and skid-steer
  bases do slip sideways; a wheeled base may lower it);
* pose: the covariance of a straight run of ``horizon`` metres (default 1 m;
  :func:`odolab.uncertainty.straight_line_covariance`): ``var x = k d / 4``,
  ``var y = k d^3 / (3 b^2)``, ``var yaw = k d / b^2`` with ``k = k_l + k_r``;
* ``z``, ``roll``, ``pitch`` (not observed by planar odometry): :data:`UNOBSERVED` (1e6).

The fixed values can only describe one motion; the propagated covariance
(:func:`odolab.uncertainty.propagate_covariance`, the ``/odom`` messages of ``odolab export
mcap``) grows with the path as it should.

Models the controller cannot express (``extended`` with unequal weights, ``icr``): the file says
so and gives the best differential-drive equivalent: radius multipliers from the rotation terms
and the separation from the model's rotation denominator, so that straight runs and turns in
place match; the forward motion during a turn in place and the sideways motion (``x_icr``) are
lost.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from odolab.errors import ParamsError
from odolab.params import RobotParams
from odolab.text import safe_terminal

__all__ = [
    "LIMITS",
    "UNOBSERVED",
    "ControllerExport",
    "controller_numbers",
    "diff_drive_controller_yaml",
]

#: Variance written for the terms planar odometry does not observe (z, roll, pitch).
UNOBSERVED = 1e6
#: Largest ``--speed`` (m/s), ``--rate`` (Hz) and ``--horizon`` (m) accepted: far beyond any
#: wheeled robot, small enough that every covariance term stays a finite number.
LIMITS = {"--speed": 100.0, "--rate": 100_000.0, "--horizon": 100_000.0}


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
        raise ParamsError(f"{name} is {value!r}; expected a positive number up to {limit:g}")
    return float(value)


def controller_numbers(
    params: RobotParams,
    *,
    nominal: RobotParams | None = None,
    speed: float = 0.5,
    rate: float = 50.0,
    horizon: float = 1.0,
) -> ControllerExport:
    """What :func:`diff_drive_controller_yaml` writes, as numbers."""
    v = _check_positive("--speed", speed)
    f = _check_positive("--rate", rate)
    d = _check_positive("--horizon", horizon)
    c = params.coefficients
    notes: list[str] = []
    # effective radii and separation of the best differential-drive equivalent
    r_left = params.left_wheel_radius * c.e_left
    r_right = params.right_wheel_radius * c.e_right
    separation = c.denominator
    exact = (
        math.isclose(2.0 * c.w_left, c.e_left, rel_tol=1e-12)
        and math.isclose(2.0 * c.w_right, c.e_right, rel_tol=1e-12)
        and c.lateral == 0.0
    )
    if not exact:
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
    if noise is None:
        notes.append(
            "the parameters have no [noise] table: the covariance diagonals are placeholders "
            "(1e-3); measure k_left, k_right with `odolab analyze` or `odolab calibrate noise`"
        )
        twist = (1e-3, 1e-3, UNOBSERVED, UNOBSERVED, UNOBSERVED, 1e-3)
        pose = (1e-3, 1e-3, UNOBSERVED, UNOBSERVED, UNOBSERVED, 1e-3)
    else:
        k = noise.k_left + noise.k_right
        b = separation
        var_vx = k * v * f / 4.0
        twist = (var_vx, var_vx, UNOBSERVED, UNOBSERVED, UNOBSERVED, k * v * f / b**2)
        pose = (
            k * d / 4.0, k * d**3 / (3.0 * b**2), UNOBSERVED, UNOBSERVED, UNOBSERVED, k * d / b**2
        )  # fmt: skip
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


def _scalar(value: Any) -> str:
    """Text for one comment line: numbers by repr; line breaks and every other control or
    invisible character shown as an escape (``\\x0a``), so that nothing ends the comment."""
    if isinstance(value, float):
        return repr(value)
    return safe_terminal(value, limit=200)


def _yaml_name(name: str, what: str = "--controller-name", kind: str = "node") -> str:
    """``name`` if it is a ROS 2 node name (or, ``kind="joint"``, a URDF joint name that also
    allows ``-`` and ``.``); otherwise one sentence naming the option ``what``."""
    extra = "_/" if kind == "node" else "_/-."
    if (
        not name
        or not all(ch.isascii() and (ch.isalnum() or ch in extra) for ch in name)
        or name[0].isdigit()
    ):
        allowed = ", ".join(repr(ch) for ch in extra)
        raise ParamsError(
            f"{what} {safe_terminal(repr(name), limit=80)} is not a ROS 2 {kind} name; expected "
            f"ASCII letters, digits and {allowed}, not starting with a digit"
        )
    return name


def diff_drive_controller_yaml(
    params: RobotParams,
    *,
    nominal: RobotParams | None = None,
    controller: str = "diff_drive_controller",
    speed: float = 0.5,
    rate: float = 50.0,
    horizon: float = 1.0,
    left_wheel_names: tuple[str, ...] = ("left_wheel_joint",),
    right_wheel_names: tuple[str, ...] = ("right_wheel_joint",),
    provenance: dict[str, Any] | None = None,
) -> str:
    """The YAML text: ``<controller>: ros__parameters: ...`` with provenance as comments."""
    name = _yaml_name(controller)
    for side, joints in (("--left-wheel", left_wheel_names), ("--right-wheel", right_wheel_names)):
        for joint in joints:
            _yaml_name(joint, side, "joint")
    n = controller_numbers(params, nominal=nominal, speed=speed, rate=rate, horizon=horizon)
    head = [
        f"# diff_drive_controller parameters written by odolab from {_scalar(repr(params.name))}.",
        "# Effective values (value x multiplier) are the calibrated ones:",
        f"#   left wheel radius  {n.effective_left_radius!r} m",
        f"#   right wheel radius {n.effective_right_radius!r} m",
        f"#   wheel separation   {n.effective_separation!r} m",
        f"# Covariance from [noise] at {speed!r} m/s and {rate!r} Hz, pose after {horizon!r} m"
        " of straight driving (see odolab docs/ros2.md for the formula).",
    ]
    for note in n.notes:
        head += _comment("NOTE: " + note)
    if provenance:
        head.append("# provenance:")
        for key, value in provenance.items():
            head.append(f"#   {_scalar(key)}: {_scalar(value)}")

    def flist(values: tuple[float, ...]) -> str:
        return "[" + ", ".join(repr(float(v)) for v in values) + "]"

    def slist(values: tuple[str, ...]) -> str:
        return "[" + ", ".join(f'"{v}"' for v in values) + "]"

    body = [
        f"{name}:",
        "  ros__parameters:",
        f"    left_wheel_names: {slist(left_wheel_names)}",
        f"    right_wheel_names: {slist(right_wheel_names)}",
        f"    wheels_per_side: {len(left_wheel_names)}",
        f"    wheel_separation: {n.wheel_separation!r}",
        f"    wheel_radius: {n.wheel_radius!r}",
        f"    wheel_separation_multiplier: {n.wheel_separation_multiplier!r}",
        f"    left_wheel_radius_multiplier: {n.left_wheel_radius_multiplier!r}",
        f"    right_wheel_radius_multiplier: {n.right_wheel_radius_multiplier!r}",
        f"    publish_rate: {float(rate)!r}",
        f"    pose_covariance_diagonal: {flist(n.pose_covariance_diagonal)}",
        f"    twist_covariance_diagonal: {flist(n.twist_covariance_diagonal)}",
        "    odom_frame_id: odom",
        "    base_frame_id: base_link",
        "    open_loop: false",
        "    position_feedback: true",
        "    enable_odom_tf: true",
    ]
    return "\n".join(head + body) + "\n"
