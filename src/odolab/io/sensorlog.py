"""Phone IMU logs in the SensorLog app's CSV format (the lab's Fig. 21), read and written.

SensorLog writes one row per logging tick with a header of names carrying their units in
parentheses (``motionYaw(rad)``, ``loggingTime(txt)``, ``locationTrueHeading(°)`` ...). Which
columns exist depends on the sensors enabled, and a cell is empty where a sensor had no new
sample, so columns are found BY NAME (the part before the parenthesis) and rows are kept per
sensor. See ``/work/shared/SENSORLOG.md`` and ``docs/validation.md``.

Conventions: ``yaw`` is counter-clockwise positive about the phone's z axis (the phone lies face
up on the robot), in rad, unwrapped; the compass (degrees clockwise from north) is used only as a
fall-back heading, with its sign flipped. Times ``t`` are on the phone's own clock (seconds since
the phone rebooted when the ``..._sinceReboot(s)`` clocks are there, else POSIX seconds parsed from
``loggingTime(txt)``).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from odolab.core.arrays import FloatArray
from odolab.core.errors import ImuLogError
from odolab.core.kinematics import wrap_angle
from odolab.core.trajectory import MAX_TIME_S

if TYPE_CHECKING:
    import polars as pl

__all__ = [
    "DEFAULT_START",
    "WRITTEN_COLUMNS",
    "ImuLog",
    "check_imu_log",
    "rate_aided_unwrap",
    "read_sensorlog",
    "write_sensorlog",
]


#: Default wall-clock start of a written log (the format's own example time).
DEFAULT_START = datetime(2013, 10, 3, 14, 5, 11, 532000, tzinfo=timezone(timedelta(hours=-7)))

LOGGING_TIME = "loggingTime(txt)"


@dataclass(frozen=True, eq=False)
class ImuLog:
    """A phone's heading over time, on the phone's own clock.

    ``t`` (s, shape (n,), strictly increasing), ``yaw`` (rad, unwrapped, counter-clockwise
    positive; its zero is arbitrary), ``yaw_rate`` (rad/s, shape (n,), or None when the log has
    no gyro). ``wallclock_offset`` (s) turns ``t`` into POSIX time (``t + wallclock_offset``),
    when the log has ``loggingTime(txt)``. ``heading_column``/``time_column`` name what was read.
    """

    t: FloatArray
    yaw: FloatArray
    yaw_rate: FloatArray | None = None
    source: str = "IMU log"
    heading_column: str = ""
    rate_column: str | None = None
    time_column: str = ""
    wallclock_offset: float | None = None

    def __post_init__(self) -> None:
        check_imu_log(self.t, self.yaw, self.yaw_rate, self.source)

    def __len__(self) -> int:
        return int(self.t.size)

    @property
    def duration(self) -> float:
        """Time from the first to the last sample (s)."""
        return float(self.t[-1] - self.t[0])

    def flipped(self) -> ImuLog:
        """The same log with yaw and yaw rate negated: for a phone lying face down."""
        rate = None if self.yaw_rate is None else -self.yaw_rate
        return ImuLog(
            self.t,
            -self.yaw,
            rate,
            self.source,
            f"-{self.heading_column}",
            None if self.rate_column is None else f"-{self.rate_column}",
            self.time_column,
            self.wallclock_offset,
        )

    def on_wallclock(self) -> ImuLog:
        """The same log with ``t`` in POSIX seconds (needs ``loggingTime(txt)`` in the file).

        Raises:
            ImuLogError: the log has no wall-clock time.
        """
        if self.wallclock_offset is None:
            raise ImuLogError(
                f"{self.source}: no wall-clock time in the log; expected a {LOGGING_TIME} column"
            )
        return ImuLog(
            self.t + self.wallclock_offset,
            self.yaw,
            self.yaw_rate,
            self.source,
            self.heading_column,
            self.rate_column,
            self.time_column + " + wall-clock offset",
            0.0,
        )


def check_imu_log(
    t: ArrayLike, yaw: ArrayLike, yaw_rate: ArrayLike | None, source: str = "IMU log"
) -> None:
    """Raise :class:`ImuLogError` unless ``t``/``yaw``(/``yaw_rate``) are a usable IMU log.

    Raises:
        ImuLogError: the arrays differ in length, hold fewer than two samples, a time does not
            increase, or a value is not finite.
    """
    tt = np.asarray(t, dtype=np.float64)
    yy = np.asarray(yaw, dtype=np.float64)
    if tt.ndim != 1 or yy.shape != tt.shape:
        raise ImuLogError(f"{source}: t and yaw must be 1-D of the same length")
    if tt.size < 2:
        raise ImuLogError(f"{source}: {tt.size} heading sample(s); at least 2 are needed")
    if yaw_rate is not None and np.asarray(yaw_rate).shape != tt.shape:
        raise ImuLogError(f"{source}: yaw_rate has a different length from t")
    arrays = [("t", tt), ("yaw", yy)]
    if yaw_rate is not None:
        arrays.append(("yaw_rate", np.asarray(yaw_rate, dtype=np.float64)))
    for name, arr in arrays:
        bad = ~np.isfinite(arr)
        if bad.any():
            raise ImuLogError(f"{source}: {name}[{int(np.argmax(bad))}] is not a finite number")
    back = np.diff(tt) <= 0
    if back.any():
        i = int(np.argmax(back)) + 1
        raise ImuLogError(
            f"{source}: time does not increase at sample {i} ({tt[i]} after {tt[i - 1]})"
        )


def rate_aided_unwrap(
    t: FloatArray, wrapped: FloatArray, rate: FloatArray | None = None
) -> FloatArray:
    """Unwrap an angle (rad), using the rate (rad/s) to count whole turns across long gaps.

    Shapes (n,). Without ``rate`` this is :func:`numpy.unwrap`. With it, each step is the
    wrapped difference plus the number of whole turns that brings it closest to the
    trapezoidal integral of the rate over the step (so a gap longer than half a turn is kept).
    """
    if rate is None or wrapped.size < 2:
        return np.asarray(np.unwrap(wrapped), dtype=np.float64)
    d = np.diff(wrapped)
    d = wrap_angle(d)
    predicted = 0.5 * (rate[1:] + rate[:-1]) * np.diff(t)
    d = d + 2.0 * math.pi * np.round((predicted - d) / (2.0 * math.pi))
    out = np.empty_like(wrapped)
    out[0] = wrapped[0]
    out[1:] = wrapped[0] + np.cumsum(d)
    return out


# --------------------------------------------------------------------------------------------
# reading


def _base(name: str) -> str:
    """A column's name without its unit: ``motionYaw(rad)`` -> ``motionYaw``."""
    return name.split("(", 1)[0].strip()


