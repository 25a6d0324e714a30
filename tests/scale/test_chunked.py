"""Chunked odometry equals the whole-log run, rollover at a chunk boundary included."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from typer.testing import CliRunner

from odolab.cli import app
from odolab.core.errors import EncoderJumpError, LogFormatError
from odolab.core.odometry import integrate
from odolab.core.params import PRESETS
from odolab.core.trials import EncoderLog
from odolab.io import read_trajectory, write_encoder_csv
from odolab.io.chunked import ChunkedOdometry, integrate_file, iter_encoder_chunks

MOD = 1024


def _params():  # type: ignore[no-untyped-def]
    from dataclasses import replace

    return replace(PRESETS["jaguar-lite"], encoder_modulus=MOD)


def _log(steps_l: list[int], steps_r: list[int], wrap_at: int) -> tuple[np.ndarray, ...]:
    """Counters that wrap forward between samples ``wrap_at - 1`` and ``wrap_at``."""
    n = len(steps_l) + 1
    left = np.concatenate(([0], np.cumsum(steps_l))).astype(np.int64)
    right = np.concatenate(([0], np.cumsum(steps_r))).astype(np.int64)
    # shift the left counter so that it crosses MOD exactly at wrap_at (when it moves forward)
    shift = MOD - 1 - int(left[wrap_at - 1])
    left = np.mod(left + shift, MOD)
    right = np.mod(right + 7, MOD)
    t = np.arange(n) * 0.05
    return t, left, right


def _chunked(t, left, right, params, size, start=None):  # type: ignore[no-untyped-def]
    odo = ChunkedOdometry(params, "arc", start=start)
    parts = [odo.feed(t[k : k + size], left[k : k + size], right[k : k + size])
             for k in range(0, len(t), size)]  # fmt: skip
    return {c: np.concatenate([getattr(p, c) for p in parts]) for c in
            ("t", "x", "y", "theta", "heading")}  # fmt: skip


@given(
    steps=st.lists(st.tuples(st.integers(1, 200), st.integers(-200, 200)), min_size=2, max_size=40),
    data=st.data(),
)
def test_chunked_equals_whole_for_every_chunk_size(steps, data) -> None:  # type: ignore[no-untyped-def]
    params = _params()
    sl = [a for a, _ in steps]
    sr = [b for _, b in steps]
    n = len(steps) + 1
    wrap_at = data.draw(st.integers(1, n - 1))
    t, left, right = _log(sl, sr, wrap_at)
    assert left[wrap_at] < left[wrap_at - 1]  # the counter rolls over there
    start = (0.5, -1.0, 20.0)  # an unwrapped heading that must continue across chunks
    whole = integrate(t, left, right, params, "arc", start=start)
    for size in range(1, n + 1):  # every size, so the rollover falls on a boundary for some
        got = _chunked(t, left, right, params, size, start)
        for c in ("t", "x", "y", "theta", "heading"):
            np.testing.assert_allclose(got[c], getattr(whole, c), rtol=0, atol=1e-9)


def test_rollover_exactly_at_a_boundary_and_heading_beyond_pi() -> None:
    params = _params()
    # turn on the spot for many turns: heading passes pi many times, counters wrap often
    n = 4001
    left = np.mod(1000 - 37 * np.arange(n), MOD)
    right = np.mod(5 + 37 * np.arange(n), MOD)
    t = np.arange(n) * 0.01
    whole = integrate(t, left, right, params)
    assert whole.heading[-1] > 4 * np.pi
    boundary = int(np.argmax(np.diff(right) < 0)) + 1  # first wrap of the right counter
    odo = ChunkedOdometry(params)
    a = odo.feed(t[:boundary], left[:boundary], right[:boundary])
    b = odo.feed(t[boundary:], left[boundary:], right[boundary:])
    assert b.heading[0] > a.heading[-1]  # continued, not restarted at the wrapped theta
    np.testing.assert_allclose(np.concatenate((a.x, b.x)), whole.x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.concatenate((a.heading, b.heading)), whole.heading, atol=1e-9)


def test_jump_error_names_the_global_sample() -> None:
    params = _params()
    left = np.array([0, 10, 20, 30, 300, 310], dtype=np.int64)  # 270 > 1024/4
    right = np.arange(6, dtype=np.int64) * 10
    t = np.arange(6) * 0.1
    odo = ChunkedOdometry(params, source="log.csv")
    odo.feed(t[:3], left[:3], right[:3])
    with pytest.raises(
        EncoderJumpError, match=r"log\.csv: left_ticks jumps by 270 counts between samples 3 and 4"
    ):
        odo.feed(t[3:], left[3:], right[3:])


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".arrow"])
def test_file_in_chunks_equals_whole_file(tmp_path: Path, suffix: str) -> None:
    params = _params()
    rng = np.random.default_rng(5)
    n = 1000
    left = np.mod(np.cumsum(rng.integers(-20, 60, n)) + 900, MOD)
    right = np.mod(np.cumsum(rng.integers(-20, 60, n)), MOD)
    t = np.arange(n) * 0.05
    log = write_encoder_csv(tmp_path / f"log{suffix}", EncoderLog(t, left, right, MOD))
    whole = integrate(t, left, right, params)
    out = tmp_path / f"traj{suffix}"
    res = integrate_file(log, out, params, chunk_rows=10)  # the log is 100x the chunk
    assert res.rows == n and res.chunks == 100
    got = read_trajectory(out)
    np.testing.assert_allclose(got.x, whole.x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(got.heading, whole.heading, rtol=0, atol=1e-9)


def test_chunked_reader_names_the_line_across_chunks(tmp_path: Path) -> None:
    p = tmp_path / "log.csv"
    p.write_text("t,left_ticks,right_ticks\n0,1,1\n0.1,2,2\n\n0.2,3,3\n0.15,4,4\n")
    with pytest.raises(LogFormatError, match=r"log\.csv: time goes backwards at line 6"):
        list(iter_encoder_chunks(p, chunk_rows=3))
    q = tmp_path / "frac.csv"
    q.write_text("t,left_ticks,right_ticks\n0,1,1\n0.1,2,2\n0.2,3.5,3\n")
    with pytest.raises(LogFormatError, match=r"line 4, column 'left_ticks' is 3.5"):
        list(iter_encoder_chunks(q, chunk_rows=2))
    r = tmp_path / "text.csv"
    r.write_text("t,left_ticks,right_ticks\n0,1,1\n0.1,2,2\n0.2,abc,3\n")
    with pytest.raises(LogFormatError, match=r"line 4, column 'left_ticks' is 'abc'"):
        list(iter_encoder_chunks(r, chunk_rows=2))


def test_increments_carry_across_chunks(tmp_path: Path) -> None:
    p = tmp_path / "inc.csv"
    p.write_text("t,dticks_left,dticks_right\n0,5,5\n0.1,2,3\n0.2,4,-1\n0.3,1,1\n")
    chunks = list(iter_encoder_chunks(p, chunk_rows=2))
    assert np.concatenate([c.left for c in chunks]).tolist() == [0, 2, 6, 7]
    assert np.concatenate([c.right for c in chunks]).tolist() == [0, 3, 2, 3]


def test_cli_odometry_chunked_equals_whole_and_keeps_output_on_error(tmp_path: Path) -> None:
    params = _params()
    n = 500
    left = np.mod(np.arange(n) * 13 + 1000, MOD)
    right = np.mod(np.arange(n) * 11, MOD)
    t = np.arange(n) * 0.05
    log = write_encoder_csv(tmp_path / "log.csv", EncoderLog(t, left, right, MOD))
    toml = tmp_path / "p.toml"
    from odolab.core.params import save_params

    save_params(toml, params)
    runner = CliRunner()
    r1 = runner.invoke(app, ["odometry", str(log), "-p", str(toml), "-o", str(tmp_path / "w.csv"),
                             "--chunk-rows", "0"])  # fmt: skip
    r2 = runner.invoke(app, ["odometry", str(log), "-p", str(toml), "-o",
                             str(tmp_path / "c.parquet"), "--chunk-rows", "7"])  # fmt: skip
    assert r1.exit_code == 0 and r2.exit_code == 0, r1.output + r2.output
    a, b = read_trajectory(tmp_path / "w.csv"), read_trajectory(tmp_path / "c.parquet")
    np.testing.assert_allclose(a.x, b.x, rtol=0, atol=1e-9)
    assert r1.output.split("->")[1].split(";")[1] == r2.output.split("->")[1].split(";")[1]
    bad = tmp_path / "bad.csv"
    bad.write_text("t,left_ticks,right_ticks\n0,1,1\n0.1,2,2\n0.2,x,3\n")
    before = (tmp_path / "c.parquet").read_bytes()
    r3 = runner.invoke(app, ["odometry", str(bad), "-p", str(toml), "-o",
                             str(tmp_path / "c.parquet"), "--chunk-rows", "1"])  # fmt: skip
    assert r3.exit_code == 1
    assert "line 4, column 'left_ticks' is 'x'" in str(r3.exception)
    assert (tmp_path / "c.parquet").read_bytes() == before  # nothing already written is lost


def test_read_ahead_keeps_the_order_raises_where_the_reader_failed_and_stops_early() -> None:
    import threading

    from odolab.io.chunked import prefetched

    assert list(prefetched(iter(range(50)), depth=3)) == list(range(50))
    assert list(prefetched([])) == []

    def failing():  # type: ignore[no-untyped-def]
        yield 1
        yield 2
        raise LogFormatError("log.csv, line 7: not a number")

    got = []
    with pytest.raises(LogFormatError, match="line 7"):
        for item in prefetched(failing()):
            got.append(item)
    assert got == [1, 2]  # everything read before the error is handed out first

    read = []

    def endless():  # type: ignore[no-untyped-def]
        i = 0
        while True:
            read.append(i)
            yield i
            i += 1

    for item in prefetched(endless()):
        if item == 5:
            break
    assert max(read) <= 7  # the reader stops after the item it was reading
    assert not [t for t in threading.enumerate() if t.name == "odolab-read-ahead"]
