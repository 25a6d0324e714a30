"""Numeric tables in and out at library speed: CSV, Parquet and Arrow IPC, chosen by extension.

``.parquet``/``.pq`` is Parquet, ``.arrow``/``.feather``/``.ipc`` is Arrow IPC (Feather v2),
anything else is CSV. A CSV is read as blocks of lines that polars parses on every core;
Parquet and IPC as pyarrow's record batches; whole files are copied block by block into arrays
allocated once, so memory is what is kept plus a block (see docs/scale.md). polars writes CSV;
pyarrow's writers write Parquet and IPC tables of numbers (whole or in chunks, on a writer
thread: :class:`ChunkWriter`), polars other tables.

CSV numbers are written as the shortest text that reads back to the same double (``0.05`` stays
``0.05``). The fast CSV reader names no line: when it refuses a block (an empty cell, a word, a
line of another width), the careful reader in :mod:`odolab.io._table` reads the file again, so
every error still names the file, line and column. Parquet and IPC files have no lines: their errors
name the row (from 1) and column.
"""

from __future__ import annotations

import contextlib
import queue
import threading
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import IO, TYPE_CHECKING, Literal, TypeVar, cast

import numpy as np
from numpy.typing import NDArray

from odolab.core.errors import LogFormatError
from odolab.io._table import Column, Columns, _CsvRefused, _parse_block, check_columns_present

__all__ = [
    "BINARY_SUFFIXES",
    "ChunkWriter",
    "TableFormat",
    "is_csv_with",
    "iter_columns",
    "read_columns",
    "read_header",
    "table_format",
    "write_columns",
    "write_frame",
]

TableFormat = Literal["csv", "parquet", "ipc"]

if TYPE_CHECKING:
    import polars as pl
    import pyarrow as pa
    import pyarrow.ipc as ipc
    import pyarrow.parquet as pq
T = TypeVar("T")

_PARQUET = (".parquet", ".pq")
_IPC = (".arrow", ".feather", ".ipc")
#: Suffixes of the binary table formats (everything else is CSV text).
BINARY_SUFFIXES = _PARQUET + _IPC


def table_format(path: str | Path) -> TableFormat:
    """The table format of a file name, by its extension (CSV unless Parquet or Arrow IPC)."""
    suffix = Path(path).suffix.lower()
    if suffix in _PARQUET:
        return "parquet"
    if suffix in _IPC:
        return "ipc"
    return "csv"


def _check_file(p: Path) -> None:
    if not p.exists():
        raise LogFormatError(f"{p}: no such file")
    if not p.is_file():
        raise LogFormatError(f"{p}: is not a file (a folder?); expected a table file")


def _arrow_errors() -> tuple[type[BaseException], ...]:
    """What pyarrow raises for a damaged Parquet or IPC file: its own errors, and Python's from
    the metadata it decodes (a column name that is not UTF-8: UnicodeDecodeError, a ValueError)."""
    import pyarrow as pa

    return (pa.ArrowException, OSError, ValueError, KeyError, IndexError, TypeError, MemoryError)


def _numpy_of(col: pa.Array) -> NDArray[np.generic]:
    """A pyarrow array without nulls as numpy: a view of its data buffer for the usual integer
    and float types. (pyarrow's ``to_numpy`` and ``np.asarray`` import pandas, half a second
    of a command that reads Parquet.) Other types go through ``to_numpy``."""
    import pyarrow as pa

    typ = col.type
    if (pa.types.is_integer(typ) or pa.types.is_floating(typ)) and not pa.types.is_float16(typ):
        kind = "f" if pa.types.is_floating(typ) else "i" if pa.types.is_signed_integer(typ) else "u"
        dtype = np.dtype(f"{kind}{typ.bit_width // 8}")
        data = col.buffers()[1]
        if data is not None and data.size >= (col.offset + len(col)) * dtype.itemsize:
            return np.frombuffer(data, dtype=dtype, count=col.offset + len(col))[col.offset :]
    return np.asarray(col.to_numpy(zero_copy_only=False))


