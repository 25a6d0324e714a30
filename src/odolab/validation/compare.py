"""Old vs new parameters vs a phone IMU: the lab's Fig. 21, with numbers.

:func:`validate` integrates one encoder log with two parameter sets, finds the clock offset to a
phone IMU log (:mod:`odolab.validation.align`), and compares each odometry heading with the
IMU's, on the IMU's samples inside the overlap. All headings are changes since the start of the
overlap (the IMU's yaw has an arbitrary zero), so both errors start at zero there.
``error = predicted - actual`` = odometry heading change - IMU heading change (rad).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np

from odolab.core.arrays import FloatArray
from odolab.core.errors import ImuLogError
from odolab.core.kinematics import Method
from odolab.core.odometry import integrate
from odolab.core.params import RobotParams
from odolab.core.text import figure_text
from odolab.core.trajectory import Trajectory
from odolab.core.trials import EncoderLog
from odolab.validation.align import ClockAlignment, check_search, find_clock_offset
from odolab.validation.sensorlog import ImuLog

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from odolab.robot.drift import SenseFinding

__all__ = ["HeadingError", "ValidationResult", "plot_validation", "validate", "validation_figure"]


#: Below this peak rate correlation the result carries a warning.
LOW_CORRELATION = 0.8


def _rms(e: FloatArray) -> float:
    return float(np.sqrt(np.mean(np.square(e))))


@dataclass(frozen=True, eq=False)
class HeadingError:
    """One parameter set against the IMU: heading change (rad) and its error on the common
    times, shape (m,) each, with summary numbers (rad) and the rotation ratio actual/predicted."""

    label: str
    params: RobotParams
    heading: FloatArray
    error: FloatArray

    @property
    def rms(self) -> float:
        """Root mean square of the error over the overlap (rad)."""
        return _rms(self.error)

    @property
    def final(self) -> float:
        """Error at the end of the overlap (rad)."""
        return float(self.error[-1])

    @property
    def max_abs(self) -> float:
        """Largest absolute error over the overlap (rad)."""
        return float(np.max(np.abs(self.error)))

    def summary(self) -> dict[str, object]:
        total = float(self.heading[-1])
        actual = total - self.final
        return {
            "label": self.label,
            "params": self.params.to_dict(),
            "rms_error_rad": self.rms,
            "final_error_rad": self.final,
            "max_abs_error_rad": self.max_abs,
            "predicted_rotation_rad": total,
            "ratio_actual_over_predicted": actual / total if total != 0 else None,
        }


@dataclass(frozen=True, eq=False)
class ValidationResult:
    """Everything :func:`validate` found. ``t`` (s, robot clock, shape (m,)) are the IMU's
    samples inside the overlap; ``imu_heading`` (rad) the IMU's heading change since ``t[0]``;
    ``old``/``new`` the two parameter sets' headings and errors on the same times."""

    t: FloatArray
    imu_heading: FloatArray
    old: HeadingError
    new: HeadingError
    alignment: ClockAlignment
    method: str
    encoder_source: str
    imu_source: str
    imu_heading_column: str
    warnings: tuple[str, ...] = ()

    @property
    def clock_offset(self) -> float:
        """Phone clock minus robot clock (s)."""
        return self.alignment.clock_offset

    @property
    def improvement(self) -> float:
        """RMS error of the new parameters over that of the old (below 1 = better)."""
        return self.new.rms / self.old.rms if self.old.rms > 0 else math.inf

    def to_dict(self, *, series: bool = True) -> dict[str, object]:
        """Plain JSON-able dict: summary numbers, and (with ``series``) the time series."""
        a = self.alignment
        out: dict[str, object] = {
            "encoder_log": self.encoder_source,
            "imu_log": self.imu_source,
            "imu_heading_column": self.imu_heading_column,
            "method": self.method,
            "clock_offset_s": a.clock_offset,
            "clock_offset_meaning": "phone clock minus robot clock",
            "offset_correlation": None if math.isnan(a.correlation) else a.correlation,
            "offset_search_s": [v if math.isfinite(v) else None for v in a.searched],
            "overlap_s": [a.overlap_start, a.overlap_end],
            "samples": int(self.t.size),
            "imu_rotation_rad": float(self.imu_heading[-1]),
            "old": self.old.summary(),
            "new": self.new.summary(),
            "rms_ratio_new_over_old": self.improvement,
            "warnings": list(self.warnings),
        }
        if series:
            out["series"] = {
                "t_s": self.t.tolist(),
                "imu_heading_rad": self.imu_heading.tolist(),
                "old_heading_rad": self.old.heading.tolist(),
                "new_heading_rad": self.new.heading.tolist(),
                "old_error_rad": self.old.error.tolist(),
                "new_error_rad": self.new.error.tolist(),
            }
        return out


