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

from odolab.errors import LogFormatError, OdolabError
from odolab.text import quote_input

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
    """
    p = Path(path)
    try:
        fh = p.open("rb")
    except OSError:
        return
    decoder = codecs.getincrementaldecoder("utf-8")()
    line = 1  # the line the next byte belongs to
    length = 0  # bytes of that line so far
    with fh:
        while chunk := fh.read(_CHUNK):
            nul = chunk.find(b"\x00")
            if nul >= 0:
                where = line + chunk.count(b"\n", 0, nul)
                raise error(
                    f"{p}: line {where} has a NUL byte; expected {expected} (is it binary?)"
                )
            pending = len(decoder.getstate()[0])
            try:
                decoder.decode(chunk)
            except UnicodeDecodeError as err:
                at = max(0, err.start - pending)
                where = line + chunk.count(b"\n", 0, at)
                raise error(
                    f"{p}: line {where} is not UTF-8 text (byte 0x{err.object[err.start]:02x}); "
                    f"expected {expected} saved as UTF-8"
                ) from None
            ends = np.flatnonzero(np.frombuffer(chunk, dtype=np.uint8) == 10)
            if ends.size == 0:
                length += len(chunk)
            else:
                sizes = np.diff(ends, prepend=-1) - 1
                sizes[0] += length
                long = np.flatnonzero(sizes > MAX_LINE_BYTES)
                if long.size:
                    _too_long(p, line + int(long[0]), error)
                line += int(ends.size)
                length = len(chunk) - 1 - int(ends[-1])
            if length > MAX_LINE_BYTES:
                _too_long(p, line, error)
        try:
            decoder.decode(b"", final=True)
        except UnicodeDecodeError:
            raise error(
                f"{p}: line {line} ends in the middle of a UTF-8 character; expected {expected} "
                "saved as UTF-8"
            ) from None


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