def _arrow_schema_names(p: Path, fmt: TableFormat) -> list[str]:
    import pyarrow as pa
    import pyarrow.ipc as ipc
    import pyarrow.parquet as pq

    try:
        if fmt == "parquet":
            return list(pq.read_schema(p).names)
        with pa.memory_map(str(p)) as source:
            return list(ipc.open_file(source).schema.names)
    except _arrow_errors() as err:
        kind = "Parquet" if fmt == "parquet" else "Arrow IPC"
        raise LogFormatError(f"{p}: not a readable {kind} file ({err})") from err


def is_csv_with(path: str | Path, columns: Sequence[str]) -> bool:
    """Whether ``path`` is a readable CSV file whose header names every one of ``columns``."""
    p = Path(path)
    if p.suffix.lower() != ".csv" or not p.is_file():
        return False
    try:
        header = read_header(p)
    except LogFormatError:
        return False
    return all(c in header for c in columns)


def read_header(path: str | Path) -> list[str]:
    """Column names of a table file (CSV: the first line, stripped).

    Raises:
        LogFormatError: the file is missing, unreadable, or has no header line.
    """
    p = Path(path)
    _check_file(p)
    fmt = table_format(p)
    if fmt != "csv":
        return _arrow_schema_names(p, fmt)
    from odolab.io.limits import first_line_cells

    try:
        header = first_line_cells(p)
    except OSError as err:
        raise LogFormatError(f"{p}: cannot read ({err.strerror or err})") from err
    if not header:
        raise LogFormatError(f"{p}: empty or unreadable file; expected a header line")
    return header


def _checked_header(
    p: Path, columns: Sequence[str], checked: bool
) -> tuple[TableFormat, list[str]]:
    """The file's format and header, after the checks every reader makes: a CSV's lines
    (unless ``checked``) and that the header names every one of ``columns``."""
    fmt = table_format(p)
    if fmt == "csv" and not checked:
        _check_file(p)
        _check_text(p)
    header = read_header(p)
    check_columns_present(p, header, columns)
    return fmt, header


def _check_text(p: Path) -> None:
    """The input limits of every text reader (:mod:`odolab.io.limits`), in one streaming pass."""
    from odolab.io.limits import check_columns_unique, check_text_file, first_line_cells

    check_text_file(p, expected="a delimited text file")
    check_columns_unique(p, first_line_cells(p))


def _check_finite(p: Path, out: Mapping[str, Column], where: str, offset: int = 0) -> None:
    for name, arr in out.items():
        bad = ~np.isfinite(arr)
        if bad.any():
            i = int(np.argmax(bad))
            raise LogFormatError(
                f"{p}: {where} {i + 1 + offset}, column {name!r} is {arr[i]}, expected a number"
            )


def prefetched(items: Iterable[T], depth: int = 1) -> Iterator[T]:
    """``items``, with the next ``depth`` of them read ahead on a background thread.

    For a reader that releases Python's lock while it parses (pyarrow, polars): the next chunk
    is read while this one is integrated and written. Memory: ``depth`` more items. An error of
    the reader is raised here, at the item where it happened; leaving the loop early stops the
    reader after the item it is reading."""
    slots: queue.Queue[tuple[bool, object]] = queue.Queue(maxsize=depth)
    stop = threading.Event()

    def read() -> None:
        try:
            for item in items:
                if stop.is_set():
                    return
                slots.put((True, item))
            slots.put((False, None))
        except BaseException as err:  # handed to the consumer, raised there
            slots.put((False, err))

    reader = threading.Thread(target=read, name="odolab-read-ahead", daemon=True)
    reader.start()
    try:
        while True:
            more, item = slots.get()
            if not more:
                if isinstance(item, BaseException):
                    raise item
                return
            yield cast(T, item)
    finally:
        stop.set()
        while reader.is_alive():  # unblock a reader waiting for a free slot
            with contextlib.suppress(queue.Empty):
                slots.get(timeout=0.05)
        reader.join()