class _Table:
    """The text cells of a SensorLog CSV (stripped; empty where missing), with lookups by
    column base name. Read by polars' parser as text (row ``i`` is the file's line ``i + 2``:
    blank lines are rows of empty cells); a layout polars refuses is read by Python's csv reader."""

    def __init__(self, path: Path) -> None:
        self.path = path
        if not path.exists():
            raise ImuLogError(f"{path}: no such file")
        from odolab.io.limits import check_text_file  # (SensorLog repeats unused names)

        check_text_file(path, error=ImuLogError, expected="a SensorLog CSV")
        try:
            with path.open(newline="", encoding="utf-8-sig") as fh:
                first = fh.readline()
        except (OSError, UnicodeDecodeError) as err:
            raise ImuLogError(f"{path}: cannot read as UTF-8 text ({err})") from err
        if not first.strip():
            raise ImuLogError(f"{path}: empty file; expected a SensorLog header line")
        self.sep = ";" if first.count(";") > first.count(",") else ","
        self.header = [c.strip() for c in next(csv.reader([first], delimiter=self.sep))]
        self.by_base: dict[str, str] = {}
        self._pos: dict[str, int] = {}
        for j, name in enumerate(self.header):
            if _base(name) not in self.by_base:
                self.by_base[_base(name)] = name
                self._pos[_base(name)] = j
        self._cells: dict[int, NDArray[np.str_]] = {}
        self._frame = self._read_polars()
        if self._frame is None:
            self._cells = dict(enumerate(self._read_csv()))

    def _read_polars(self) -> pl.DataFrame | None:
        """The cells as a polars frame of text; None where polars cannot be trusted with the
        layout (lines ended by a bare carriage return, quotes)."""
        import polars as pl

        data = self.path.read_bytes()  # (checked: UTF-8, lines of at most 1 MB)
        if b"\r" in data.replace(b"\r\n", b"") or b'"' in data:
            return None
        names = [f"c{j}" for j in range(len(self.header))]
        try:
            frame = pl.read_csv(
                data, has_header=False, skip_rows=1, separator=self.sep, new_columns=names,
                infer_schema=False, truncate_ragged_lines=False, encoding="utf8",
                quote_char=None,
            )  # fmt: skip
        except pl.exceptions.PolarsError:
            return None
        if frame.width != len(names):
            return None
        return frame

    def _read_csv(self) -> list[NDArray[np.str_]]:
        """Every cell as text by Python's csv reader (lines ended by a bare carriage return,
        quotes): a line is a row (a blank one of empty cells), short rows' missing cells are
        empty; a row longer than the header is refused."""
        width = len(self.header)
        cols: list[list[str]] = [[] for _ in range(width)]
        try:
            with self.path.open(newline="", encoding="utf-8-sig") as fh:
                reader = csv.reader(fh, delimiter=self.sep)
                next(reader, None)  # the header
                for row in reader:
                    if len(row) > width:
                        raise ImuLogError(
                            f"{self.path}: not a readable CSV table (line {reader.line_num} "
                            f"has {len(row)} cells, the header {width})"
                        )
                    for j in range(width):
                        cols[j].append(row[j].strip() if j < len(row) else "")
        except (csv.Error, UnicodeDecodeError) as err:
            why = " ".join(str(err).split())
            raise ImuLogError(f"{self.path}: not a readable CSV table ({why})") from err
        return [np.asarray(c, dtype=str) for c in cols]

    def has(self, base: str) -> bool:
        return base in self.by_base

    def name(self, base: str) -> str:
        return self.by_base[base]

    def _column(self, base: str) -> NDArray[np.str_]:
        j = self._pos[base]
        if j not in self._cells:  # polars' column, stripped, missing cells empty
            assert self._frame is not None  # (without a frame every column was read at once)
            series = self._frame.get_column(f"c{j}").fill_null("").str.strip_chars()
            self._cells[j] = np.asarray(series.to_numpy(), dtype=str)
        return self._cells[j]

    def present(self, base: str) -> NDArray[np.bool_]:
        """Rows whose cell in the column is not empty."""
        return np.asarray(self._column(base) != "", dtype=bool)

    def numbers(self, base: str) -> FloatArray:
        """The column as float64; empty cells are nan; text is an error naming the line."""
        col = self._column(base)
        filled = col != ""
        values = np.full(col.shape, np.nan)
        try:
            values[filled] = col[filled].astype(np.float64)  # (Python's float, in C)
        except ValueError:
            for i in np.flatnonzero(filled):  # the first cell that is not a number
                try:
                    values[i] = float(col[i])
                except ValueError:
                    raise ImuLogError(
                        f"{self.path}: line {i + 2}, column {self.name(base)!r} is "
                        f"{str(col[i])!r}, expected a number"
                    ) from None
        return values

    def posix_times(self) -> FloatArray:
        """``loggingTime(txt)`` as POSIX seconds (nan where empty); bad text names the line.
        SensorLog's own form by polars; any other (ISO 8601) cell by Python, one at a time."""
        import polars as pl

        col = self._column("loggingTime")
        filled = col != ""
        parsed = pl.Series(col).str.to_datetime(
            "%Y-%m-%d %H:%M:%S%.f %z", strict=False, time_unit="us", time_zone="UTC"
        )
        us = parsed.dt.epoch("us").to_numpy()  # (microseconds, as pandas parsed them before)
        out = np.where(filled, us.astype(np.float64) / 1e6, np.nan)  # (null: nan)
        for i in np.flatnonzero(filled & np.isnan(out)):
            text = str(col[i])
            try:
                stamp: datetime | None = datetime.fromisoformat(text)
            except ValueError:
                stamp = None
            if stamp is None or stamp.tzinfo is None:
                raise ImuLogError(
                    f"{self.path}: line {i + 2}, column {self.name('loggingTime')!r} is "
                    f"{text!r}, expected a date-time like '2013-10-03 14:05:11.532 -0700'"
                )
            out[i] = stamp.timestamp()
        return out