def _with_log_modulus(params: RobotParams, log: EncoderLog) -> RobotParams:
    if log.modulus is not None and params.encoder_modulus != log.modulus:
        return params.with_(encoder_modulus=log.modulus)
    return params


def _noop(_: str) -> None:
    return None


def _integrated(
    encoder_log: EncoderLog, params: RobotParams, m: Method, encoder_source: str
) -> Trajectory:
    return integrate(
        encoder_log.t,
        encoder_log.left_ticks,
        encoder_log.right_ticks,
        _with_log_modulus(params, encoder_log),
        m,
        source=encoder_source,
    )


def _warnings(
    align: ClockAlignment, old_error: HeadingError, imu_h: FloatArray, t: FloatArray
) -> list[str]:
    """What the comparison saw that may make it wrong: a weak correlation, opposite senses, a
    sense check of the old parameters' odometry that fails."""
    warnings = []
    if not math.isnan(align.correlation) and align.correlation < LOW_CORRELATION:
        warnings.append(
            f"the yaw rates correlate only {align.correlation:.2f} at the clock offset found "
            f"({align.clock_offset:+.2f} s): either the true yaw rate is noisy (tracks that "
            "scrub), or the logs do not record the same motion, or the offset search range is "
            "wrong; check the heading plot"
        )
    old_total, imu_total = old_error.heading[-1], imu_h[-1]
    if abs(imu_total) > 0.5 and old_total * imu_total < 0:
        warnings.append(
            f"the IMU turned {imu_total:.2f} rad but the odometry {old_total:.2f} rad: opposite "
            "senses; is the phone face down (flip the IMU)?"
        )
    else:  # the same rule as a robot's live sense check (odolab.robot.drift.sense_check)
        from odolab.robot.drift import sense_check

        found = sense_check(float(old_total), float(imu_total), float(t[-1] - t[0]))
        if found is not None:
            warnings.append(
                f"sense check of the odometry (old parameters) against the IMU: "
                f"{_log_sense_sentence(found)}"
            )
    return warnings


def validate(
    encoder_log: EncoderLog,
    imu: ImuLog,
    old: RobotParams,
    new: RobotParams,
    *,
    offset: float = 0.0,
    max_offset: float = 30.0,
    method: Method | str = "midpoint",
    min_overlap: float = 1.0,
    smooth: float = 0.1,
    encoder_source: str = "encoder log",
    progress: Callable[[str], None] = _noop,
) -> ValidationResult:
    """Compare the heading of ``old`` and ``new`` parameters with a phone IMU's.

    ``encoder_log``: raw counters on the robot clock; ``imu``: the phone's heading on its own
    clock. ``offset`` (s, phone minus robot) is the nominal clock offset and ``max_offset`` (s)
    how far from it to search (0 = use ``offset`` as is; ``math.inf`` = any offset leaving
    ``min_overlap`` seconds of overlap). The counters' wrap is the log's (``encoder_log.modulus``)
    when it has one. Raises :class:`ImuLogError` when the logs do not overlap.
    """
    m = Method(method)
    check_search(offset, max_offset, smooth)  # before any work
    if len(encoder_log) < 2:
        raise ImuLogError(f"{encoder_source}: {len(encoder_log)} sample(s); at least 2 are needed")
    progress("integrating the encoder log with the old and the new parameters")
    trajs = [_integrated(encoder_log, p, m, encoder_source) for p in (old, new)]
    progress("finding the clock offset between the phone and the robot")
    align = find_clock_offset(
        trajs[0].t,
        trajs[0].heading,
        imu,
        nominal_offset=offset,
        max_offset=max_offset,
        min_overlap=min_overlap,
        smooth=smooth,
        robot_source=encoder_source,
    )
    t_robot = imu.t - align.clock_offset
    inside = (t_robot >= align.overlap_start) & (t_robot <= align.overlap_end)
    if inside.sum() < 2:
        raise ImuLogError(
            f"{imu.source}: fewer than 2 IMU samples fall inside the encoder log after aligning "
            f"the clocks (offset {align.clock_offset:.3f} s)"
        )
    t = t_robot[inside]
    imu_h = imu.yaw[inside] - imu.yaw[inside][0]
    errors = []
    for label, params, traj in (("old", old, trajs[0]), ("new", new, trajs[1])):
        h = np.interp(t, traj.t, traj.heading)
        h = h - h[0]
        errors.append(HeadingError(label, params, h, h - imu_h))
    warnings = _warnings(align, errors[0], imu_h, t)
    progress("done")
    return ValidationResult(
        t,
        imu_h,
        errors[0],
        errors[1],
        align,
        m.value,
        encoder_source,
        imu.source,
        imu.heading_column,
        tuple(warnings),
    )


