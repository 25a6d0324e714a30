"""Every reader, fed damaged files, answers with an OdolabError (one sentence) or reads them:
a seeded byte-mutation fuzz of every reader with a fixed budget, and the damaged inputs that gave
tracebacks (issue 24, item 8), each as its own test."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from hostile.fuzzing import TARGETS, prepare, run_case
from odolab.cli import main
from odolab.core.errors import LogFormatError, ParamsError

#: Mutations per reader in CI: 25 readers x 60 cases read in about 15 s on one core (the
#: 10-minute run is benchmarks/bench_fuzz.py).
CASES = 60


@pytest.mark.parametrize("name", sorted(TARGETS))
def test_mutated_files_give_a_sentence_or_a_result(name: str, tmp_path: Path) -> None:
    target = TARGETS[name]
    seed, mutable, read_path = prepare(target, tmp_path)
    found: dict[str, list[int]] = {}
    for case in range(CASES):
        signature = run_case(target, seed, mutable, read_path, case)
        if signature is not None:
            found.setdefault(signature, []).append(case)
    assert found == {}, f"{name}: exceptions that are not OdolabError (signature: cases) {found}"


def test_the_fuzzer_finds_a_foreign_exception(tmp_path: Path) -> None:
    """The harness can fail: a reader that lets a parser's error through is reported."""
    from hostile.fuzzing import Target

    def fragile(p: Path) -> object:
        return float(p.read_text().split()[0])  # ValueError on a word, as a bare parser would

    target = Target("fragile", lambda d: ((d / "x.txt"), (d / "x.txt")), fragile)
    (tmp_path / "x.txt").write_text("1.5 2\n")
    found = {run_case(target, b"1.5 2\n", tmp_path / "x.txt", tmp_path / "x.txt", k)
             for k in range(40)}  # fmt: skip
    assert any(s and s.startswith("ValueError at") for s in found), found


# ---------------------------------------------------------------------------------------------
# the inputs of issue 24's item 8, each of which gave a traceback