def _fast_csv(
    p: Path, header: list[str], columns: Sequence[str], integer: Sequence[str]
) -> Columns | None:
    """polars on blocks of lines (:func:`_parse_block`, the next one parsed on a thread), copied
    into arrays allocated once; None where the careful reader must look.

    The arrays are sized from the file's size and the first block's bytes a row, with a quarter
    to spare (pages never written are never resident), and grow only if the estimate was short.
    So the peak is the columns read plus two blocks, whatever polars' allocator keeps; joining
    pieces at the end measured 1.6-2.2x the output arrays from run to run."""
    if len(set(header)) != len(header):
        return None  # duplicated names: the careful reader's rules apply
    size = p.stat().st_size
    out: Columns = {c: np.empty(0, np.int64) if c in integer else np.empty(0) for c in columns}
    n = 0
    try:
        for nbytes, part in prefetched(_parsed_blocks(p, header, columns, integer, _CSV_BLOCK)):
            k = len(part[columns[0]])
            if n + k > len(out[columns[0]]):  # the first block, or an estimate too short
                need = (n + k) * 2 if n else int(size / max(nbytes, 1) * k * 1.25) + k
                out = {c: _grown(a, n, need, part[c].dtype) for c, a in out.items()}
            for c in columns:
                if part[c].dtype != out[c].dtype and out[c].dtype.kind == "i":
                    out[c] = out[c].astype(np.float64)  # a block wrote "7.0": floats from here
                out[c][n : n + k] = part[c]
            n += k
    except _CsvRefused:
        return None
    return {c: a[:n] for c, a in out.items()}


def _grown(a: Column, n: int, size: int, dtype: np.dtype[np.generic]) -> Column:
    """A new array of ``size`` holding ``a[:n]`` (float64 if either is)."""
    kind = np.result_type(a.dtype, dtype)
    b = np.empty(size, kind)
    b[:n] = a[:n]
    return b


def _whole_binary(
    p: Path, fmt: TableFormat, columns: Sequence[str], integer: Sequence[str], allow_nan: bool
) -> Columns:
    """A whole Parquet or IPC table's columns (int64 where asked and stored as integers).

    Read batch by batch (:func:`_arrow_batches`) into arrays allocated once from the row count
    in the file's metadata: the peak is the columns read plus one batch, whatever the Arrow
    allocator keeps (polars' whole-file reader left its buffers beside the output: 2.3x)."""
    import pyarrow as pa

    kind = "Parquet" if fmt == "parquet" else "Arrow IPC"
    try:
        with contextlib.ExitStack() as stack:
            rows, schema, batches = _arrow_batches(p, fmt, columns, stack)
            out: Columns = {}
            for name in columns:
                typ = schema.field(name).type
                if not (pa.types.is_integer(typ) or pa.types.is_floating(typ)
                        or pa.types.is_decimal(typ)):  # fmt: skip
                    raise LogFormatError(f"{p}: column {name!r} holds {typ}, expected numbers")
                whole = name in integer and pa.types.is_integer(typ)
                out[name] = np.empty(rows, np.int64) if whole else np.empty(rows)
            row = 0
            for batch in batches:
                k = batch.num_rows
                for name in columns:
                    col = batch.column(batch.schema.get_field_index(name))
                    if col.null_count:
                        i = row + int(np.argmax(np.asarray(col.is_null())))
                        raise LogFormatError(
                            f"{p}: row {i + 1}, column {name!r} is empty, expected a number"
                        )
                    out[name][row : row + k] = _numpy_of(col)
                row += k
    except _arrow_errors() as err:
        raise LogFormatError(f"{p}: not a readable {kind} file ({err})") from err
    if row != rows:  # pragma: no cover - metadata and data disagree
        raise LogFormatError(f"{p}: {row} rows where the metadata says {rows}; a damaged file?")
    if not allow_nan:
        _check_finite(p, {k: v for k, v in out.items() if v.dtype.kind == "f"}, "row")
    return out


def _arrow_batches(
    p: Path, fmt: TableFormat, columns: Sequence[str], stack: contextlib.ExitStack
) -> tuple[int, pa.Schema, Iterator[pa.RecordBatch]]:
    """Rows (from the metadata), schema and record batches of the named columns of a Parquet or
    IPC file (IPC memory-mapped; the map stays open until ``stack`` closes)."""
    import pyarrow as pa
    import pyarrow.ipc as ipc
    import pyarrow.parquet as pq

    if fmt == "parquet":
        pf = pq.ParquetFile(p, pre_buffer=False)  # (pre-buffered: the whole file stays)
        batches = pf.iter_batches(batch_size=1 << 16, columns=list(columns))
        return int(pf.metadata.num_rows), pf.schema_arrow, batches
    reader = ipc.open_file(stack.enter_context(pa.memory_map(str(p))))
    rows = sum(reader.get_batch(k).num_rows for k in range(reader.num_record_batches))
    batches = (reader.get_batch(k).select(list(columns)) for k in range(reader.num_record_batches))
    return rows, reader.schema, batches