#: Heading sources, best first: (kind, column base name, its own time column base name).
_YAW = ("motionYaw", "motionTimestamp_sinceReboot")
_RATES = (
    ("motionRotationRateZ", "motionTimestamp_sinceReboot"),
    ("gyroRotationZ", "gyroTimestamp_sinceReboot"),
)
_COMPASS = ("locationTrueHeading", "locationMagneticHeading")
_COMPASS_TIME = "locationHeadingTimestamp_since1970"


def _times_for(
    tab: _Table, rows: NDArray[np.bool_], time_base: str, wall: FloatArray | None
) -> tuple[FloatArray, str]:
    """Times (s) of the selected rows from the sensor's own clock, else ``loggingTime(txt)``."""
    if tab.has(time_base):
        t = tab.numbers(time_base)[rows]
        missing = np.isnan(t)
        if missing.any():
            line = int(np.flatnonzero(rows)[int(np.argmax(missing))]) + 2
            raise ImuLogError(
                f"{tab.path}: line {line}, column {tab.name(time_base)!r} is empty on a row with "
                "a heading sample; expected its time stamp"
            )
        far = ~(np.abs(t) <= MAX_TIME_S)
        if far.any():  # (past it the spacing is lost, and the clock offset overflows)
            k = int(np.argmax(far))
            line = int(np.flatnonzero(rows)[k]) + 2
            raise ImuLogError(
                f"{tab.path}: line {line}, column {tab.name(time_base)!r} is {float(t[k]):g} s; "
                f"expected seconds from {-MAX_TIME_S:g} to {MAX_TIME_S:g}"
            )
        return t, tab.name(time_base)
    if wall is None:
        raise ImuLogError(
            f"{tab.path}: no time column for the heading; expected {time_base}(s) or "
            f"{LOGGING_TIME}, but the header has: {', '.join(tab.header)}"
        )
    return wall[rows], LOGGING_TIME


