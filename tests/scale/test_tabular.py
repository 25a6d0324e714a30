"""Tabular I/O: CSV with shortest round-trip numbers, Parquet and Arrow IPC by extension."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from odolab.core.errors import LogFormatError
from odolab.core.trajectory import Trajectory
from odolab.core.trials import EncoderLog
from odolab.io import read_encoder_csv, read_trajectory, write_encoder_csv, write_trajectory_csv
from odolab.io.tabular import iter_columns, read_columns, table_format, write_columns


def test_format_by_extension() -> None:
    assert table_format("a.parquet") == "parquet"
    assert table_format("a.PQ") == "parquet"
    assert table_format("a.arrow") == "ipc"
    assert table_format("a.feather") == "ipc"
    assert table_format("a.csv") == "csv"
    assert table_format("a.txt") == "csv"


def test_csv_numbers_are_the_shortest_round_trip_text(tmp_path: Path) -> None:
    traj = Trajectory.from_xyh([0.0, 0.05, 0.1], [0.05, 0.1 + 0.2, 1e-20], [0, 0, 0], [0, 0, 0.5])
    p = write_trajectory_csv(tmp_path / "t.csv", traj)
    lines = p.read_text().splitlines()
    assert lines[0] == "t,x,y,theta,heading"
    assert lines[2].split(",")[:2] == ["0.05", "0.30000000000000004"]  # repr(0.1 + 0.2)
    assert lines[3].split(",")[1] == "1e-20"
    back = read_trajectory(p)
    assert np.array_equal(back.x, traj.x)  # exact, not just close
    assert np.array_equal(back.heading, traj.heading)


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".arrow", ".feather"])
def test_encoder_log_round_trip_every_format(tmp_path: Path, suffix: str) -> None:
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.01, 0.1, 50))
    left = rng.integers(0, 4096, 50)
    right = rng.integers(0, 4096, 50)
    p = write_encoder_csv(tmp_path / f"log{suffix}", EncoderLog(t, left, right, 4096))
    back = read_encoder_csv(p, modulus=4096)
    assert np.array_equal(back.t, t)
    assert np.array_equal(back.left_ticks, left)
    assert np.array_equal(back.right_ticks, right)


def test_parquet_written_by_pyarrow_is_read_by_name(tmp_path: Path) -> None:
    p = tmp_path / "gt.parquet"
    pq.write_table(
        pa.table({"heading": [0.0, 0.5], "extra": ["a", "b"], "t": [1.0, 2.0], "x": [0.0, 1.5],
                  "y": [0.0, -2.0], "theta": [0.0, 0.5]}),
        p,
    )  # fmt: skip
    traj = read_trajectory(p)
    assert traj.t.tolist() == [1.0, 2.0]
    assert traj.x.tolist() == [0.0, 1.5]
    assert traj.heading.tolist() == [0.0, 0.5]


def test_parquet_errors_name_file_row_and_column(tmp_path: Path) -> None:
    p = tmp_path / "log.parquet"
    pq.write_table(pa.table({"t": [0.0, 1.0, float("nan")], "left_ticks": [1, 2, 3],
                             "right_ticks": [1, 2, 3]}), p)  # fmt: skip
    with pytest.raises(LogFormatError, match=r"log\.parquet: row 3, column 't' is nan"):
        read_encoder_csv(p)
    q = tmp_path / "null.parquet"
    pq.write_table(pa.table({"t": [0.0, 1.0], "left_ticks": [1, None], "right_ticks": [1, 2]}), q)
    with pytest.raises(LogFormatError, match=r"null\.parquet: row 2, column 'left_ticks' is empty"):
        read_encoder_csv(q)
    r = tmp_path / "back.parquet"
    pq.write_table(pa.table({"t": [0.0, 2.0, 1.0], "left_ticks": [1, 2, 3],
                             "right_ticks": [1, 2, 3]}), r)  # fmt: skip
    with pytest.raises(LogFormatError, match=r"time goes backwards at row 3"):
        read_encoder_csv(r)
    s = tmp_path / "missing.parquet"
    pq.write_table(pa.table({"t": [0.0], "left_ticks": [1]}), s)
    with pytest.raises(LogFormatError, match=r"missing column 'right_ticks'"):
        read_encoder_csv(s)
    bad = tmp_path / "junk.parquet"
    bad.write_text("not parquet")
    with pytest.raises(LogFormatError, match=r"junk\.parquet: not a readable Parquet file"):
        read_encoder_csv(bad)


def test_fast_reader_falls_back_to_the_careful_one_for_line_numbers(tmp_path: Path) -> None:
    p = tmp_path / "log.csv"
    p.write_text("t,left_ticks,right_ticks\n0,1,1\n\n0.1,2,2\n0.2,x,3\n")
    with pytest.raises(LogFormatError, match=r"line 5, column 'left_ticks' is 'x'"):
        read_encoder_csv(p)
    q = tmp_path / "blank.csv"
    q.write_text("t,left_ticks,right_ticks\n0,1,1\n\n0.1,2,2\n")
    assert read_encoder_csv(q).t.tolist() == [0.0, 0.1]  # a blank line is no row


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".arrow"])
@pytest.mark.parametrize("chunk", [1, 3, 7, 100])
def test_chunks_are_exact_rows_and_concatenate_to_the_table(
    tmp_path: Path, suffix: str, chunk: int
) -> None:
    t = np.arange(23) * 0.1
    p = write_columns(tmp_path / f"c{suffix}", {"t": t, "v": np.arange(23)}, "table")
    rows = []
    for row0, data in iter_columns(p, ["t", "v"], chunk_rows=chunk):
        assert row0 == len(rows)
        assert data["t"].size == min(chunk, 23 - row0)
        rows.extend(data["v"].tolist())
    assert rows == list(range(23))
    assert np.array_equal(read_columns(p, ["t"])["t"], t)


def test_writing_into_a_missing_parent_folder_creates_it(tmp_path: Path) -> None:
    p = write_columns(tmp_path / "a" / "b.parquet", {"x": np.ones(2)}, "table")
    assert pq.read_table(p).column("x").to_pylist() == [1.0, 1.0]


def test_an_unwritable_target_is_one_sentence(tmp_path: Path) -> None:
    (tmp_path / "dir.csv").mkdir()
    with pytest.raises(
        LogFormatError, match=r"dir\.csv: is a folder; expected a file name for the table"
    ):
        write_columns(tmp_path / "dir.csv", {"x": np.ones(2)}, "table")


@pytest.mark.parametrize(
    ("name", "value"), [("OMP_WAIT_POLICY", "passive"), ("OPENBLAS_THREAD_TIMEOUT", "4")]
)
def test_the_command_line_has_idle_threads_sleep_unless_the_user_chose(
    name: str, value: str
) -> None:
    import os
    import subprocess
    import sys

    # the entry point's package import loads no numpy, so the settings precede its BLAS
    code = (
        "import os, sys, odolab; before = 'numpy' in sys.modules; import odolab.cli; "
        f"print(before, os.environ[{name!r}])"
    )
    env = {k: v for k, v in os.environ.items() if k != name}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.stdout.split() == ["False", value]
    mine = {**env, name: "17"}
    out = subprocess.run([sys.executable, "-c", code], env=mine, capture_output=True, text=True)
    assert out.stdout.split() == ["False", "17"]


@pytest.mark.parametrize("block", [1, 16, 40, 1 << 20])
def test_csv_blocks_cut_anywhere_read_like_the_whole_file(
    tmp_path: Path, block: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    # blocks of text end at a line end wherever the cut falls; blank lines, CRLF line ends and
    # counts written as "7.0" (in some blocks only) read as the whole-file reader reads them
    import odolab.io.tabular as tabular

    monkeypatch.setattr(tabular, "_CSV_BLOCK", block)
    monkeypatch.setattr(tabular, "_CSV_BLOCK_MIN", 1)
    lines = ["t,left_ticks,right_ticks,note"]
    for i in range(40):
        left = f"{i}.0" if 20 <= i < 25 else str(i)
        lines.append(f"{i * 0.1:.1f},{left},{2 * i},n{i}")
        if i % 7 == 3:
            lines.append("")
    p = tmp_path / "log.csv"
    p.write_bytes(("\r\n".join(lines) + "\r\n").encode())
    whole = read_encoder_csv(p)
    for chunk in (1, 3, 40):
        parts = list(iter_columns(p, ["t", "left_ticks", "right_ticks"], chunk_rows=chunk,
                                  integer=["left_ticks", "right_ticks"]))  # fmt: skip
        t = np.concatenate([d["t"] for _, d in parts])
        left = np.concatenate([d["left_ticks"] for _, d in parts])
        assert [r for r, _ in parts] == list(range(0, 40, chunk))
        assert np.array_equal(t, whole.t) and np.array_equal(left, whole.left_ticks)


def test_csv_chunks_refuse_what_the_whole_reader_refuses_naming_the_line(tmp_path: Path) -> None:
    from odolab.io.chunked import iter_encoder_chunks

    huge = tmp_path / "huge.csv"
    huge.write_text("t,dticks_left,dticks_right\n0,1,1\n0.1,1e20,2\n")
    for read in (read_encoder_csv, lambda p: list(iter_encoder_chunks(p, chunk_rows=1))):
        with pytest.raises(LogFormatError, match=r"line 3, column 'dticks_left' is 1e\+20, "
                                                 "expected an integer count"):  # fmt: skip
            read(huge)
    empty = tmp_path / "empty.csv"
    empty.write_text("t,left_ticks,right_ticks\n0,1,1\n0.1,,2\n")
    with pytest.raises(LogFormatError, match=r"line 3, column 'left_ticks'"):
        list(iter_encoder_chunks(empty, chunk_rows=1))
    # old Mac line ends: the careful reader reads it, the chunked one says what to do
    mac = tmp_path / "mac.csv"
    mac.write_bytes(b"t,left_ticks,right_ticks\r0,1,1\r0.1,2,2\r")
    assert read_encoder_csv(mac).t.tolist() == [0.0, 0.1]
    with pytest.raises(LogFormatError, match=r"could not be read in chunks \(lines end in a "
                                             r"bare carriage return\).*read it whole"):  # fmt: skip
        list(iter_encoder_chunks(mac, chunk_rows=1))


def test_whole_csv_arrays_grow_when_the_first_block_was_wordy(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the whole-file reader sizes its arrays from the first block's bytes a row: long lines
    # first, then short ones, make that estimate short, and the arrays grow
    import odolab.io.tabular as tabular

    monkeypatch.setattr(tabular, "_CSV_BLOCK", 64)
    lines = ["t,left_ticks,right_ticks"]
    lines += [f"{i * 0.1:.15f},{1000000 + i},{2000000 + i}" for i in range(4)]
    lines += [f"{i},{i % 10},{i % 7}" for i in range(4, 300)]
    p = tmp_path / "log.csv"
    p.write_text("\n".join(lines) + "\n")
    got = read_columns(p, ["t", "left_ticks", "right_ticks"], integer=["left_ticks"])
    assert got["left_ticks"].dtype == np.int64 and got["right_ticks"].dtype == np.float64
    assert got["t"].size == 300 and got["left_ticks"][-1] == 299 % 10
    assert np.array_equal(got["t"][4:], np.arange(4, 300))


def test_numba_leaves_the_standard_streams_alone() -> None:
    # numba's coloured error messages go through colorama, which swaps sys.stderr while it
    # formats them and then puts back a stale stream; the kernels compile on a background thread
    # (odometry.warm_up), so that clobbered the stream a program (or a test) had set meanwhile
    import os
    import subprocess
    import sys

    code = "import odolab, numba.core.errors as e; print(type(e.termcolor()).__name__)"
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.stdout.strip() == "NOPColorScheme", out.stderr
