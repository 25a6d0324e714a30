"""Size checks of bag files before rosbags reads them.

rosbags trusts the lengths a file declares: a damaged length field in an MCAP or ROS 1 bag made
it allocate that many bytes (a ``MemoryError`` for 2^63, gigabytes for 2^32). These walks read
only the record headers, compare every declared length with the bytes that are really there (the
file, or the record that holds it) and bound what a chunk may expand to, so a damaged file is
one sentence naming the file and the byte where its structure breaks. What they do not check
(a checksum, a message's own fields) is left to rosbags, whose errors the reader turns into
sentences too.
"""

from __future__ import annotations

import struct
from pathlib import Path
from typing import BinaryIO

from odolab.core.errors import LogFormatError

__all__ = ["MAX_CHUNK_BYTES", "check_bag_sizes", "check_mcap", "check_ros1"]

#: Largest uncompressed chunk accepted (bytes). Writers use 1-64 MiB (rosbag2's MCAP default
#: is 1 MiB, ROS 1's 768 KiB); a chunk is held in memory whole while it is read.
MAX_CHUNK_BYTES = 1 << 30
#: Largest metadata.yaml of a rosbag2 folder (bytes): it is parsed whole.
MAX_METADATA_BYTES = 1 << 20

_MCAP_MAGIC = b"\x89MCAP0\r\n"
_ROS1_MAGIC = b"#ROSBAG V2.0\n"
_U32 = struct.Struct("<I")
_U64 = struct.Struct("<Q")


def _damaged(p: Path, what: str) -> LogFormatError:
    return LogFormatError(f"{p}: {what}; a damaged or truncated bag (expected a whole file)")


def _read(fh: BinaryIO, n: int, p: Path, at: int, what: str) -> bytes:
    data = fh.read(n)
    if len(data) != n:
        raise _damaged(p, f"byte {at:,}: the file ends inside {what}")
    return data


def check_bag_sizes(path: Path) -> None:
    """Check the declared sizes of a ROS 1 bag, an MCAP file, or the storage files of a rosbag2
    folder (and its metadata.yaml's size); other files are left to rosbags."""
    if path.is_dir():
        meta = path / "metadata.yaml"
        if meta.is_file() and meta.stat().st_size > MAX_METADATA_BYTES:
            raise LogFormatError(
                f"{meta}: {meta.stat().st_size:,} bytes; a rosbag2 metadata.yaml is at most "
                f"{MAX_METADATA_BYTES:,} bytes"
            )
        for q in sorted(path.glob("*.mcap")):
            check_mcap(q)
        return
    if not path.is_file():
        return
    with path.open("rb") as fh:
        head = fh.read(len(_ROS1_MAGIC))
    if head.startswith(_MCAP_MAGIC):
        check_mcap(path)
    elif head == _ROS1_MAGIC:
        check_ros1(path)


def _check_chunk_size(p: Path, at: int, size: int) -> None:
    if size > MAX_CHUNK_BYTES:
        raise _damaged(
            p,
            f"byte {at:,}: a chunk declares {size:,} bytes uncompressed, more than the "
            f"{MAX_CHUNK_BYTES:,} a chunk may hold",
        )


def check_mcap(path: Path) -> None:
    """Every record of an MCAP file fits in the file, walked from its start and from where its
    footer says the summary starts (rosbags reads both); every chunk fits in its record and
    expands to at most :data:`MAX_CHUNK_BYTES`; every chunk index points inside the file."""
    p = Path(path)
    size = p.stat().st_size
    with p.open("rb") as fh:
        if fh.read(8) != _MCAP_MAGIC:
            return  # not MCAP: rosbags says so
        _walk_mcap(fh, p, size, 8, (0x02,))
        if size >= 8 + 37:
            fh.seek(size - 37)
            footer = fh.read(37)
            if footer[:9] == b"\x02\x14\x00\x00\x00\x00\x00\x00\x00":
                summary = _U64.unpack_from(footer, 9)[0]
                if 8 <= summary <= size - 37:
                    _walk_mcap(fh, p, size, summary, (0x02, 0x0E))


def _walk_mcap(fh: BinaryIO, p: Path, size: int, pos: int, stops: tuple[int, ...]) -> None:
    """The records from byte ``pos`` to one of opcode ``stops`` (the footer; the summary's
    end) or the end of the file."""
    while pos < size - len(_MCAP_MAGIC):
        fh.seek(pos)
        op, length = struct.unpack("<BQ", _read(fh, 9, p, pos, "a record header"))
        if length > size - pos - 9:
            raise _damaged(
                p,
                f"byte {pos:,}: a record (opcode 0x{op:02x}) declares {length:,} bytes "
                f"where {max(0, size - pos - 9):,} remain",
            )
        if op == 0x06:
            _check_mcap_chunk(fh, p, pos, length)
        elif op == 0x08:
            _check_mcap_chunk_index(fh, p, pos, length, size)
        if op in stops:
            break
        pos += 9 + length


