"""Odometry of logs larger than memory: read, integrate and write chunk by chunk.

Built on the public :func:`odolab.core.odometry.integrate`: each chunk is integrated with the previous
chunk's last counter sample prepended (so a rollover across the boundary is unwrapped as in one
pass) and starting from the previous chunk's last pose (x, y and the unwrapped heading), then
that repeated first pose is dropped. The poses equal the whole-file run's to rounding (the same
operations in the same order). Memory is bounded by the chunk size.

With ``covariance=True`` the pose covariance (:data:`odolab.core.uncertainty.COV_COLUMNS`, from the
parameters' ``[noise]`` table) is propagated the same way: each chunk starts from the previous
chunk's last covariance and heading, so the chunked covariance equals the whole-file one.

Errors name the file and line (CSV) or row (Parquet, IPC), as the whole-file reader does; the
line numbers of a CSV are counted only when there is an error to report.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from odolab.core.arrays import FloatArray as F64
from odolab.core.arrays import IntArray as I64
from odolab.core.defaults import DEFAULT_CHUNK_ROWS
from odolab.core.errors import EncoderJumpError, LogFormatError
from odolab.core.kinematics import Method
from odolab.core.params import RobotParams
from odolab.core.progress import Progress
from odolab.core.trajectory import Pose, Trajectory, check_advanced, check_times
from odolab.core.writing import replacing_path
from odolab.io._table import as_float64, data_line_numbers
from odolab.io.encoder_csv import (
    INCREMENTS,
    RAW,
    _ticks,
    check_counter_range,
    check_encoder_header,
)
from odolab.io.tabular import (
    BINARY_SUFFIXES,
    ChunkWriter,
    iter_columns,
    prefetched,
    read_header,
    row_count,
    table_format,
)

__all__ = [
    "DEFAULT_CHUNK_ROWS",
    "ChunkedOdometry",
    "EncoderChunk",
    "OdometryChunk",
    "OdometryFileResult",
    "OdometryJob",
    "integrate_file",
    "iter_encoder_chunks",
    "iter_trajectory_chunks",
    "run_odometry_job",
]

TRAJECTORY_COLUMNS = ("t", "x", "y", "theta", "heading")


@dataclass(frozen=True)
class EncoderChunk:
    """Rows ``row0 .. row0 + len - 1`` (0-based data rows) of an encoder log."""

    row0: int
    t: F64
    left: I64
    right: I64


class _Lines:
    """Data row index -> physical line (CSV, counted on first use) or row number from 1."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.text = table_format(path) == "csv"
        self.where = "line" if self.text else "row"
        self._lines: I64 | None = None

    def __call__(self, row: int) -> int:
        if not self.text:
            return row + 1
        if self._lines is None:
            self._lines = data_line_numbers(self.path)
        return int(self._lines[row])


def iter_encoder_chunks(
    path: str | Path, *, modulus: int | None = None, chunk_rows: int = DEFAULT_CHUNK_ROWS
) -> Iterator[EncoderChunk]:
    """An encoder log (raw counters or increments; CSV, Parquet or IPC) chunk by chunk.

    The same checks as :func:`odolab.io.read_encoder_csv`, with the same messages: times finite
    and non-decreasing (across chunks too), counts whole, raw counters within the modulus.
    Increments are summed into counters that carry across chunks.

    Raises:
        LogFormatError: the log is unreadable, has no samples, or a time or counter value is wrong
            (the line is named).
    """
    p = Path(path)
    text = table_format(p) == "csv" and p.is_file()
    if text:  # once, with this reader's words (iter_columns is told it is done)
        from odolab.io.limits import check_columns_unique, check_text_file, first_line_cells

        check_text_file(p, expected="an encoder log CSV")
        cells = first_line_cells(p)
        check_encoder_header(p, cells)
        check_columns_unique(p, cells)
    header = read_header(p)
    increments = "dticks_left" in header and "left_ticks" not in header
    cols = INCREMENTS if increments else RAW
    lines = _Lines(p)
    last_t: float | None = None
    first_t: float | None = None
    rows = 0
    carry = np.zeros(2, dtype=np.int64)
    any_rows = False
    for row0, data in iter_columns(p, cols, chunk_rows=chunk_rows, integer=cols[1:], checked=text):
        t = np.asarray(data["t"], dtype=np.float64)  # (float64 already: not in ``integer``)
        if t.size == 0:
            continue
        any_rows = True

        def line_of(i: int, row0: int = row0) -> int:
            return lines(row0 + i)

        _check_times_from(t, last_t, str(p), row0, lines)
        first_t = float(t[0]) if first_t is None else first_t
        last_t = float(t[-1])
        rows = row0 + t.size

        left = _ticks(p, data[cols[1]], cols[1], line_of, lines.where)
        right = _ticks(p, data[cols[2]], cols[2], line_of, lines.where)
        if increments:
            if row0 == 0:  # the first increment is not motion
                left, right = left.copy(), right.copy()  # (the reader's may be read-only)
                left[0] = right[0] = 0
            left = np.cumsum(left) + carry[0]
            right = np.cumsum(right) + carry[1]
            carry[:] = (left[-1], right[-1])
        elif modulus is not None:
            check_counter_range(p, cols, left, right, modulus, line_of, lines.where)
        yield EncoderChunk(row0, t, left, right)
    if not any_rows:
        raise LogFormatError(f"{p}: no samples after the header")
    _check_advanced(first_t, last_t, rows, str(p), lines)