def read_columns(
    path: str | Path,
    columns: Sequence[str],
    *,
    allow_nan: bool = False,
    integer: Sequence[str] = (),
    checked: bool = False,
) -> Columns:
    """Read the named columns of a table file as float64 arrays.

    Columns named in ``integer`` come back as int64 where every value is written as an integer
    (faster, exact); otherwise, as the others, float64. Every error is a
    :class:`LogFormatError` naming the file and, where there is one, the line (CSV) or row
    (Parquet, IPC) and column. A CSV's lines are checked first (:mod:`odolab.io.limits`;
    ``checked``: the caller already did).
    """
    p = Path(path)
    fmt, header = _checked_header(p, columns, checked)
    if fmt != "csv":
        return _whole_binary(p, fmt, columns, integer, allow_nan)
    from odolab.io._table import read_numeric_columns

    fast = _fast_csv(p, header, columns, integer)
    if fast is None:
        return dict(read_numeric_columns(p, columns, allow_nan=allow_nan, checked=True))
    floats = [a for a in fast.values() if a.dtype.kind == "f"]
    if not allow_nan and not all(bool(np.isfinite(a).all()) for a in floats):
        return dict(read_numeric_columns(p, columns, allow_nan=allow_nan, checked=True))
    return fast


def _arrow_to_f64(p: Path, batch: pa.RecordBatch, columns: Sequence[str], row0: int) -> Columns:
    import pyarrow as pa

    out: Columns = {}
    for name in columns:
        col = batch.column(batch.schema.get_field_index(name))
        if col.null_count:
            i = int(np.argmax(np.asarray(col.is_null())))
            raise LogFormatError(
                f"{p}: row {row0 + i + 1}, column {name!r} is empty, expected a number"
            )
        try:
            arr = _numpy_of(col)
        except pa.ArrowException as err:  # pragma: no cover - exotic types
            raise LogFormatError(f"{p}: column {name!r} is not numeric ({err})") from err
        if arr.dtype.kind not in "iuf":
            raise LogFormatError(f"{p}: column {name!r} holds {col.type}, expected numbers")
        out[name] = arr.astype(np.float64, copy=False)
    return out


def _rechunk(
    blocks: Iterator[Columns], columns: Sequence[str], chunk_rows: int | None
) -> Iterator[Columns]:
    """Blocks of any size as chunks of exactly ``chunk_rows`` rows (the last one shorter).

    Each row is copied at most once (a chunk made of pieces of several blocks); a chunk inside
    one block is a view of it.
    """
    if chunk_rows is None:
        parts = list(blocks)
        if parts:
            yield {c: np.concatenate([b[c] for b in parts]) for c in columns}
        return
    first = columns[0]
    pending: deque[Columns] = deque()
    offset = 0  # rows of pending[0] already yielded
    have = 0  # rows pending, after the offset

    def take(rows: int) -> Columns:
        nonlocal offset, have
        pieces: list[Columns] = []
        while rows > 0:
            block = pending[0]
            size = len(block[first]) - offset
            n = min(size, rows)
            pieces.append({c: block[c][offset : offset + n] for c in columns})
            rows -= n
            have -= n
            offset += n
            if offset == len(block[first]):
                pending.popleft()
                offset = 0
        if len(pieces) == 1:
            return pieces[0]
        return {c: np.concatenate([p[c] for p in pieces]) for c in columns}

    for block in blocks:
        if len(block[first]) == 0:
            continue
        pending.append(block)
        have += len(block[first])
        while have >= chunk_rows:
            yield take(chunk_rows)
    if have:
        yield take(have)