def _one_sentence(args: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    capsys.readouterr()
    assert main(args) == 1
    err = capsys.readouterr().err
    assert err.startswith("odolab: error: ") and err.count("\n") == 1, err[-2000:]
    assert "Traceback" not in err
    return err


def _tum(tmp_path: Path, tz: str) -> Path:
    lines = [f"{0.1 * k!r} {k} {2 * k} 0 0 0 0 1" for k in range(10)]
    lines[6] = f"0.6 6 12 {tz} 0 0 0 1"  # the file's line 7
    p = tmp_path / "est.tum"
    p.write_text("\n".join(lines) + "\n")
    return p


@pytest.mark.parametrize("digits", [400, 5000])
def test_a_huge_integer_in_a_tum_file_names_its_line(
    tmp_path: Path, digits: int, capsys: pytest.CaptureFixture[str]
) -> None:
    est = _tum(tmp_path, "9" * digits)  # (an integer column: pandas' python parser overflowed)
    (tmp_path / "gt").mkdir()
    gt = _tum(tmp_path / "gt", "0")
    err = _one_sentence(["evaluate", str(gt), str(est)], capsys)
    assert f"{est}: line 7, column 'tz' is '999" in err
    assert f"({digits} characters)', expected a number" in err


def _params(tmp_path: Path, name: str, robot_extra: str = "", tables: str = "") -> Path:
    p = tmp_path / name
    p.write_text(
        "[robot]\nname = 'r'\nleft_wheel_radius = 0.1\nright_wheel_radius = 0.1\n"
        f"track_width = 0.5\n{robot_extra or 'ticks_per_rev = 380'}\n{tables}"
    )
    return p


def test_huge_integers_in_a_params_toml_are_one_sentence(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    big = _params(tmp_path, "big.toml", "ticks_per_rev = " + "9" * 400)
    with pytest.raises(ParamsError, match=r"'robot.ticks_per_rev' is an integer of 400 digits"):
        from odolab.core.params import load_params

        load_params(big)
    model = _params(
        tmp_path, "model.toml", tables="[model]\nkind = 'extended'\nchi_d = " + "9" * 400
    )
    with pytest.raises(ParamsError, match=r"'model.chi_d' is an integer of 400 digits"):
        load_params(model)
    noise = _params(tmp_path, "noise.toml", tables=f"[noise]\nk_left = {'9' * 400}\nk_right = 0")
    with pytest.raises(ParamsError, match=r"'noise.k_left' is an integer of 400 digits"):
        load_params(noise)
    huge = _params(tmp_path, "huge.toml", "ticks_per_rev = " + "9" * 5000)
    err = _one_sentence(["params", "show", str(huge)], capsys)
    assert f"{huge}: a number too long to read" in err
    deep = tmp_path / "deep.toml"
    deep.write_text("a = " + "[" * 50_000 + "]" * 50_000 + "\n")
    with pytest.raises(ParamsError, match="nested too deeply"):
        load_params(deep)


def test_a_huge_integer_passed_to_the_parameter_check_is_a_sentence() -> None:
    from odolab.core.params import NoiseParams, RobotParams

    with pytest.raises(ParamsError, match="track_width must be a positive finite number"):
        RobotParams(0.1, 0.1, 10**400, 380)
    with pytest.raises(ParamsError, match="k_left must be a number from 0 to 1"):
        NoiseParams(10**400, 0.0)


def test_an_unterminated_quote_names_its_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    traj = tmp_path / "traj.csv"
    traj.write_text('t,x,y,theta\n0.0,1.0,".0,0.0\n0.1,1.0,0.0,0.0\n0.2,1.0,0.0,0.0\n')
    with pytest.raises(
        LogFormatError, match=r"line 2, column 'y' is '\.0,0\.0', expected a number"
    ):
        from odolab.io import read_trajectory

        read_trajectory(traj)
    enc = tmp_path / "enc.csv"
    enc.write_text('t,left_ticks,right_ticks\n0,0,0\n0.05,"3,4\n0.1,6,8\n')
    err = _one_sentence(["odometry", str(enc), "-o", str(tmp_path / "o.csv")], capsys)
    assert f"{enc}: line 3, column 'left_ticks'" in err


def _rename_column(p: Path, old: bytes, new: bytes) -> None:
    data = p.read_bytes()
    assert old in data and len(old) == len(new)
    p.write_bytes(data.replace(old, new))


@pytest.mark.parametrize("suffix", [".parquet", ".arrow"])
def test_a_column_name_that_is_not_utf8_is_a_sentence(
    tmp_path: Path, suffix: str, capsys: pytest.CaptureFixture[str]
) -> None:
    from odolab.core.trials import EncoderLog
    from odolab.io import write_encoder_csv

    p = write_encoder_csv(
        tmp_path / f"enc{suffix}", EncoderLog(np.arange(5) * 0.1, np.arange(5), np.arange(5), None)
    )
    _rename_column(p, b"left_ticks", b"\xffeft_tick\xfe")  # the footer's (schema's) bytes
    err = _one_sentence(["odometry", str(p), "-o", str(tmp_path / "o.csv")], capsys)
    kind = "Parquet" if suffix == ".parquet" else "Arrow IPC"
    assert f"{p}: not a readable {kind} file" in err


# ---------------------------------------------------------------------------------------------
# bags: lengths checked against the file before rosbags allocates them


def _scan_mcap(tmp_path: Path) -> Path:
    from hostile.fuzzing import _scan_mcap as make

    return make(tmp_path)[0]


def _records(data: bytes) -> list[tuple[int, int, int]]:
    """(offset, opcode, length) of each top-level MCAP record."""
    out, pos = [], 8
    while pos < len(data) - 8:
        op, length = struct.unpack_from("<BQ", data, pos)
        out.append((pos, op, length))
        if op == 0x02:
            break
        pos += 9 + length
    return out


def test_an_mcap_record_length_of_2_64_is_refused_before_it_is_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from odolab.io._bagcheck import check_mcap

    p = _scan_mcap(tmp_path)
    data = bytearray(p.read_bytes())
    pos = next(pos for pos, op, _ in _records(bytes(data)) if op == 0x06)  # the first chunk
    data[pos + 1 : pos + 9] = struct.pack("<Q", 2**64 - 1)
    p.write_bytes(bytes(data))
    with pytest.raises(LogFormatError, match=rf"byte {pos:,}: a record \(opcode 0x06\) declares"):
        check_mcap(p)  # the walk that rosbags' reader now follows (it tried to allocate 2^64)
    err = _one_sentence(["scans", str(p), "-o", str(tmp_path / "s.csv")], capsys)
    assert f"{p}: byte {pos:,}: a record (opcode 0x06) declares 18,446,744,073,709,551,615" in err
    assert "a damaged or truncated bag" in err


def test_a_summary_offset_into_garbage_is_walked_too(tmp_path: Path) -> None:
    """rosbags reads the summary where the footer says it starts, not where the records lead:
    a footer pointing into a chunk made it allocate a length read from the chunk's bytes."""
    from odolab.io._bagcheck import check_mcap

    p = _scan_mcap(tmp_path)
    data = bytearray(p.read_bytes())
    chunk = next(pos for pos, op, _ in _records(bytes(data)) if op == 0x06)
    at = chunk + 9  # the chunk's start time: nothing checks it
    data[at : at + 9] = b"\x03" + struct.pack("<Q", 2**63)
    data[len(data) - 37 + 9 : len(data) - 37 + 17] = struct.pack("<Q", at)  # the footer
    p.write_bytes(bytes(data))
    with pytest.raises(LogFormatError, match=rf"byte {at:,}: a record \(opcode 0x03\) declares"):
        check_mcap(p)


def test_an_mcap_chunk_that_expands_past_a_gigabyte_is_refused(tmp_path: Path) -> None:
    from odolab.io._bagcheck import check_mcap
    from odolab.io.scans import read_scans

    p = _scan_mcap(tmp_path)
    data = bytearray(p.read_bytes())
    pos = next(pos for pos, op, _ in _records(bytes(data)) if op == 0x06)
    data[pos + 9 + 16 : pos + 9 + 24] = struct.pack("<Q", 1 << 40)  # its uncompressed size
    p.write_bytes(bytes(data))
    with pytest.raises(LogFormatError, match=r"declares 1,099,511,627,776 bytes uncompressed"):
        check_mcap(p)
    with pytest.raises(LogFormatError, match="more than the 1,073,741,824 a chunk may hold"):
        read_scans(p)


def test_a_chunk_index_past_the_end_of_the_file_is_refused(tmp_path: Path) -> None:
    from odolab.io.scans import read_scans

    p = _scan_mcap(tmp_path)
    data = bytearray(p.read_bytes())
    pos = next(pos for pos, op, _ in _records(bytes(data)) if op == 0x08)  # in the summary
    data[pos + 9 + 24 : pos + 9 + 32] = struct.pack("<Q", 1 << 50)  # the chunk's length
    p.write_bytes(bytes(data))
    with pytest.raises(LogFormatError, match=r"a chunk index points at bytes .* past the file"):
        read_scans(p)


def test_a_ros1_record_longer_than_the_file_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from hostile.fuzzing import _bag as make

    p = make("ros1")(tmp_path)[0]
    data = bytearray(p.read_bytes())
    first = 13  # after "#ROSBAG V2.0\n": the bag header record
    header_len = struct.unpack_from("<I", data, first)[0]
    data_at = first + 4 + header_len
    data[data_at : data_at + 4] = struct.pack("<I", 0xFFFFFFFF)  # its data length
    p.write_bytes(bytes(data))
    err = _one_sentence(
        ["export", "mcap", str(p), "--format", "bag", "-p", "jaguar-lite",
         "-o", str(tmp_path / "x.mcap")], capsys,
    )  # fmt: skip
    assert f"{p}: byte 13: a record declares 4,294,967,295 bytes of data" in err


def test_a_malformed_message_names_its_topic_and_number(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A JointState whose bytes are not a JointState (rosbags' deserializer raised
    struct.error; a message read with another type's fields raised AttributeError)."""
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    folder = tmp_path / "bad_ros2"
    with Writer(folder, version=9) as w:
        conn = w.add_connection("/joint_states", "sensor_msgs/msg/JointState", typestore=store)
        w.write(conn, 1, b"\x00\x01\x00\x00\x05")  # a CDR header and one byte
    from odolab.io import read_bag

    with pytest.raises(LogFormatError, match=r"at message 1 of topic '/joint_states'"):
        read_bag(folder)
    err = _one_sentence(
        ["export", "mcap", str(folder), "--format", "bag", "-p", "jaguar-lite",
         "-o", str(tmp_path / "x.mcap")], capsys,
    )  # fmt: skip
    assert f"{folder}: not a readable ROS 1 or ROS 2 bag at message 1 of topic" in err
