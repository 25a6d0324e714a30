"""Poses and trajectories: time, planar position, wrapped ``theta`` and unwrapped ``heading``."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odolab.core.errors import LogFormatError
from odolab.core.kinematics import wrap_angle

__all__ = [
    "MAX_COORDINATE_M",
    "MAX_TIME_S",
    "Pose",
    "Trajectory",
    "check_positions",
    "check_times",
    "yaw_from_quaternions",
]

#: Largest time stamp a log or trajectory may hold (s): a robot clock or a Unix time (the year
#: 2286). Past it a float64 loses the sample spacing (at 1e308 t + 0.05 == t): nanoseconds read
#: as seconds, or damage.
MAX_TIME_S = 1.0e10
#: Largest position coordinate a trajectory may hold (m): ten times a UTM northing. Past it the
#: squares of errors overflow a float64 (1e308 m gave numpy's overflow warning and an APE of inf).
MAX_COORDINATE_M = 1.0e8


class Pose(NamedTuple):
    """One pose: time (s), x, y (m), theta wrapped to (-pi, pi] and heading unwrapped (rad)."""

    t: float
    x: float
    y: float
    theta: float
    heading: float


def check_times(
    t: NDArray[np.float64],
    source: str = "t",
    *,
    row_offset: int = 0,
    line_of: Callable[[int], int] | None = None,
    what: str = "line",
    advancing: bool = True,
) -> None:
    """Raise :class:`LogFormatError` if ``t`` has a non-finite value or goes backwards, or
    (``advancing``) if every time is the same: a reader of chunks passes False for each chunk
    (a chunk of equal stamps is fine inside a file whose time advances) and checks the whole
    file's first and last time at its end (:func:`check_advanced`).

    ``row_offset`` is added to indexes in the message (e.g. 2 for a CSV with a header, so the
    message names the file's line number); ``line_of`` (index -> line), when given, is used
    instead, for files whose blank or comment lines make the offset vary. ``what`` names the
    position in the message (``"sample"`` for sources without lines, such as a bag).
    """

    def line(i: int) -> int:
        return line_of(i) if line_of is not None else i + row_offset

    if not np.isfinite(t).all():  # (no index array on the usual, clean input)
        i = int(np.argmax(~np.isfinite(t)))
        raise LogFormatError(f"{source}: time at {what} {line(i)} is {t[i]}, expected a number")
    if t.size and not (t.min() >= -MAX_TIME_S and t.max() <= MAX_TIME_S):
        i = int(np.argmax(np.abs(t) > MAX_TIME_S))
        raise LogFormatError(
            f"{source}: time at {what} {line(i)} is {t[i]:g} s; expected seconds from "
            f"{-MAX_TIME_S:g} to {MAX_TIME_S:g} (a robot clock or a Unix time)"
        )
    if t.size > 1:
        back = t[1:] < t[:-1]  # (no array of differences: a 10 M-sample log is 80 MB less)
        if back.any():
            i = int(np.argmax(back)) + 1
            raise LogFormatError(
                f"{source}: time goes backwards at {what} {line(i)} "
                f"({t[i]} after {t[i - 1]}); expected non-decreasing times"
            )
        # (non-decreasing: the last time is the first only if every one is). The line numbers
        # only for the refusal: ``line_of`` scans the file's lines (0.3 s a 100,000-pose TUM)
        if advancing and t[-1] == t[0]:
            check_advanced(
                float(t[0]), float(t[-1]), t.size, source, line(0), line(t.size - 1), what
            )


def check_advanced(
    first: float, last: float, rows: int, source: str, first_line: int, last_line: int, what: str
) -> None:
    """The whole file's time advanced (a chunked reader's end of :func:`check_times`)."""
    if rows > 1 and last == first:
        raise LogFormatError(
            f"{source}: the time is {first:g} s at every {what} from {first_line} to "
            f"{last_line}; expected times that advance"
        )


def _first(bad: NDArray[np.bool_], line_of: Callable[[int], int] | None) -> tuple[int, int]:
    """The index of the first True of ``bad`` (one is) and the line (``line_of``) or index
    that names it in a message."""
    i = int(np.argmax(bad))
    return i, line_of(i) if line_of is not None else i


def check_positions(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    source: str,
    *,
    line_of: Callable[[int], int] | None = None,
    what: str = "line",
) -> None:
    """Raise :class:`LogFormatError` if a position coordinate is not a number or lies beyond
    :data:`MAX_COORDINATE_M` (``line_of``: index -> the line or row named in the message)."""
    for name, v in (("x", x), ("y", y)):
        bad = ~(np.abs(v) <= MAX_COORDINATE_M)  # (NaN too)
        if bad.any():
            i, where = _first(bad, line_of)
            raise LogFormatError(
                f"{source}: {what} {where}, position {name} is {v[i]:g} m; expected a number "
                f"of metres from {-MAX_COORDINATE_M:g} to {MAX_COORDINATE_M:g}"
            )


def yaw_from_quaternions(
    qx: ArrayLike,
    qy: ArrayLike,
    qz: ArrayLike,
    qw: ArrayLike,
    source: str,
    *,
    line_of: Callable[[int], int] | None = None,
    what: str = "line",
) -> NDArray[np.float64]:
    """The yaw (rad) of each quaternion ``(qx, qy, qz, qw)``, whatever its length near 1 (TUM
    files keep 4 decimals, so ``|q|`` is 1 only to about 1e-4: both arguments of the arctangent
    scale with ``|q|^2``). A quaternion of length outside 0.5 to 1.5 (the zero quaternion, which
    is no rotation and was read as heading 0; NaN) is refused with :class:`LogFormatError`
    naming its line (``line_of``: index -> line or message number)."""
    x, y, z, w = (np.asarray(a, dtype=np.float64) for a in (qx, qy, qz, qw))
    length = np.hypot(np.hypot(x, y), np.hypot(z, w))  # (no overflow at 1e200)
    off = ~((length >= 0.5) & (length <= 1.5))  # (NaN, inf too)
    if off.any():
        i, where = _first(off, line_of)
        raise LogFormatError(
            f"{source}: {what} {where}, the quaternion qx qy qz qw = {x[i]:g} {y[i]:g} {z[i]:g} "
            f"{w[i]:g} has length {length[i]:.3g}; expected a unit quaternion (length 1), "
            "which is a rotation"
        )
    yaw: NDArray[np.float64] = np.arctan2(2.0 * (w * z + x * y), w * w + x * x - y * y - z * z)
    return yaw


def _f64(a: ArrayLike, name: str) -> NDArray[np.float64]:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim != 1:
        raise LogFormatError(f"trajectory {name} must be 1-D, got shape {arr.shape}")
    return arr


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A planar trajectory as parallel numpy arrays, shape (n,) each."""

    t: NDArray[np.float64]
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    theta: NDArray[np.float64]
    heading: NDArray[np.float64]

    def __post_init__(self) -> None:
        n = None
        for name in ("t", "x", "y", "theta", "heading"):
            arr = _f64(getattr(self, name), name)
            object.__setattr__(self, name, arr)
            if n is None:
                n = arr.size
            elif arr.size != n:
                raise LogFormatError(f"trajectory arrays differ in length: {name} has {arr.size}")

    @classmethod
    def from_xyh(cls, t: ArrayLike, x: ArrayLike, y: ArrayLike, heading: ArrayLike) -> Trajectory:
        """Build from an unwrapped heading; theta is derived by wrapping."""
        h = _f64(heading, "heading")
        return cls(_f64(t, "t"), _f64(x, "x"), _f64(y, "y"), wrap_angle(h), h)

    @classmethod
    def from_xytheta(cls, t: ArrayLike, x: ArrayLike, y: ArrayLike, theta: ArrayLike) -> Trajectory:
        """Build from a wrapped heading; heading is derived by unwrapping."""
        th = _f64(theta, "theta")
        return cls(_f64(t, "t"), _f64(x, "x"), _f64(y, "y"), wrap_angle(th), np.unwrap(th))

    def __len__(self) -> int:
        return int(self.t.size)

    # NDArray's shape is typing.Any inside numpy's own alias: not an Any of ours
    def __getitem__(  # type: ignore[explicit-any]
        self, index: int | slice | NDArray[np.bool_] | NDArray[np.int64]
    ) -> Trajectory:
        if isinstance(index, int):
            index = slice(index, index + 1 if index != -1 else None)
        return Trajectory(
            self.t[index], self.x[index], self.y[index], self.theta[index], self.heading[index]
        )

    def pose(self, i: int) -> Pose:
        """The i-th pose."""
        return Pose(
            float(self.t[i]),
            float(self.x[i]),
            float(self.y[i]),
            float(self.theta[i]),
            float(self.heading[i]),
        )

    @property
    def final(self) -> Pose:
        """The last pose."""
        return self.pose(-1)

    @property
    def xy(self) -> NDArray[np.float64]:
        """Positions, shape (n, 2)."""
        return np.column_stack((self.x, self.y))

    def path_length(self) -> float:
        """Distance travelled along the positions (m)."""
        return float(np.hypot(np.diff(self.x), np.diff(self.y)).sum())