#: Bytes of CSV text parsed at a time (by polars, on every core). Measured on the 10 M-row log
#: of benchmarks/bench_tabular.py: 4 MiB blocks read it in 0.80-0.90 s at a peak of +50 MB over
#: polars' import; 1 MiB: 0.91-1.09 s; 16 MiB: 0.89-0.98 s at +170 MB. (pyarrow's streaming
#: reader, which parses on one thread, took 1.34-1.52 s.) Smaller chunks read smaller blocks:
#: :data:`_CSV_BLOCK_BYTES_PER_ROW` a row of the chunk, at least 64 KiB.
_CSV_BLOCK = 4 << 20
_CSV_BLOCK_BYTES_PER_ROW = 64
_CSV_BLOCK_MIN = 64 << 10


def _csv_text_blocks(p: Path, block: int = _CSV_BLOCK) -> Iterator[bytes]:
    """The data lines of a CSV file (those after its header, the first non-blank line), in
    pieces of about ``block`` bytes, each ending at a line end."""
    with p.open("rb") as fh:
        for line in fh:
            if line.removeprefix(b"\xef\xbb\xbf").strip():
                if b"\r" in line.rstrip(b"\r\n"):
                    raise _CsvRefused("lines end in a bare carriage return")
                break
        rest = b""
        while data := fh.read(block):
            cut = data.rfind(b"\n") + 1
            if cut == 0:
                rest += data
                continue
            text = rest + data[:cut] if rest else data[:cut]
            rest = data[cut:]
            if text[:1] in (b"\n", b"\r"):  # a parser takes a block's width from its first line
                text = text.lstrip(b"\r\n")
            if text:
                yield text
        if rest.strip():
            yield rest.lstrip(b"\r\n")


def iter_columns(
    path: str | Path,
    columns: Sequence[str],
    *,
    chunk_rows: int | None,
    allow_nan: bool = False,
    integer: Sequence[str] = (),
    checked: bool = False,
) -> Iterator[tuple[int, Columns]]:
    """``(first row index, {column: array})`` per chunk of ``chunk_rows`` rows.

    Arrays are float64; a CSV's columns named in ``integer`` come as int64 in a chunk where every
    value of theirs is written as an integer. ``chunk_rows=None`` yields the whole table at
    once. Memory is bounded by the chunk (plus one block of the underlying reader: a Parquet
    batch, an IPC batch, or CSV text of 64 bytes a row of the chunk, 64 KiB to 4 MiB). A CSV's
    lines are checked first (:mod:`odolab.io.limits`; ``checked``: the caller already did).

    Raises:
        LogFormatError: the chunk size is not a whole number >= 1, or the table cannot be read (the
            line or row is named).
    """
    p = Path(path)
    if chunk_rows is not None and (chunk_rows < 1 or int(chunk_rows) != chunk_rows):
        raise LogFormatError(f"chunk size is {chunk_rows!r}; expected a whole number of rows >= 1")
    fmt, header = _checked_header(p, columns, checked)
    blocks: Iterator[Columns]
    if fmt == "csv":
        block = _CSV_BLOCK
        if chunk_rows is not None:
            block = min(block, max(_CSV_BLOCK_MIN, chunk_rows * _CSV_BLOCK_BYTES_PER_ROW))
        blocks = _csv_chunks(p, header, columns, integer, allow_nan, block)
    else:
        blocks = _arrow_chunks(p, fmt, columns)
    row = 0
    where = "line" if fmt == "csv" else "row"
    for chunk in _rechunk(blocks, columns, chunk_rows):
        if not allow_nan and fmt != "csv":
            _check_finite(p, chunk, where, offset=row)
        yield row, chunk
        row += len(chunk[columns[0]])


def _parsed_blocks(
    p: Path, header: list[str], columns: Sequence[str], integer: Sequence[str], block: int
) -> Iterator[tuple[int, Columns]]:
    """``(bytes of text, its columns)`` block by block."""
    for text in _csv_text_blocks(p, block):
        yield len(text), _parse_block(text, header, columns, integer)


def _csv_chunks(
    p: Path,
    header: list[str],
    columns: Sequence[str],
    integer: Sequence[str],
    allow_nan: bool,
    block: int = _CSV_BLOCK,
) -> Iterator[Columns]:
    """Streaming CSV blocks; anything unusual goes to the careful reader, which raises."""
    from odolab.io._table import read_numeric_columns

    try:
        for _, parsed in _parsed_blocks(p, header, columns, integer, block):
            if not allow_nan and not all(
                bool(np.isfinite(a).all()) for a in parsed.values() if a.dtype.kind == "f"
            ):
                raise _CsvRefused("a value that is not a finite number")
            yield parsed
    except _CsvRefused as err:
        read_numeric_columns(p, columns, allow_nan=allow_nan, checked=True)  # names the line
        raise LogFormatError(  # the careful reader found nothing wrong: an unusual layout
            f"{p}: could not be read in chunks ({err}); expected a plain numeric CSV, or read "
            "it whole ({{chunk_rows}} 0)"
        ) from err


