"""The chunked writer (odolab.io.tabular.ChunkWriter): chunks written on a thread while the next
is integrated give the single-pass file; Parquet row groups of the right size, without
dictionaries, with statistics; a failure inside the writer thread reaches the user as one
sentence and leaves an existing output as it was; Parquet in and out loads neither polars nor
pandas."""

from __future__ import annotations

import errno
import json
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import numpy as np
import pytest

import odolab.io.tabular as tabular
from odolab.cli import main
from odolab.core.trials import EncoderLog
from odolab.io import read_trajectory, write_encoder_csv

ROWS = 600


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """One encoder log (counters wrapping at 15 bits) in each format."""
    rng = np.random.default_rng(42)
    left = (np.cumsum(rng.integers(-20, 60, ROWS)) + 5) % 32768
    right = (np.cumsum(rng.integers(-20, 60, ROWS)) + 9) % 32768
    log = EncoderLog(np.arange(ROWS) * 0.01, left, right, None)
    d = tmp_path_factory.mktemp("logs")
    return {s: write_encoder_csv(d / f"log{s}", log) for s in (".csv", ".parquet", ".arrow")}


def _odometry(log: Path, out: Path, chunk_rows: int) -> int:
    return main(["odometry", str(log), "-p", "jaguar-lite", "-o", str(out),
                 "--chunk-rows", str(chunk_rows)])  # fmt: skip


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".arrow"])
def test_threaded_chunks_equal_the_single_pass(
    logs: dict[str, Path], tmp_path: Path, suffix: str
) -> None:
    whole = tmp_path / f"whole{suffix}"
    assert _odometry(logs[suffix], whole, 0) == 0
    expected = read_trajectory(whole)
    for size in (7, 250, ROWS):
        out = tmp_path / f"chunks{size}{suffix}"
        assert _odometry(logs[suffix], out, size) == 0
        if suffix == ".csv":  # the same text, byte for byte
            assert out.read_bytes() == whole.read_bytes(), size
        got = read_trajectory(out)
        for name in ("t", "x", "y", "theta", "heading"):
            assert np.array_equal(getattr(got, name), getattr(expected, name)), (size, name)


def test_parquet_row_groups_of_the_right_size_without_dictionaries(
    logs: dict[str, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import pyarrow.parquet as pq

    monkeypatch.setattr(tabular, "ROW_GROUP_MIN_ROWS", 100)
    monkeypatch.setattr(tabular, "ROW_GROUP_MAX_ROWS", 160)
    expected = {
        7: [105] * 5 + [75],  # small chunks gathered until a group holds 100 rows
        250: [160, 90] * 2 + [100],  # a bigger chunk cut into groups of at most 160
        1000: [160] * 3 + [120],  # (the whole log as one chunk)
    }
    for size, groups in expected.items():
        out = tmp_path / f"c{size}.parquet"
        assert _odometry(logs[".parquet"], out, size) == 0
        meta = pq.ParquetFile(out).metadata
        got = [meta.row_group(k).num_rows for k in range(meta.num_row_groups)]
        assert got == groups, size
        for k in range(meta.num_row_groups):
            for c in range(meta.num_columns):
                col = meta.row_group(k).column(c)
                assert not any("DICT" in e for e in col.encodings), (size, k, col.encodings)
                assert col.is_stats_set and col.statistics.has_min_max, (size, k, c)


@pytest.mark.parametrize(
    ("suffix", "fails_at"),
    [(".csv", 2), (".csv", 5), (".parquet", 3), (".arrow", 1)],
)
def test_a_failure_in_the_writer_thread_is_one_sentence_and_keeps_the_output(
    logs: dict[str, Path],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    suffix: str,
    fails_at: int,
) -> None:
    """A full disk on the writer thread: at a middle chunk (raised at the next chunk handed
    over) or at the last one (raised when the file closes)."""
    out = tmp_path / f"traj{suffix}"
    out.write_bytes(b"the previous trajectory\n")
    before = sorted(p.name for p in tmp_path.iterdir())
    # CSV: each chunk a polars frame (5 chunks of 120 rows); Parquet/IPC: each column of a row
    # group (row groups of 100 rows; call 3 is the first group's third column)
    name = "_frame" if suffix == ".csv" else "_arrow_array"
    real = getattr(tabular, name)
    calls: list[str] = []

    def failing(*args: object) -> object:
        calls.append(threading.current_thread().name)
        if len(calls) == fails_at:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(*args)

    monkeypatch.setattr(tabular, name, failing)
    monkeypatch.setattr(tabular, "ROW_GROUP_MIN_ROWS", 100)
    assert _odometry(logs[suffix], out, 120) == 1
    err = capsys.readouterr().err.strip()
    assert err == (
        f"odolab: error: {out}: cannot write the trajectory (No space left on device); "
        "expected a file name in a writable folder"
    )
    assert calls[fails_at - 1] == "odolab-write"  # it failed inside the writer thread
    assert len(calls) == fails_at  # and nothing was written after it
    assert out.read_bytes() == b"the previous trajectory\n"  # the output as it was
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no partial file left


_IMPORTS = textwrap.dedent(
    """
    import json, sys
    from odolab.cli import main
    found = {}
    for name, args in json.loads(sys.argv[1]).items():
        code = main(args)
        found[name] = [code, sorted(m for m in ("polars", "pandas", "numba") if m in sys.modules)]
    print(json.dumps(found))
    """
)


def test_parquet_odometry_loads_neither_polars_nor_pandas(
    logs: dict[str, Path], tmp_path: Path
) -> None:
    """pyarrow reads and writes Parquet alone (`pa.array` of a numpy array imported pandas);
    chunks shorter than the compiled kernels' threshold load no numba either."""
    log = str(logs[".parquet"])
    commands = {
        "whole": ["odometry", log, "-o", str(tmp_path / "w.parquet"), "--chunk-rows", "0"],
        "chunks": ["odometry", log, "-o", str(tmp_path / "c.parquet"), "--chunk-rows", "50"],
        "IPC out": ["odometry", log, "-o", str(tmp_path / "c.arrow"), "--chunk-rows", "50"],
    }
    proc = subprocess.run(
        [sys.executable, "-c", _IMPORTS, json.dumps(commands)],
        capture_output=True, text=True, check=True, timeout=120,
    )  # fmt: skip
    found = json.loads(proc.stdout.splitlines()[-1])
    assert found == {name: [0, []] for name in commands}, found


def test_a_failed_output_leaves_no_writer_thread_running(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A row group fails on the writer thread, a smaller chunk is gathered after it: the close
    hands the gathered chunk over (raising the earlier error) and still ends the thread."""
    monkeypatch.setattr(tabular, "ROW_GROUP_MIN_ROWS", 10)
    real = tabular._arrow_array
    calls: list[int] = []

    def failing(*args: object) -> object:
        calls.append(1)
        if len(calls) == 1:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(*args)

    monkeypatch.setattr(tabular, "_arrow_array", failing)
    before = {t for t in threading.enumerate() if t.name == "odolab-write"}
    with (
        pytest.raises(tabular.LogFormatError, match="No space left on device"),
        tabular.ChunkWriter(tmp_path / "out.parquet") as writer,
    ):
        writer.write({"x": np.arange(10.0)})  # a full row group: fails on the thread
        writer.write({"x": np.arange(3.0)})  # gathered; handed over at the close
    left = {t for t in threading.enumerate() if t.name == "odolab-write"} - before
    assert not [t for t in left if t.is_alive()]