def _check_increasing(tab: _Table, t: FloatArray, rows: NDArray[np.bool_], column: str) -> None:
    back = np.diff(t) < 0
    if back.any():
        k = int(np.argmax(back)) + 1
        line = int(np.flatnonzero(rows)[k]) + 2
        raise ImuLogError(
            f"{tab.path}: line {line}, column {column!r} goes back in time ({float(t[k])!r} after "
            f"{float(t[k - 1])!r}); expected increasing times"
        )


def _dedupe(t: FloatArray, *arrays: FloatArray) -> tuple[FloatArray, ...]:
    """Drop rows that repeat the previous time stamp (a sensor sample logged twice)."""
    keep = np.ones(t.size, dtype=bool)
    keep[1:] = np.diff(t) > 0
    return (t[keep], *(a[keep] for a in arrays))


def _interp_rate(t: FloatArray, tr: FloatArray, rate: FloatArray) -> FloatArray:
    ok = np.isfinite(rate)
    tr, rate = tr[ok], rate[ok]
    return np.asarray(np.interp(t, tr, rate), dtype=np.float64)


def _offset_to_wall(
    wall: FloatArray | None, rows: NDArray[np.bool_], t: FloatArray
) -> float | None:
    """Median of loggingTime - sensor time: turns the sensor clock into POSIX seconds."""
    if wall is None:
        return None
    w = wall[rows]
    ok = np.isfinite(w)
    return float(np.median(w[ok] - t[ok])) if ok.any() else None


def _rate_series(
    tab: _Table, wall: FloatArray | None, rate_choice: tuple[str, str] | None, wall_clock: bool
) -> tuple[FloatArray, FloatArray, str, str, float | None] | None:
    """(t, rate, rate column, time column, wall offset) of the gyro, or None. With
    ``wall_clock`` its times come from loggingTime (to match a heading timed by it)."""
    if rate_choice is None:
        return None
    base, tbase = rate_choice
    if wall_clock or not tab.has(tbase):
        if wall is None:
            return None
        tbase = "(wall)"  # no header's base name has a parenthesis: use loggingTime
    rows = tab.present(base)
    if rows.sum() < 2:
        return None
    values = tab.numbers(base)[rows]
    tr, tcol = _times_for(tab, rows, tbase, wall)
    _check_increasing(tab, tr, rows, tcol)
    offset = _offset_to_wall(wall, rows, tr)
    tr, values = _dedupe(tr, values)
    return tr, values, tab.name(base), tcol, offset


def _from_yaw(
    tab: _Table, p: Path, wall: FloatArray | None, rate_choice: tuple[str, str] | None
) -> ImuLog:
    """The heading from motionYaw, unwrapped with the help of the rate."""
    rows = tab.present(_YAW[0])
    if rows.sum() < 2:
        raise ImuLogError(f"{p}: column {tab.name(_YAW[0])!r} has fewer than 2 values")
    yaw_w = tab.numbers(_YAW[0])[rows]
    t, tcol = _times_for(tab, rows, _YAW[1], wall)
    _check_increasing(tab, t, rows, tcol)
    wall_offset = _offset_to_wall(wall, rows, t)
    t, yaw_w = _dedupe(t, yaw_w)
    rs = _rate_series(tab, wall, rate_choice, wall_clock=tcol == LOGGING_TIME)
    rate = None if rs is None else _interp_rate(t, rs[0], rs[1])
    yaw = rate_aided_unwrap(t, yaw_w, rate)
    rcol = None if rs is None else rs[2]
    return ImuLog(t, yaw, rate, str(p), tab.name(_YAW[0]), rcol, tcol, wall_offset)