def _log_sense_sentence(found: SenseFinding) -> str:
    """The sense check's finding in a log's words: what can be wrong in an encoder log, its
    parameters and a phone's IMU log (no link, no robot options: those are a robot run's)."""
    said = (
        f"odometry {found.odometry_turn:+.2f} rad, IMU {found.gyro_turn:+.2f} rad over "
        f"{found.elapsed:.1f} s"
    )
    if found.kind == "opposite":
        return (
            f"odometry and IMU turn opposite ways ({said}): likely the left and right wheel "
            "columns swapped in the encoder log, both encoder signs reversed in the params, "
            "or the phone mounted upside down"
        )
    shown = "infinite" if not math.isfinite(found.ratio) else f"{found.ratio:.2f}"
    which = "the IMU" if abs(found.gyro_turn) > abs(found.odometry_turn) else "the odometry"
    lo, hi = found.expected
    return (
        f"{which} saw much more turning than the other ({said}; IMU/odometry {shown}, "
        f"calibrated {lo:.2f} to {hi:.2f}): likely one encoder sign reversed in the params "
        "(one encoder counting backwards), counts per revolution or track width in the params "
        "far from this robot's, or the phone's heading taken about the wrong axis (not "
        "mounted flat)"
    )


# --------------------------------------------------------------------------------------------
# plots


def plot_validation(
    result: ValidationResult,
    ax: Axes | None = None,
    *,
    kind: Literal["heading", "error"] = "heading",
) -> Axes:
    """Fig. 21: heading change vs time of the IMU, the old and the new model (``kind="heading"``),
    or the two models' heading error vs time (``kind="error"``). Returns the axes."""
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(8, 4.5))
    t = result.t - result.t[0]
    old, new = result.old, result.new
    if kind == "heading":
        ax.plot(t, result.imu_heading, color="black", lw=2.0, label="IMU (phone)")
        ax.plot(
            t,
            old.heading,
            color="tab:red",
            lw=1.3,
            ls="--",
            label=f"old model ({figure_text(old.params.name)})",
        )
        ax.plot(
            t,
            new.heading,
            color="tab:blue",
            lw=1.3,
            label=f"new model ({figure_text(new.params.name)})",
        )
        ax.set_ylabel("heading change (rad)")
        ax.set_title("Heading: old vs new model vs IMU")
    elif kind == "error":
        ax.axhline(0.0, color="black", lw=0.8)
        ax.plot(t, old.error, color="tab:red", lw=1.3, ls="--", label=f"old: RMS {old.rms:.3f} rad")
        ax.plot(t, new.error, color="tab:blue", lw=1.3, label=f"new: RMS {new.rms:.3f} rad")
        ax.set_ylabel("heading error, odometry - IMU (rad)")
        ax.set_title("Heading error vs IMU")
    else:
        raise ValueError(f"kind must be 'heading' or 'error', got {kind!r}")
    ax.set_xlabel("time from the start of the overlap (s)")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best")
    return ax


def validation_figure(result: ValidationResult) -> Figure:
    """Two stacked panels sharing the time axis: headings (top) and errors (bottom)."""
    import matplotlib.pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    plot_validation(result, top, kind="heading")
    plot_validation(result, bottom, kind="error")
    top.set_xlabel("")
    fig.suptitle(
        f"Validation against a phone IMU (clock offset {result.clock_offset:.3f} s, "
        f"RMS new/old {result.improvement:.2f})"
    )
    fig.tight_layout()
    return fig