def _check_times_from(t: F64, last_t: float | None, source: str, row0: int, lines: _Lines) -> None:
    """Times of one chunk finite and non-decreasing, also after the previous chunk's last."""

    def line_of(i: int) -> int:
        return lines(row0 + i)

    def line_before(i: int) -> int:
        return lines(row0 + i - 1)

    if last_t is None:
        check_times(t, source, line_of=line_of, what=lines.where, advancing=False)
    else:
        check_times(
            np.concatenate(([last_t], t)),
            source,
            line_of=line_before,
            what=lines.where,
            advancing=False,
        )


def _check_advanced(
    first_t: float | None, last_t: float | None, rows: int, source: str, lines: _Lines
) -> None:
    """At the end of a chunked read: the whole file's time advanced, as the whole reader asks
    (the line numbers are looked up only for the message: finding them reads the file)."""
    if first_t is not None and last_t is not None and rows > 1 and last_t == first_t:
        check_advanced(first_t, last_t, rows, source, lines(0), lines(rows - 1), lines.where)


def iter_trajectory_chunks(
    path: str | Path, *, chunk_rows: int = DEFAULT_CHUNK_ROWS
) -> Iterator[Trajectory]:
    """A trajectory file chunk by chunk: the same poses as :func:`odolab.io.read_trajectory`.

    CSV, Parquet and Arrow IPC (``t,x,y,theta[,heading]`` or ``t,x,y,heading``) are read
    ``chunk_rows`` rows at a time; a heading derived from ``theta`` is unwrapped across the
    chunks (continuing from the previous chunk's last heading). TUM text has no chunked reader:
    it comes as one chunk. The same checks and messages as the whole-file reader.

    Raises:
        LogFormatError: the file is missing, empty, or has a bad time or position (the line is
            named).
    """
    from odolab.core.kinematics import wrap_angle
    from odolab.io.limits import check_columns_unique, check_text_file, first_line_cells
    from odolab.io.trajectory_csv import read_trajectory_csv, read_tum, trajectory_columns

    p = Path(path)
    if not p.is_file():
        raise LogFormatError(f"{p}: no such trajectory file")
    if p.suffix.lower() not in (".csv", *BINARY_SUFFIXES):
        yield read_tum(p)
        return
    text = table_format(p) == "csv"
    if text:
        check_text_file(p, expected="a trajectory CSV")
        header = first_line_cells(p)
        if not header:
            raise LogFormatError(f"{p}: empty file; expected header t,x,y,theta,heading")
        check_columns_unique(p, header)
    else:
        header = read_header(p)
    cols = trajectory_columns(header)
    if "theta" not in cols and "heading" not in cols:  # t,x,y: the heading is the whole path's
        yield read_trajectory_csv(p)  # tangent (odolab.io.trajectory_csv.heading_from_path)
        return
    lines = _Lines(p)
    last: tuple[float, float, float] | None = None  # t, theta read, heading of the last row
    first_t: float | None = None
    rows = 0
    for row0, read in iter_columns(p, cols, chunk_rows=chunk_rows, checked=text):
        d = as_float64(read)
        t = d["t"]
        if t.size == 0:
            continue
        _check_times_from(t, None if last is None else last[0], str(p), row0, lines)
        first_t = float(t[0]) if first_t is None else first_t
        rows = row0 + t.size
        if "heading" in d:
            traj = Trajectory.from_xyh(t, d["x"], d["y"], d["heading"])
            last = (float(t[-1]), 0.0, float(traj.heading[-1]))
        else:
            th = d["theta"]
            if last is None:
                heading = np.unwrap(th)
            else:  # unwrapped after the last row, then moved onto its heading
                heading = np.unwrap(np.concatenate(([last[1]], th)))[1:] + (last[2] - last[1])
            traj = Trajectory(t, d["x"], d["y"], wrap_angle(th), heading)
            last = (float(t[-1]), float(th[-1]), float(heading[-1]))
        yield traj
    _check_advanced(first_t, None if last is None else last[0], rows, str(p), lines)