def _from_compass(tab: _Table, p: Path, wall: FloatArray | None, compass: str) -> ImuLog:
    """The heading from the compass column (sign flipped; negative values skipped)."""
    vals = tab.numbers(compass)
    rows = tab.present(compass) & (vals >= 0)
    if rows.sum() < 2:
        raise ImuLogError(f"{p}: column {tab.name(compass)!r} has fewer than 2 valid values")
    t, tcol = _times_for(tab, rows, _COMPASS_TIME, wall)
    _check_increasing(tab, t, rows, tcol)
    t, deg = _dedupe(t, vals[rows])
    yaw = np.unwrap(-np.radians(deg))
    # both of the compass's possible clocks are POSIX seconds
    return ImuLog(t, yaw, None, str(p), tab.name(compass), None, tcol, 0.0)


def read_sensorlog(path: str | Path) -> ImuLog:
    """Read a SensorLog CSV into an :class:`ImuLog` (heading and yaw rate on the phone clock).

    Heading, best first: ``motionYaw(rad)`` (unwrapped, helped by the rate across gaps); the
    integral of ``motionRotationRateZ(rad/s)`` or ``gyroRotationZ(rad/s)``; the compass
    ``locationTrueHeading(°)`` or ``locationMagneticHeading(°)`` with its sign flipped (negative
    compass values mean "invalid" in iOS and are skipped). Yaw rate: ``motionRotationRateZ`` or
    ``gyroRotationZ``, interpolated onto the heading's times. Time: the sensor's
    ``..._sinceReboot(s)`` clock, else ``loggingTime(txt)`` with its time-zone offset.
    Every problem is an :class:`ImuLogError` naming the file (and line and column).

    Raises:
        ImuLogError: the file has no usable heading column, or too few values in it.
    """
    p = Path(path)
    tab = _Table(p)
    wall = tab.posix_times() if tab.has("loggingTime") else None

    rate_choice = next((r for r in _RATES if tab.has(r[0])), None)
    compass = next((c for c in _COMPASS if tab.has(c)), None)
    have_time = wall is not None or any(
        tab.has(b) for b in (_YAW[1], *(r[1] for r in _RATES), _COMPASS_TIME)
    )
    if not have_time or not (tab.has(_YAW[0]) or rate_choice or compass):
        raise ImuLogError(
            f"{p}: missing columns; expected a heading (motionYaw(rad), "
            f"motionRotationRateZ(rad/s), gyroRotationZ(rad/s) or locationTrueHeading(°)) and "
            f"a time ({LOGGING_TIME} or "
            f"..._sinceReboot(s)), but the header has: {', '.join(tab.header)}"
        )
    if tab.has(_YAW[0]) and (tab.has(_YAW[1]) or wall is not None):
        return _from_yaw(tab, p, wall, rate_choice)

    rs = _rate_series(tab, wall, rate_choice, wall_clock=False)
    if rs is not None:
        tr, rate, rcol, tcol, wall_offset = rs
        yaw = np.concatenate(([0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(tr))))
        return ImuLog(tr, yaw, rate, str(p), f"integral of {rcol}", rcol, tcol, wall_offset)

    if compass is not None:
        return _from_compass(tab, p, wall, compass)

    raise ImuLogError(  # pragma: no cover - the column check above makes this unreachable
        f"{p}: no usable heading column; the header has: {', '.join(tab.header)}"
    )


# --------------------------------------------------------------------------------------------
# writing


def _wall_text(start: datetime, seconds: FloatArray) -> list[str]:
    """``2013-10-03 14:05:11.532 -0700`` for ``start + seconds`` (in ``start``'s time zone)."""
    out = []
    for s in seconds:
        d = start + timedelta(seconds=float(s))
        out.append(
            d.strftime("%Y-%m-%d %H:%M:%S.") + f"{d.microsecond // 1000:03d} " + d.strftime("%z")
        )
    return out