def _arrow_chunks(p: Path, fmt: TableFormat, columns: Sequence[str]) -> Iterator[Columns]:

    row = 0
    try:
        with contextlib.ExitStack() as stack:
            for batch in _arrow_batches(p, fmt, columns, stack)[2]:
                yield _arrow_to_f64(p, batch, columns, row)
                row += batch.num_rows
    except _arrow_errors() as err:
        kind = "Parquet" if fmt == "parquet" else "Arrow IPC"
        raise LogFormatError(f"{p}: not a readable {kind} file ({err})") from err


def _frame(columns: Mapping[str, NDArray[np.generic]]) -> pl.DataFrame:
    """A polars frame over the arrays (numeric numpy arrays are not copied)."""
    import polars as pl

    return pl.DataFrame({k: np.ascontiguousarray(v) for k, v in columns.items()})


def _cannot_write(p: Path, what: str, err: BaseException) -> LogFormatError:
    why = err.strerror if isinstance(err, OSError) and err.strerror else str(err)
    return LogFormatError(
        f"{p}: cannot write the {what} ({why}); expected a file name in a writable folder"
    )


def write_columns(path: str | Path, columns: Mapping[str, NDArray[np.generic]], what: str) -> Path:
    """Write equal-length 1-D arrays as a table, in the format of the file's extension.

    Float columns stay float64 (CSV: shortest round-trip text), integer columns stay int64.
    CSV: the arrays are handed to polars without a copy, then written at once. Parquet and Arrow
    IPC of float64 and int64 columns: pyarrow's writer over the arrays (no copy, no polars), with
    the settings of :class:`ChunkWriter`; other columns go through polars.
    """
    p = Path(path)
    arrays = [np.asarray(v) for v in columns.values()]
    if (
        table_format(p) != "csv"
        and arrays
        and all(a.ndim == 1 and a.dtype in (np.float64, np.int64) for a in arrays)
    ):
        from odolab.core.writing import replacing_path

        with (
            replacing_path(p, what=what, error=LogFormatError) as tmp,
            ChunkWriter(tmp, what, shown=p, background=False) as writer,
        ):
            writer.write(columns)
        return p
    import polars as pl

    try:
        frame = _frame(columns)
    except pl.exceptions.PolarsError as err:
        raise _cannot_write(Path(path), what, err) from err
    return write_frame(path, frame, what)


def write_frame(path: str | Path, frame: pl.DataFrame, what: str) -> Path:
    """Write a polars frame as CSV, Parquet or Arrow IPC by the file's extension; a failure is
    one sentence naming the file and ``what`` it holds."""
    import polars as pl

    from odolab.core.writing import replacing_path

    p = Path(path)
    fmt = table_format(p)
    try:
        # through a temporary file renamed over the path (odolab.core.writing): never through a
        # link planted at the path, and no half file when the disk fills
        with replacing_path(p, what=what, error=LogFormatError) as tmp:
            if fmt == "csv":
                frame.write_csv(tmp)
            elif fmt == "parquet":
                frame.write_parquet(tmp)
            else:
                frame.write_ipc(tmp)
    except (OSError, pl.exceptions.PolarsError) as err:
        raise _cannot_write(p, what, err) from err
    return p


#: Rows of a Parquet row group (or an Arrow IPC record batch) that :class:`ChunkWriter` writes:
#: chunks are gathered until at least ``ROW_GROUP_MIN_ROWS`` rows (so that small chunks do not
#: make a file of tiny row groups, which readers read slowly), and a bigger chunk is cut into
#: groups of at most ``ROW_GROUP_MAX_ROWS`` (pyarrow's own largest row group). The default
#: chunk of ``odolab odometry`` (1,000,000 rows) is one row group, written as it is.
ROW_GROUP_MIN_ROWS = 1 << 16
ROW_GROUP_MAX_ROWS = 1 << 20