_SAMPLES = re.compile(r"between samples (\d+) and (\d+)")


@dataclass(frozen=True)
class OdometryChunk:
    """One chunk's poses and, when asked for, their covariance (n, 6) in ``COV_COLUMNS``."""

    trajectory: Trajectory
    covariance: F64 | None

    def columns(self) -> dict[str, NDArray[np.float64]]:
        """The output table's columns: ``t,x,y,theta,heading`` (then ``cov_xx .. cov_hh``)."""
        tr = self.trajectory
        out = dict(zip(TRAJECTORY_COLUMNS, (tr.t, tr.x, tr.y, tr.theta, tr.heading), strict=True))
        if self.covariance is not None:
            from odolab.core.uncertainty import COV_COLUMNS

            out.update(zip(COV_COLUMNS, self.covariance.T, strict=True))
        return out


class ChunkedOdometry:
    """Batch odometry fed chunk by chunk; ``feed`` returns each chunk's poses.

    Equal to one :func:`odolab.core.odometry.integrate` call over the concatenated chunks (to
    rounding), rollover across a boundary included. With ``covariance=True``, :meth:`step` also
    returns the covariance, equal to one :func:`odolab.core.uncertainty.covariance_from_ticks` call
    (a :class:`odolab.core.errors.ParamsError` up front when ``params`` have no ``[noise]`` table).
    """

    def __init__(
        self,
        params: RobotParams,
        method: Method | str = Method.MIDPOINT,
        *,
        start: tuple[float, float, float] | None = None,
        max_dticks: int | None = None,
        source: str = "encoder log",
        covariance: bool = False,
    ) -> None:
        if covariance and params.noise is None:
            from odolab.core.errors import ParamsError

            raise ParamsError(
                f"the parameters {params.name} have no [noise] table, which a covariance needs "
                "(k_left, k_right in m): write one with `odolab calibrate noise RUNS -o P.toml` "
                "or add it by hand"
            )
        self.params = params
        self.covariance = covariance
        self._cov: F64 | None = None
        self.method = Method(method)
        self.start = start
        self.max_dticks = max_dticks
        self.source = source
        self.rows = 0
        self._prev: tuple[float, int, int] | None = None
        self._pose: Pose | None = None

    @property
    def pose(self) -> Pose | None:
        """The last pose so far (None before the first sample)."""
        return self._pose

    def feed(self, t: F64, left: I64, right: I64) -> Trajectory:
        """Integrate the next rows; returns their poses (one per row)."""
        return self.step(t, left, right).trajectory

    def step(self, t: F64, left: I64, right: I64) -> OdometryChunk:
        """Integrate the next rows; their poses and (``covariance=True``) covariance."""
        from odolab.core.odometry import integrate, integrate_with_covariance

        n = len(t)
        if self._prev is None or self._pose is None:
            tt, ll, rr, start, skip = t, left, right, self.start, 0
        else:
            pt, pl, pr = self._prev
            tt = np.concatenate(([pt], np.asarray(t, dtype=np.float64)))
            ll = np.concatenate(([pl], np.asarray(left, dtype=np.int64)))
            rr = np.concatenate(([pr], np.asarray(right, dtype=np.int64)))
            start = (self._pose.x, self._pose.y, self._pose.heading)
            skip = 1
        offset = self.rows - skip  # global index of tt[0]
        cov = None
        try:
            if self.covariance:
                traj, cov = integrate_with_covariance(
                    tt, ll, rr, self.params, self.method, start=start, cov0=self._cov,
                    max_dticks=self.max_dticks, source=self.source,
                )  # fmt: skip
            else:
                traj = integrate(
                    tt, ll, rr, self.params, self.method, start=start,
                    max_dticks=self.max_dticks, source=self.source,
                )  # fmt: skip
        except EncoderJumpError as err:
            text = _SAMPLES.sub(
                lambda m: (
                    f"between samples {int(m.group(1)) + offset} and {int(m.group(2)) + offset}"
                ),
                str(err),
            )
            raise EncoderJumpError(text) from err
        if cov is not None:
            cov = cov[skip:]
            if len(cov):
                self._cov = cov[-1].copy()
        if skip:
            traj = traj[skip:]
        if n:
            self._prev = (float(t[-1]), int(left[-1]), int(right[-1]))
            self._pose = traj.final
        self.rows += n
        return OdometryChunk(traj, cov)


