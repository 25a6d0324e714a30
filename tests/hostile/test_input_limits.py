"""Input limits of the readers: a line over 1 MB, a NUL byte, non-UTF-8 bytes and a column
named twice are each one short sentence naming the file and the line, from the CLI."""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import pytest

from odolab.cli import main
from odolab.core.errors import LogFormatError
from odolab.io.limits import MAX_LINE_BYTES, check_text_file

GIB = 1 << 30


def _fails(args: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    capsys.readouterr()
    assert main(args) == 1
    err = capsys.readouterr().err
    assert err.startswith("odolab: error: ") and err.count("\n") == 1, err[:500]
    assert len(err) < 400
    return err


def test_a_1_gib_file_of_zero_bytes_is_one_short_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    zeros = tmp_path / "zeros.csv"
    with zeros.open("wb") as fh:
        fh.truncate(GIB)  # sparse: 1 GiB of zero bytes that take no disk
    # the command's imports first (alone, this test would count them: 20 MB of modules)
    small = tmp_path / "small.csv"
    small.write_bytes(b"\0" * 100)
    _fails(["odometry", str(small), "-o", str(tmp_path / "t.csv")], capsys)
    tracemalloc.start()
    try:
        err = _fails(["odometry", str(zeros), "-o", str(tmp_path / "t.csv")], capsys)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert f"{zeros}: line 1 has a NUL byte; expected an encoder log CSV" in err
    assert peak < 16 * (1 << 20)  # bytes: one 1 MiB chunk read, not the gigabyte
    err = _fails(["trials", "import", str(zeros), "--db", str(tmp_path / "lab.db")], capsys)
    assert f"{zeros}: line 1 has a NUL byte; expected a trials CSV" in err


def test_a_line_over_1_mb_is_refused_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / "enc.csv"
    log.write_text("t,left_ticks,right_ticks\n0,0,0\n" + "1" * (MAX_LINE_BYTES + 1) + ",0,0\n")
    err = _fails(["odometry", str(log), "-o", str(tmp_path / "t.csv")], capsys)
    assert f"{log}: line 3 is longer than 1,000,000 bytes" in err
    errors = tmp_path / "errors.csv"
    errors.write_text("direction,x,y\n" + "cw," * 600_000 + "\n")
    err = _fails(["calibrate", "umbmark", "-p", "jaguar-lite", "--errors", str(errors),
                  "--side", "4", "-o", str(tmp_path / "n.toml")], capsys)  # fmt: skip
    assert f"{errors}: line 2 is longer than 1,000,000 bytes" in err


def test_non_utf8_input_is_one_sentence(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    errors = tmp_path / "errors.csv"
    errors.write_bytes(b"direction,x,y\ncw,-0.1,-0.1\nccw,-0.05,0.05\ncw,0.1\xe9,0\n")
    args = ["calibrate", "umbmark", "-p", "jaguar-lite", "--errors", str(errors), "--side", "4",
            "-o", str(tmp_path / "n.toml")]  # fmt: skip
    err = _fails(args, capsys)
    assert f"{errors}: line 4 is not UTF-8 text (byte 0xe9); expected a CSV" in err
    log = tmp_path / "enc.csv"
    log.write_bytes(b"t,left_ticks,right_ticks\n0,0,0\n0.05,\xff1,2\n")
    err = _fails(["odometry", str(log), "-o", str(tmp_path / "t.csv")], capsys)
    assert f"{log}: line 3 is not UTF-8 text (byte 0xff)" in err
    trials = tmp_path / "trials.csv"
    trials.write_bytes(b"trial_id,campaign\n\xc3(,x\n")
    err = _fails(["trials", "import", str(trials), "--db", str(tmp_path / "lab.db")], capsys)
    assert f"{trials}: line 2 is not UTF-8 text (byte 0xc3)" in err


def test_a_column_named_twice_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / "enc.csv"
    log.write_text("t,left_ticks,right_ticks,left_ticks\n0,0,0,5\n0.05,1,1,6\n")
    err = _fails(["odometry", str(log), "-o", str(tmp_path / "t.csv")], capsys)
    assert f"{log}: line 1, column 'left_ticks' appears twice; expected each column once" in err
    errors = tmp_path / "errors.csv"
    errors.write_text("direction,x,y,x\ncw,0.1,0.1,9\nccw,0.1,0.1,9\n")
    err = _fails(["calibrate", "umbmark", "-p", "jaguar-lite", "--errors", str(errors),
                  "--side", "4", "-o", str(tmp_path / "n.toml")], capsys)  # fmt: skip
    assert f"{errors}: line 1, column 'x' appears twice" in err


def test_trajectory_and_metadata_readers_apply_the_same_limits(tmp_path: Path) -> None:
    from odolab.io import read_optiodom_metadata, read_trajectory_csv

    traj = tmp_path / "traj.csv"
    traj.write_text("t,x,y,theta,x\n0,0,0,0,1\n")
    with pytest.raises(LogFormatError, match="line 1, column 'x' appears twice"):
        read_trajectory_csv(traj)
    meta = tmp_path / "a_metadata.csv"
    meta.write_bytes(b"Li,0.2\nngear,\x00\n")
    with pytest.raises(LogFormatError, match="line 2 has a NUL byte"):
        read_optiodom_metadata(meta)


def test_line_numbers_across_chunk_boundaries(tmp_path: Path) -> None:
    f = tmp_path / "f.txt"
    # 3 lines of 700,000 bytes: the second ends in the second 1 MiB chunk
    ok = ("a" * 700_000 + "\n") * 3
    f.write_text(ok)
    check_text_file(f)
    f.write_text(ok + "b" * (MAX_LINE_BYTES - 1) + "é\n")  # 1,000,001 bytes: é is 2 bytes
    with pytest.raises(LogFormatError, match="line 4 is longer than 1,000,000 bytes"):
        check_text_file(f)
    f.write_text(ok + "b" * (MAX_LINE_BYTES - 2) + "é\n")  # exactly 1,000,000: accepted
    check_text_file(f)
    # a 2-byte character split by the chunk boundary (byte 1 MiB) is fine; a lone byte is not
    chunk = 1 << 20
    head = (b"x" * 99_999 + b"\n") * 10  # 1,000,000 bytes
    f.write_bytes(head + b"y" * (chunk - 1 - len(head)) + "é".encode() + b"\n")
    check_text_file(f)
    f.write_bytes(b"x\n" * 10 + b"\xc3")
    with pytest.raises(LogFormatError, match="line 11 ends in the middle of a UTF-8 character"):
        check_text_file(f)


def test_echoed_input_is_capped(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "enc.csv"
    log.write_text("t,left_ticks,right_ticks\n0,0,0\n0.05," + "z" * 500_000 + ",1\n")
    err = _fails(["odometry", str(log), "-o", str(tmp_path / "t.csv")], capsys)
    assert f"{log}: line 3, column 'left_ticks' is 'zzz" in err
    assert "... (500000 characters)', expected a number" in err
    trials = tmp_path / "trials.csv"
    trials.write_text(
        "trial_id,campaign,terrain,kind,distance_m,predicted_x_m,predicted_y_m,"
        "predicted_heading_rad,robot,left_wheel_radius_m,right_wheel_radius_m,track_width_m,"
        "ticks_per_rev\nT1,c,lab,translation,1,1,0,0,jag,0.08,0.08,0.5,\x1b[2J" + "k" * 100_000
    )
    err = _fails(["trials", "import", str(trials), "--db", str(tmp_path / "lab.db")], capsys)
    assert "\x1b" not in err and "(100004 characters)' is not a number" in err


def test_validate_refuses_a_binary_imu_log(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    enc = tmp_path / "enc.csv"
    enc.write_text("t,left_ticks,right_ticks\n0,0,0\n0.05,1,1\n0.1,2,2\n")
    imu = tmp_path / "phone.csv"
    with imu.open("wb") as fh:
        fh.truncate(GIB)
    args = ["validate", str(enc), str(imu), "--new", "jaguar-lite"]
    assert f"{imu}: line 1 has a NUL byte; expected a SensorLog CSV" in _fails(args, capsys)
    imu.write_bytes(b"loggingTime(txt),motionYaw(rad)\n2024-01-01,\xb0\n")
    assert f"{imu}: line 2 is not UTF-8 text (byte 0xb0)" in _fails(args, capsys)