#: pyarrow's ParquetWriter settings for the numeric tables odolab writes (docs/scale.md measures
#: them): no dictionary (every float of a trajectory is distinct, and pyarrow's default tries a
#: dictionary for each column of each row group before giving up on it: half the writing time);
#: min/max statistics of every column (what a reader filters row groups on; cheap); snappy.
PARQUET_WRITER_OPTIONS: dict[str, bool | str] = {
    "use_dictionary": False,
    "write_statistics": True,
    "compression": "snappy",
}


def _arrow_array(values: NDArray[np.generic]) -> pa.Array:
    """A pyarrow array over a numeric numpy array without a copy. (``pa.array`` of a numpy array
    imports pandas to check for its types: 0.3-1 s of a command that writes Parquet.)"""
    import pyarrow as pa

    a = np.ascontiguousarray(values)
    types = {"f8": pa.float64(), "i8": pa.int64(), "f4": pa.float32(), "i4": pa.int32()}
    typ = types.get(f"{a.dtype.kind}{a.dtype.itemsize}") if a.dtype.isnative else None
    if typ is None:  # pragma: no cover - odolab writes float64 and int64 columns
        return pa.array(a)
    return pa.Array.from_buffers(typ, len(a), [None, pa.py_buffer(a)])


class _WriterThread:
    """One background thread that runs write jobs in order, one at a time.

    :meth:`submit` waits until the previous job is done (so one chunk is written while the
    caller makes the next, and memory holds at most those two), and raises the error of an
    earlier job there; after an error no further job runs. :meth:`finish` waits for the last
    job and raises its error."""

    def __init__(self, name: str) -> None:
        self._jobs: queue.Queue[Callable[[], None] | None] = queue.Queue()
        self._free = threading.Semaphore(1)
        self.error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while (job := self._jobs.get()) is not None:
            try:
                if self.error is None:
                    job()
            except BaseException as err:  # kept, raised in the caller's thread
                self.error = err
            finally:
                self._free.release()

    def submit(self, job: Callable[[], None]) -> None:
        self._free.acquire()  # the previous job is done
        if self.error is not None:
            self._free.release()
            raise self.error
        self._jobs.put(job)

    def finish(self, *, raise_error: bool = True) -> None:
        self._free.acquire()
        self._jobs.put(None)
        self._thread.join()
        if raise_error and self.error is not None:
            raise self.error