def _check_mcap_chunk(fh: BinaryIO, p: Path, pos: int, length: int) -> None:
    """A Chunk record: start, end, uncompressed size, crc, compression, records."""
    if length < 40:
        raise _damaged(p, f"byte {pos:,}: a chunk record of {length} bytes, at least 40 expected")
    body = _read(fh, 32, p, pos, "a chunk record")
    uncompressed = _U64.unpack_from(body, 16)[0]
    _check_chunk_size(p, pos, uncompressed)
    name_len = _U32.unpack_from(body, 28)[0]
    if 32 + name_len + 8 > length:
        raise _damaged(p, f"byte {pos:,}: a chunk's compression name runs past its record")
    compression = _read(fh, name_len, p, pos, "a chunk record")
    records = _U64.unpack(_read(fh, 8, p, pos, "a chunk record"))[0]
    if 32 + name_len + 8 + records > length:
        raise _damaged(
            p, f"byte {pos:,}: a chunk declares {records:,} bytes of records, more than its record"
        )
    declared = _frame_content_size(compression, fh.read(min(records, 32)))
    if declared is not None and declared != uncompressed:
        raise _damaged(
            p, f"byte {pos:,}: a chunk's {compression.decode(errors='replace')} frame declares "
            f"{declared:,} bytes where the chunk says {uncompressed:,}"
        )  # fmt: skip


def _frame_content_size(compression: bytes, head: bytes) -> int | None:
    """The content size an LZ4 or Zstandard frame header declares (what its decompressor
    allocates), or None where it declares none; -1 for a header that cannot be read."""
    try:
        if compression == b"lz4":
            import lz4.frame  # type: ignore[import-untyped]

            size = lz4.frame.get_frame_info(head).get("content_size") or None
            return None if size is None else int(size)
        if compression == b"zstd":
            import zstandard

            size = zstandard.frame_content_size(head)
            return None if size < 0 else int(size)
    except Exception:
        return -1
    return None


def _check_mcap_chunk_index(fh: BinaryIO, p: Path, pos: int, length: int, size: int) -> None:
    """A Chunk Index record: where its chunk is, and the chunk's sizes."""
    if length < 32 + 4:
        raise _damaged(p, f"byte {pos:,}: a chunk index of {length} bytes, at least 36 expected")
    body = _read(fh, min(length, 1 << 16), p, pos, "a chunk index")
    start = _U64.unpack_from(body, 16)[0]
    chunk_length = _U64.unpack_from(body, 24)[0]
    if start > size or chunk_length > size - start:
        raise _damaged(
            p, f"byte {pos:,}: a chunk index points at bytes {start:,} + {chunk_length:,}, past "
            f"the file's {size:,}"
        )  # fmt: skip
    offsets = _U32.unpack_from(body, 32)[0]
    tail = 36 + offsets + 8  # then the compression name, compressed and uncompressed sizes
    if tail + 4 > length:
        raise _damaged(p, f"byte {pos:,}: a chunk index's offsets run past its record")
    if tail + 4 > len(body):
        return  # (an index of thousands of channels: the chunk itself is checked in place)
    name_len = _U32.unpack_from(body, tail)[0]
    end = tail + 4 + name_len
    if end + 16 > length or end + 16 > len(body):
        raise _damaged(p, f"byte {pos:,}: a chunk index's compression name runs past its record")
    compressed, uncompressed = struct.unpack_from("<QQ", body, end)
    if compressed > chunk_length:
        raise _damaged(
            p, f"byte {pos:,}: a chunk index declares {compressed:,} compressed bytes in a chunk "
            f"of {chunk_length:,}"
        )  # fmt: skip
    _check_chunk_size(p, pos, uncompressed)


def check_ros1(path: Path) -> None:
    """Every record of a ROS 1 bag (header and data) fits in the file; every header field fits
    in its header; a chunk expands to at most :data:`MAX_CHUNK_BYTES`; the index position is
    inside the file."""
    p = Path(path)
    size = p.stat().st_size
    with p.open("rb") as fh:
        pos = len(_ROS1_MAGIC)
        while pos < size:
            fh.seek(pos)
            header_len = _U32.unpack(_read(fh, 4, p, pos, "a record header"))[0]
            if header_len > size - pos - 4:
                raise _damaged(
                    p, f"byte {pos:,}: a record header declares {header_len:,} bytes where "
                    f"{size - pos - 4:,} remain"
                )  # fmt: skip
            fields = _ros1_fields(p, pos, _read(fh, header_len, p, pos, "a record header"))
            data_len = _U32.unpack(_read(fh, 4, p, pos, "a record"))[0]
            if data_len > size - pos - 8 - header_len:
                raise _damaged(
                    p, f"byte {pos:,}: a record declares {data_len:,} bytes of data where "
                    f"{max(0, size - pos - 8 - header_len):,} remain"
                )  # fmt: skip
            op = fields.get(b"op", b"")
            if op == b"\x05" and len(fields.get(b"size", b"")) == 4:  # a chunk
                _check_chunk_size(p, pos, _U32.unpack(fields[b"size"])[0])
            if op == b"\x03" and len(fields.get(b"index_pos", b"")) == 8:  # the bag header
                index_pos = _U64.unpack(fields[b"index_pos"])[0]
                if index_pos > size:
                    raise _damaged(
                        p, f"byte {pos:,}: the index is at byte {index_pos:,}, past the file's "
                        f"{size:,}"
                    )  # fmt: skip
            pos += 8 + header_len + data_len


def _ros1_fields(p: Path, pos: int, header: bytes) -> dict[bytes, bytes]:
    fields: dict[bytes, bytes] = {}
    i = 0
    while i + 4 <= len(header):
        n = _U32.unpack_from(header, i)[0]
        if n > len(header) - i - 4:
            raise _damaged(
                p, f"byte {pos:,}: a header field declares {n:,} bytes, more than its header"
            )
        name, _, value = header[i + 4 : i + 4 + n].partition(b"=")
        fields[name] = value
        i += 4 + n
    return fields
