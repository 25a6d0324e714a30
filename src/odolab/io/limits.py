"""Input limits of every text reader: lines of at most 1 MB, UTF-8, no NUL byte, no column twice.

:func:`check_text_file` reads a file once, in 1 MiB chunks, and stops at the first problem, so a
1 GB file of zero bytes costs one chunk and one short sentence, never a 1 GB message. Its
messages name the file and the line and never echo the offending bytes.
"""

from __future__ import annotations

import codecs
import csv
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from odolab.core.errors import LogFormatError, OdolabError
from odolab.core.text import quote_input

__all__ = ["MAX_LINE_BYTES", "check_columns_unique", "check_text_file", "first_line_cells"]

#: Longest line a text input may have (bytes, line end excluded).
MAX_LINE_BYTES = 1_000_000
_CHUNK = 1 << 20


def check_text_file(
    path: str | Path, *, error: type[OdolabError] = LogFormatError, expected: str = "a text file"
) -> None:
    """Refuse ``path`` unless every line is UTF-8 text of at most :data:`MAX_LINE_BYTES` bytes.

    Raises ``error`` (one sentence naming the file and the line) for a line too long, a NUL
    byte (a binary file) or bytes that are not UTF-8. A file that cannot be opened is left to
    the caller's own reader (its message says why).

    Fast on the usual input (ASCII lines far shorter than the limit): per 1 MiB chunk, one
    search for a NUL byte, one ASCII test, and a few searches for a line end (every window of
    a third of the limit holds one, so no line in between can be too long); only a chunk that
    fails one of them is looked at byte by byte. Lines are counted only for the message.
    """
    p = Path(path)
    try:
        fh = p.open("rb")
    except OSError:
        return
    decoder = codecs.getincrementaldecoder("utf-8")()
    offset = 0  # bytes of the file before this chunk
    length = 0  # bytes of the current line before this chunk
    with fh:
        while chunk := fh.read(_CHUNK):
            nul = chunk.find(b"\x00")
            if nul >= 0:
                raise error(
                    f"{p}: line {_line_at(p, offset + nul)} has a NUL byte; expected {expected} "
                    "(is it binary?)"
                )
            pending = len(decoder.getstate()[0])
            if pending or not chunk.isascii():
                try:
                    decoder.decode(chunk)
                except UnicodeDecodeError as err:
                    at = offset + max(0, err.start - pending)
                    raise error(
                        f"{p}: line {_line_at(p, at)} is not UTF-8 text (byte "
                        f"0x{err.object[err.start]:02x}); expected {expected} saved as UTF-8"
                    ) from None
            first = chunk.find(b"\n")
            if first < 0:
                length += len(chunk)
            else:
                if length + first > MAX_LINE_BYTES:
                    _too_long(p, _line_at(p, offset), error)
                last = chunk.rfind(b"\n")
                if not _short_lines_between(chunk, first, last):
                    ends = np.flatnonzero(np.frombuffer(chunk, dtype=np.uint8) == 10)
                    long = np.flatnonzero(np.diff(ends) - 1 > MAX_LINE_BYTES)
                    if long.size:
                        _too_long(p, _line_at(p, offset + int(ends[long[0]]) + 1), error)
                length = len(chunk) - 1 - last
            if length > MAX_LINE_BYTES:
                _too_long(p, _line_at(p, offset + len(chunk) - length), error)
            offset += len(chunk)
        try:
            decoder.decode(b"", final=True)
        except UnicodeDecodeError:
            raise error(
                f"{p}: line {_line_at(p, offset)} ends in the middle of a UTF-8 character; "
                f"expected {expected} saved as UTF-8"
            ) from None


_WINDOW = MAX_LINE_BYTES // 3


def _short_lines_between(chunk: bytes, first: int, last: int) -> bool:
    """True when every line between the line ends at ``first`` and ``last`` is short: each
    window of :data:`_WINDOW` bytes after a grid point holds a line end (a line over the limit
    would hold a whole window). False: look closer."""
    return all(chunk.find(b"\n", k + 1, k + 1 + _WINDOW) >= 0 for k in range(first, last, _WINDOW))


def _line_at(p: Path, pos: int) -> int:
    """The line (from 1) of byte ``pos`` of the file: counted only for an error message."""
    line = 1
    with p.open("rb") as fh:
        while pos > 0 and (chunk := fh.read(min(_CHUNK, pos))):
            line += chunk.count(b"\n")
            pos -= len(chunk)
    return line


def _too_long(p: Path, line: int, error: type[OdolabError]) -> None:
    raise error(
        f"{p}: line {line} is longer than {MAX_LINE_BYTES:,} bytes; expected lines of a "
        "delimited text file (is it the right file?)"
    )


def first_line_cells(path: str | Path, sep: str = ",") -> list[str]:
    """The cells of the first non-blank line (the header), stripped; run :func:`check_text_file`
    first so that the line is known to be short and UTF-8."""
    with Path(path).open(newline="", encoding="utf-8-sig", errors="replace") as fh:
        for text in fh:
            if text.strip():
                if sep == r"\s+":
                    return text.split()
                return [c.strip() for c in next(csv.reader([text], delimiter=sep), [])]
    return []


def check_columns_unique(
    path: str | Path, header: Sequence[str], *, error: type[OdolabError] = LogFormatError
) -> None:
    """Refuse a header that names a column twice (a reader would silently use one of them)."""
    seen: set[str] = set()
    for name in header:
        if name in seen:
            raise error(
                f"{path}: line 1, column {quote_input(name)} appears twice; expected each "
                "column once"
            )
        seen.add(name)