class ChunkWriter:
    """Write a table chunk by chunk (same columns each time); one format per file extension.

    Use as a context manager; the file is complete when it closes. Each chunk is written on a
    background thread while the caller makes the next one (``background=False``: in the
    caller's thread); an error of the writer is raised at the next :meth:`write` or at the
    close, as one sentence naming the file. Memory: the chunk being written and the one being
    made (Parquet and IPC: row groups of :data:`ROW_GROUP_MIN_ROWS` to
    :data:`ROW_GROUP_MAX_ROWS` rows; smaller chunks are gathered until one is full).
    """

    def __init__(
        self,
        path: str | Path,
        what: str = "table",
        *,
        shown: Path | None = None,
        background: bool = True,
    ) -> None:
        self.path = Path(path)
        self.shown = shown or self.path  # the name in error messages
        self.what = what
        self.format = table_format(self.path)
        self.rows = 0
        self.background = background
        self._sink: IO[bytes] | pa.NativeFile | None = None
        self._writer: pq.ParquetWriter | ipc.RecordBatchFileWriter | None = None
        self._thread: _WriterThread | None = None
        self._gathered: list[
            dict[str, NDArray[np.generic]]
        ] = []  # Parquet, IPC: the next row group
        self._gathered_rows = 0
        self._header = True

    def __enter__(self) -> ChunkWriter:
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            if self.format == "csv":
                self._sink = self.path.open("wb")
        except OSError as err:
            raise _cannot_write(self.shown, self.what, err) from err
        if self.background:
            self._thread = _WriterThread("odolab-write")
        return self

    def write(self, columns: Mapping[str, NDArray[np.generic]]) -> None:
        """Append one chunk (a mapping of column name to 1-D array; not changed afterwards)."""
        cols = dict(columns)
        rows = len(next(iter(cols.values())))
        self.rows += rows
        if self.format == "csv":
            header, self._header = self._header, False

            def write_csv() -> None:
                _frame(cols).write_csv(self._sink, include_header=header)

            self._run(write_csv)
            return
        self._gathered.append(cols)
        self._gathered_rows += rows
        if self._gathered_rows >= ROW_GROUP_MIN_ROWS:
            self._flush()

    def _flush(self) -> None:
        """Hand the gathered chunks to the writer as row groups."""
        parts, self._gathered, self._gathered_rows = self._gathered, [], 0
        if parts:
            self._run(lambda: self._write_arrow(parts))

    def _run(self, job: Callable[[], None]) -> None:
        def guarded() -> None:
            try:
                job()
            except _write_errors() as err:
                raise _cannot_write(self.shown, self.what, err) from err

        if self._thread is None:
            guarded()
        else:
            self._thread.submit(guarded)

    def _write_arrow(self, parts: list[dict[str, NDArray[np.generic]]]) -> None:
        import pyarrow as pa
        import pyarrow.ipc as ipc
        import pyarrow.parquet as pq

        names = list(parts[0])
        if len(parts) == 1:
            arrays = [_arrow_array(parts[0][k]) for k in names]
        else:  # small chunks gathered into one row group: one copy
            arrays = [_arrow_array(np.concatenate([p[k] for p in parts])) for k in names]
        table = pa.Table.from_arrays(arrays, names=names)
        if self._writer is None:
            if self.format == "parquet":
                self._writer = pq.ParquetWriter(self.path, table.schema, **PARQUET_WRITER_OPTIONS)
            else:
                self._sink = pa.OSFile(str(self.path), "wb")
                self._writer = ipc.new_file(self._sink, table.schema)
        if self.format == "parquet":
            self._writer.write_table(table, row_group_size=ROW_GROUP_MAX_ROWS)
        else:
            self._writer.write_table(table, max_chunksize=ROW_GROUP_MAX_ROWS)

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        error: BaseException | None = None
        try:
            if exc is None:
                self._flush()  # may raise an earlier job's error
        except BaseException as err:  # raised once the files are closed
            error = err
        finally:
            if self._thread is not None:  # ended whatever happened: no thread left waiting
                try:
                    self._thread.finish(raise_error=exc is None and error is None)
                except BaseException as err:
                    error = err
        try:
            if self._writer is not None:
                self._writer.close()
            if self._sink is not None:
                self._sink.close()
        except _write_errors() as err:
            if exc is None and error is None:
                error = _cannot_write(self.shown, self.what, err)
        if error is not None:
            raise error


def _write_errors() -> tuple[type[BaseException], ...]:
    """What a writer raises for a file it cannot write (a full disk, a file grown past a
    limit): Python's and pyarrow's OSError, and polars' own errors."""
    import sys

    errors: list[type[BaseException]] = [OSError]
    # (a module that failed to import, or one blocked for a test, is in sys.modules as None)
    if (pl := sys.modules.get("polars")) is not None:
        errors.append(pl.exceptions.PolarsError)
    if (pa := sys.modules.get("pyarrow")) is not None:
        errors.append(pa.ArrowException)
    return tuple(errors)


def progress_of(
    progress: Callable[[int, int, str], None] | None, total: int, name: str
) -> Callable[[int], None]:
    """A ``done -> None`` reporter from an optional ``progress(done, total, name)`` callback."""
    if progress is None:
        return lambda done: None
    report = progress
    return lambda done: report(done, total, name)


def row_count(path: str | Path) -> int | None:
    """Rows of a Parquet or IPC file from its metadata (None for CSV: unknown until read)."""
    p = Path(path)
    fmt = table_format(p)
    if fmt == "csv":
        return None
    import pyarrow as pa
    import pyarrow.ipc as ipc
    import pyarrow.parquet as pq

    with contextlib.suppress(*_arrow_errors()):
        if fmt == "parquet":
            return int(pq.ParquetFile(p).metadata.num_rows)
        with pa.memory_map(str(p)) as source:
            reader = ipc.open_file(source)
            return int(sum(reader.get_batch(k).num_rows for k in range(reader.num_record_batches)))
    return None