@dataclass(frozen=True)
class OdometryFileResult:
    """What :func:`integrate_file` did: poses written, the final pose, chunks."""

    rows: int
    final: Pose
    chunks: int
    output: Path


def integrate_file(
    log: str | Path,
    output: str | Path,
    params: RobotParams,
    method: Method | str = Method.MIDPOINT,
    *,
    start: tuple[float, float, float] | None = None,
    max_dticks: int | None = None,
    chunk_rows: int = DEFAULT_CHUNK_ROWS,
    progress: Progress | None = None,
    covariance: bool = False,
) -> OdometryFileResult:
    """Encoder log file -> trajectory file (``t,x,y,theta,heading``, then with ``covariance``
    the six ``cov_xx .. cov_hh`` of :data:`odolab.core.uncertainty.COV_COLUMNS`), chunk by chunk.

    Formats by extension (CSV, Parquet, Arrow IPC). ``progress(rows done, total rows or 0 when
    unknown, name)`` is called after each chunk. The output is written beside under a temporary
    name and renamed when complete: after an error, an existing ``output`` is left as it was.

    Raises:
        LogFormatError: the output is the input log or a folder, or the log cannot be read.
    """
    src = Path(log)
    out = Path(output)
    if src.exists() and out.exists() and src.resolve() == out.resolve():
        raise LogFormatError(f"{out}: is the input log; expected another file for the output")
    if out.is_dir():
        raise LogFormatError(
            f"{out}: cannot write the trajectory (it is a folder); expected a file name in a "
            "writable folder"
        )
    total = row_count(src) or 0
    from odolab.core.odometry import NUMPY_MAX_SAMPLES, warm_up

    # the kernels load while the first chunk is read, where a chunk (with the previous chunk's
    # last sample) may be long enough for them: a shorter one is integrated in numpy
    most = total if total else _csv_rows_at_most(src)
    if covariance or min(chunk_rows + 1, most) >= NUMPY_MAX_SAMPLES:
        warm_up(params, method, covariance=covariance)
    odo = ChunkedOdometry(
        params,
        method,
        start=start,
        max_dticks=max_dticks,
        source=str(src),
        covariance=covariance,
    )
    chunks = 0
    # a temporary file beside ``out``, renamed over it when whole (odolab.core.writing)
    with (
        replacing_path(out, what="trajectory", error=LogFormatError) as partial,
        ChunkWriter(partial, "trajectory", shown=out) as writer,
    ):
        chunks_in = iter_encoder_chunks(src, modulus=params.encoder_modulus, chunk_rows=chunk_rows)
        for chunk in prefetched(chunks_in):  # the next chunk is read meanwhile
            writer.write(odo.step(chunk.t, chunk.left, chunk.right).columns())
            chunks += 1
            if progress is not None:
                progress(odo.rows, total, src.name)
    assert odo.pose is not None  # iter_encoder_chunks raised on an empty log
    return OdometryFileResult(odo.rows, odo.pose, chunks, out)


def _csv_rows_at_most(path: Path) -> int:
    """The most rows a CSV file may hold (each takes 6 bytes or more: ``0,0,0`` and a line end)."""
    try:
        return path.stat().st_size // 6
    except OSError:  # the reader reports it
        return 1 << 62


@dataclass(frozen=True)
class OdometryJob:
    """One log to integrate into one trajectory file (sent to a Dask worker)."""

    log: Path
    output: Path
    params: RobotParams
    method: str = "midpoint"
    start: tuple[float, float, float] | None = None
    max_dticks: int | None = None
    chunk_rows: int = DEFAULT_CHUNK_ROWS
    covariance: bool = False


def run_odometry_job(job: OdometryJob) -> OdometryFileResult:
    """:func:`integrate_file` for one job."""
    return integrate_file(
        job.log,
        job.output,
        job.params,
        job.method,
        start=job.start,
        max_dticks=job.max_dticks,
        chunk_rows=job.chunk_rows,
        covariance=job.covariance,
    )