#: The columns :func:`write_sensorlog` writes, in order.
WRITTEN_COLUMNS: tuple[str, ...] = (
    "loggingTime(txt)",
    "loggingSample(N)",
    "identifierForVendor(txt)",
    "locationHeadingTimestamp_since1970(s)",
    "locationHeadingX(µT)",
    "locationHeadingY(µT)",
    "locationHeadingZ(µT)",
    "locationTrueHeading(°)",
    "locationMagneticHeading(°)",
    "locationHeadingAccuracy(°)",
    "accelerometerTimestamp_sinceReboot(s)",
    "accelerometerAccelerationX(G)",
    "accelerometerAccelerationY(G)",
    "accelerometerAccelerationZ(G)",
    "gyroTimestamp_sinceReboot(s)",
    "gyroRotationX(rad/s)",
    "gyroRotationY(rad/s)",
    "gyroRotationZ(rad/s)",
    "motionTimestamp_sinceReboot(s)",
    "motionYaw(rad)",
    "motionRoll(rad)",
    "motionPitch(rad)",
    "motionRotationRateX(rad/s)",
    "motionRotationRateY(rad/s)",
    "motionRotationRateZ(rad/s)",
    "motionAttitudeReferenceFrame(txt)",
)


# long: 27 of its lines are the signature and the documented keywords of the phone log; the body
# writes one row kind after another
def write_sensorlog(
    path: str | Path,
    t_phone: ArrayLike,
    yaw: ArrayLike,
    yaw_rate: ArrayLike,
    *,
    start_wallclock: datetime = DEFAULT_START,
    north: float = 0.0,
    compass_every: int = 10,
    accelerometer_every: int = 2,
    logging_delay: float = 0.004,
    device: str = "odolab-virtual-phone",
) -> Path:
    """Write a SensorLog-style CSV of a phone lying face up on a robot; return the path.

    ``t_phone`` (s, shape (n,), increasing): the phone's ``..._sinceReboot(s)`` clock;
    ``yaw`` (rad, unwrapped or not; written wrapped to [-pi, pi) as SensorLog does) and
    ``yaw_rate`` (rad/s), shape (n,). ``start_wallclock`` (time-zone aware) is the
    ``loggingTime(txt)`` of the first row, later rows follow ``t_phone`` plus a small
    ``logging_delay`` (s). ``north`` (rad) is the yaw that points to true north; the compass
    (degrees clockwise from north) is written on every ``compass_every``-th row and left empty
    elsewhere, the accelerometer on every ``accelerometer_every``-th row. Columns are
    :data:`WRITTEN_COLUMNS`.

    Raises:
        ImuLogError: the start time carries no time zone.
    """
    t = np.asarray(t_phone, dtype=np.float64)
    y = np.asarray(yaw, dtype=np.float64)
    r = np.asarray(yaw_rate, dtype=np.float64)
    check_imu_log(t, y, r, f"{path}")
    if start_wallclock.tzinfo is None:
        raise ImuLogError("start_wallclock must carry a time zone, e.g. datetime(..., tzinfo=UTC)")
    n = t.size
    wrapped = wrap_angle(y)
    compass = np.degrees(north - y) % 360.0
    stamps = _wall_text(start_wallclock, t - t[0] + logging_delay)
    boot_posix = start_wallclock.timestamp() - t[0]

    def f(v: float, digits: int = 6) -> str:
        return f"{v:.{digits}f}"

    from odolab.core.writing import replacing_file

    p = Path(path)
    with replacing_file(p, what="SensorLog", error=ImuLogError, newline="") as fh:
        w = csv.writer(fh)
        w.writerow(WRITTEN_COLUMNS)
        for i in range(n):
            has_compass = compass_every > 0 and i % compass_every == 0
            has_acc = accelerometer_every > 0 and i % accelerometer_every == 0
            row: Sequence[str] = (
                stamps[i],
                str(i),
                device,
                f(boot_posix + t[i], 3) if has_compass else "",
                "12.000000" if has_compass else "",
                "-3.000000" if has_compass else "",
                "-40.000000" if has_compass else "",
                f(compass[i], 3) if has_compass else "",
                f((compass[i] + 12.5) % 360.0, 3) if has_compass else "",
                "10.000000" if has_compass else "",
                f(t[i]) if has_acc else "",
                "0.000000" if has_acc else "",
                "0.000000" if has_acc else "",
                "-1.000000" if has_acc else "",
                f(t[i]),
                "0.000000",
                "0.000000",
                f(r[i]),
                f(t[i]),
                f(wrapped[i], 9),
                "0.000000",
                "0.000000",
                "0.000000",
                "0.000000",
                f(r[i]),
                "XArbitraryZVertical",
            )
            w.writerow(row)
    return p
