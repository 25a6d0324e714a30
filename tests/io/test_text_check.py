"""The fast text check (a few searches per 1 MiB chunk) refuses exactly what a byte-by-byte
check refuses, with the same sentence: run with tiny limits so that hypothesis reaches every
case (a line over the limit inside a chunk, across chunks, at a boundary; NUL; bad UTF-8)."""

from __future__ import annotations

import codecs
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from odolab.core.errors import LogFormatError
from odolab.io import limits


def _reference(p: Path, chunk_size: int, limit: int) -> None:
    """Every byte looked at: the check as it was before the fast path (same messages)."""
    decoder = codecs.getincrementaldecoder("utf-8")()
    line, length = 1, 0
    with p.open("rb") as fh:
        while chunk := fh.read(chunk_size):
            nul = chunk.find(b"\x00")
            if nul >= 0:
                where = line + chunk.count(b"\n", 0, nul)
                raise LogFormatError(
                    f"{p}: line {where} has a NUL byte; expected a text file (is it binary?)"
                )
            pending = len(decoder.getstate()[0])
            try:
                decoder.decode(chunk)
            except UnicodeDecodeError as err:
                at = max(0, err.start - pending)
                where = line + chunk.count(b"\n", 0, at)
                raise LogFormatError(
                    f"{p}: line {where} is not UTF-8 text (byte 0x{err.object[err.start]:02x}); "
                    "expected a text file saved as UTF-8"
                ) from None
            ends = np.flatnonzero(np.frombuffer(chunk, dtype=np.uint8) == 10)
            if ends.size == 0:
                length += len(chunk)
            else:
                sizes = np.diff(ends, prepend=-1) - 1
                sizes[0] += length
                long = np.flatnonzero(sizes > limit)
                if long.size:
                    raise LogFormatError(f"{p}: line {line + int(long[0])} is longer")
                line += int(ends.size)
                length = len(chunk) - 1 - int(ends[-1])
            if length > limit:
                raise LogFormatError(f"{p}: line {line} is longer")
        try:
            decoder.decode(b"", final=True)
        except UnicodeDecodeError:
            raise LogFormatError(
                f"{p}: line {line} ends in the middle of a UTF-8 character; expected a text file "
                "saved as UTF-8"
            ) from None


def _outcome(f: object) -> str:
    try:
        f()  # type: ignore[operator]
    except LogFormatError as err:
        text = str(err)
        return text.split(" is longer")[0] + " is longer" if " is longer" in text else text
    return "ok"


PIECES = [b"a", b"bc", b"\n", b"\n", b"\r\n", "é".encode(), b"\xff", b"\xc3", b"\x00", b"x" * 9]


@given(
    parts=st.lists(st.sampled_from(PIECES), max_size=80),
    chunk=st.integers(4, 40),
    limit=st.integers(3, 30),
)
def test_fast_check_refuses_what_the_byte_by_byte_check_refuses(
    tmp_path_factory: pytest.TempPathFactory, parts: list[bytes], chunk: int, limit: int
) -> None:
    p = tmp_path_factory.mktemp("text") / "f.csv"
    p.write_bytes(b"".join(parts))
    mp = pytest.MonkeyPatch()
    try:
        mp.setattr(limits, "_CHUNK", chunk)
        mp.setattr(limits, "MAX_LINE_BYTES", limit)
        mp.setattr(limits, "_WINDOW", max(1, limit // 3))
        got = _outcome(lambda: limits.check_text_file(p))
    finally:
        mp.undo()
    assert got == _outcome(lambda: _reference(p, chunk, limit))
