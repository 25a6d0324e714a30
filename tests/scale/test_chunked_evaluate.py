"""`odolab evaluate GT EST --chunk-rows N` equals the whole-file evaluation for every chunk size,
keeps its memory bounded by the chunk, and refuses bad input in one sentence."""

from __future__ import annotations

import json
import math
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from typer.testing import CliRunner

from odolab.cli import app, main
from odolab.core.errors import InsufficientDataError, LogFormatError
from odolab.core.trajectory import Trajectory
from odolab.io import read_trajectory, write_trajectory_csv, write_tum
from odolab.io.chunked import iter_trajectory_chunks
from odolab.metrics import (
    ANGLE_UNITS,
    Alignment,
    DeltaUnit,
    ErrorStats,
    EvaluationOptions,
    SyncMethod,
    evaluate,
    evaluate_files,
    exact_median_from_file,
    stats_from_errors,
)


def _traj(rng: np.random.Generator, n: int, dt: float, t0: float, noise: float) -> Trajectory:
    """A wandering path (heading beyond pi) with uneven stamps."""
    t = t0 + np.cumsum(rng.uniform(0.5, 1.5, n)) * dt
    h = np.cumsum(rng.normal(0.2, 0.6, n))
    x = np.cumsum(np.cos(h) * 0.3) + rng.normal(0.0, noise, n)
    y = np.cumsum(np.sin(h) * 0.3) + rng.normal(0.0, noise, n)
    return Trajectory.from_xyh(t, x, y, h)


def _numbers(doc: object, prefix: str = "") -> dict[str, float]:
    out: dict[str, float] = {}
    if isinstance(doc, dict):
        for k, v in doc.items():
            out.update(_numbers(v, f"{prefix}.{k}"))
    elif isinstance(doc, int | float) and not isinstance(doc, bool):
        out[prefix] = float(doc)
    return out


def _assert_same(whole: dict[str, float], got: dict[str, float]) -> None:
    assert whole.keys() == got.keys()
    for k, w in whole.items():
        g = got[k]
        assert (math.isnan(w) and math.isnan(g)) or abs(w - g) <= 1e-9, (k, w, g)


def _outcome(f: object) -> dict[str, float] | str:
    try:
        return _numbers(f().to_dict())  # type: ignore[operator]
    except (LogFormatError, InsufficientDataError) as err:
        return f"{type(err).__name__}: {err}"


def _write_pair(
    folder: Path, ref: Trajectory, est: Trajectory, ref_kind: str, est_kind: str
) -> tuple[Path, Path]:
    import polars as pl

    if ref_kind == "theta.csv":  # no heading column: unwrapped across the chunks
        a = folder / "gt.csv"
        pl.DataFrame({"t": ref.t, "x": ref.x, "y": ref.y, "theta": ref.theta}).write_csv(a)
    else:
        a = write_trajectory_csv(folder / f"gt.{ref_kind}", ref)
    b = write_tum(folder / "est.tum", est) if est_kind == "tum" else (
        write_trajectory_csv(folder / f"est.{est_kind}", est)
    )  # fmt: skip
    return a, b


@given(
    seed=st.integers(0, 2**32 - 1),
    n_ref=st.integers(2, 40),
    n_est=st.integers(2, 40),
    alignment=st.sampled_from(list(Alignment)),
    sync=st.sampled_from(list(SyncMethod)),
    unit=st.sampled_from(list(DeltaUnit)),
    all_pairs=st.booleans(),
    from_reference=st.booleans(),
    max_diff=st.sampled_from([0.0, 0.03, 0.5]),
    offset=st.sampled_from([0.0, 0.1, -0.25]),
    kinds=st.sampled_from(
        [("csv", "parquet"), ("theta.csv", "arrow"), ("parquet", "tum"), ("theta.csv", "csv")]
    ),
    coarse_stamps=st.booleans(),
)
def test_chunked_evaluation_equals_whole_for_every_chunk_size(
    tmp_path_factory: pytest.TempPathFactory,
    seed: int,
    n_ref: int,
    n_est: int,
    alignment: Alignment,
    sync: SyncMethod,
    unit: DeltaUnit,
    all_pairs: bool,
    from_reference: bool,
    max_diff: float,
    offset: float,
    kinds: tuple[str, str],
    coarse_stamps: bool,
) -> None:
    rng = np.random.default_rng(seed)
    ref = _traj(rng, n_ref, 0.1, 0.0, 0.0)
    est = _traj(rng, n_est, 0.07, float(rng.uniform(-0.3, 0.3)), 0.05)
    if coarse_stamps:  # repeated stamps: ties in the nearest-stamp search
        est = Trajectory.from_xyh(np.round(est.t, 1), est.x, est.y, est.heading)
    a, b = _write_pair(tmp_path_factory.mktemp("ev"), ref, est, *kinds)
    o = EvaluationOptions(
        delta=2.0 if unit is DeltaUnit.FRAMES else 0.5,
        delta_unit=unit,
        all_pairs=all_pairs,
        pairs_from_reference=from_reference,
        sync=sync,
        max_diff=max_diff,
        offset=offset,
        alignment=alignment,
        drift_delta_m=0.7,
    )
    names = (str(a), str(b))
    if all_pairs and unit in ANGLE_UNITS:  # every pose against every later one: whole only
        with pytest.raises(InsufficientDataError, match="needs both trajectories whole"):
            evaluate_files(a, b, o, chunk_rows=n_ref)
        return
    whole = _outcome(lambda: evaluate(read_trajectory(a), read_trajectory(b), o, names=names))
    for size in range(1, max(n_ref, n_est) + 1):  # every size: each boundary falls everywhere
        got = _outcome(lambda size=size: evaluate_files(a, b, o, chunk_rows=size))
        if isinstance(whole, str) or isinstance(got, str):
            assert got == whole  # the same sentence
        else:
            _assert_same(whole, got)


def test_long_runs_at_different_rates_equal_whole(tmp_path: Path) -> None:
    """A 100 Hz estimate against a 10 Hz reference (the walk keeps few of the dense poses), and
    the reverse, with SE(2) alignment and pairs by path length."""
    rng = np.random.default_rng(7)
    dense = _traj(rng, 3000, 0.01, 0.0, 0.01)
    sparse = _traj(rng, 300, 0.1, 0.003, 0.0)
    for ref, est in ((sparse, dense), (dense, sparse)):
        a = write_trajectory_csv(tmp_path / "gt.parquet", ref)
        b = write_trajectory_csv(tmp_path / "est.csv", est)
        for o in (
            EvaluationOptions(alignment=Alignment.SE2, max_diff=0.01),
            EvaluationOptions(
                sync=SyncMethod.INTERPOLATE,
                delta=1.0,
                delta_unit=DeltaUnit.METRES,
                all_pairs=True,
                alignment=Alignment.ORIGIN,
            ),
        ):
            whole = _numbers(evaluate(read_trajectory(a), read_trajectory(b), o).to_dict())
            for size in (1, 17, 299, 1000, 5000):
                _assert_same(whole, _numbers(evaluate_files(a, b, o, chunk_rows=size).to_dict()))


@given(
    values=st.lists(
        st.one_of(
            st.floats(allow_nan=False, allow_infinity=False, width=64),
            st.sampled_from([0.0, -0.0, 1.5, 1.5, 2.0]),
        ),
        min_size=1,
        max_size=60,
    ),
    block=st.integers(1, 70),
)
def test_median_from_file_is_numpy_median(
    tmp_path_factory: pytest.TempPathFactory, values: list[float], block: int
) -> None:
    a = np.array(values)
    f = tmp_path_factory.mktemp("med") / "v.bin"
    a.tofile(f)
    with f.open("rb") as fh:
        got = exact_median_from_file(fh, a.size, block=block)
    want = float(np.median(a))
    assert got == want or (math.isinf(want) and got == want) or abs(got - want) == 0.0


def test_error_stats_equal_stats_from_errors() -> None:
    rng = np.random.default_rng(3)
    e = np.abs(rng.normal(1e3, 0.5, 10_001))  # far from 0: the merged moments keep the std
    with ErrorStats("APE", block=100) as acc:
        for part in np.array_split(e, 37):
            acc.add(part)
        got = acc.stats()
    want = stats_from_errors(e, "APE")
    assert got.median == want.median and got.min == want.min and got.max == want.max
    for name in ("rmse", "mean", "std"):
        assert getattr(got, name) == pytest.approx(getattr(want, name), rel=0, abs=1e-9)


def test_memory_is_bounded_by_the_chunk(tmp_path: Path) -> None:
    """The peak of numpy's allocations does not grow with the files (20x the chunk and 200x)
    beyond the readers' and the median's fixed blocks (65,536 rows or values)."""
    rng = np.random.default_rng(11)
    # chunks of 1,000 rows: the files of 20,000 and 200,000 rows are 20 and 200 chunks. With
    # chunks of 200 (1,000 chunks) it took 10.4 s of CPU under tracemalloc against 2.8 s, for the
    # same peaks (3.78 MB at 200,000 rows, the readers' blocks); what a chunk could leak and pass
    # grows with the chunk: about 7.8 kB a chunk here (the bound's 1.5 MB of room over 200 chunks)
    chunk = 1000
    peaks = []
    o = EvaluationOptions(
        sync=SyncMethod.INTERPOLATE, delta=1.0, delta_unit=DeltaUnit.METRES, all_pairs=True
    )
    evaluate_files(*_write_pair(tmp_path, *(_traj(rng, 50, 0.01, 0.0, 0.0),) * 2, "csv", "csv"))
    for n in (20 * chunk, 200 * chunk):
        ref = _traj(rng, n, 0.01, 0.0, 0.0)
        est = _traj(rng, n + 3, 0.01, 0.002, 0.01)
        a, b = _write_pair(tmp_path, ref, est, "parquet", "csv")
        del ref, est
        tracemalloc.start()
        try:
            ev = evaluate_files(a, b, o, chunk_rows=chunk)
            peaks.append(tracemalloc.get_traced_memory()[1])
        finally:
            tracemalloc.stop()
        assert ev.pairs > n // 2
    whole_inputs = 200 * chunk * 5 * 8 * 2  # the two trajectories' arrays, read whole
    assert peaks[1] < 1.5 * peaks[0] + (4 << 20), peaks  # flat as the files grow 10x
    # measured 2.1-2.6 and 3.78 MB (chunks of 200 to 2,000 alike at 200,000 rows; the readers'
    # fixed blocks); bound 5.3 MB, a third of the 16 MB of the two files' arrays read whole (it
    # was a quarter, 4.0 MB: 5 % of room, which a reader's new block size could take)
    assert peaks[1] < whole_inputs / 3, peaks


def test_trajectory_chunks_unwrap_the_heading_across_chunks(tmp_path: Path) -> None:
    p = tmp_path / "spin.csv"
    theta = np.angle(np.exp(1j * 0.9 * np.arange(50)))  # wraps every few rows
    p.write_text(
        "t,x,y,theta\n" + "".join(f"{i * 0.1!r},0,0,{float(th)!r}\n" for i, th in enumerate(theta))
    )
    whole = read_trajectory(p)
    for size in (1, 3, 49):
        got = np.concatenate([c.heading for c in iter_trajectory_chunks(p, chunk_rows=size)])
        np.testing.assert_allclose(got, whole.heading, rtol=0, atol=1e-9)
    assert whole.heading[-1] > 40


def test_bad_input_is_one_sentence(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    gt = tmp_path / "gt.csv"
    gt.write_text("t,x,y,theta\n0,0,0,0\n0.1,1,0,0\n0.2,2,0,0\n0.15,3,0,0\n")
    est = tmp_path / "est.csv"
    est.write_text("t,x,y,theta\n0,0,0,0\n0.1,1,0,0\n0.2,2,0,0\n0.3,3,0,0\n")

    def fails(*args: str) -> str:
        capsys.readouterr()
        assert main(["evaluate", *args]) == 1
        err = capsys.readouterr().err
        assert err.startswith("odolab: error: ") and err.count("\n") == 1, err
        return err

    err = fails(str(gt), str(est), "--chunk-rows", "2")  # the bad line is in the second chunk
    assert f"{gt}: time goes backwards at line 5 (0.15 after 0.2)" in err
    assert "--chunk-rows is -1" in fails(str(est), str(est), "--chunk-rows", "-1")
    assert "runs (--format) are read whole" in fails(
        str(tmp_path), "--format", "csv", "--chunk-rows", "5"
    )
    far = tmp_path / "far.parquet"
    write_trajectory_csv(far, Trajectory.from_xyh([100.0, 101.0], [0, 1], [0, 0], [0, 0]))
    assert "do not overlap in time" in fails(str(est), str(far), "--chunk-rows", "1")
    text = tmp_path / "text.csv"
    text.write_text("t,x,y,theta\n0,0,0,0\n0.1,1,0,0\n0.2,abc,0,0\n")
    assert f"{text}: line 4, column 'x' is 'abc'" in fails(str(est), str(text), "--chunk-rows", "1")


def test_cli_chunked_equals_whole_and_shows_the_same_table(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    a, b = _write_pair(
        tmp_path,
        _traj(rng, 200, 0.05, 0.0, 0.0),
        _traj(rng, 150, 0.07, 0.01, 0.02),
        "csv",
        "parquet",
    )
    runner = CliRunner()
    args = ["evaluate", str(a), str(b), "--align", "se2", "--sync", "interpolate"]
    r0 = runner.invoke(app, [*args, "--chunk-rows", "0", "--json", str(tmp_path / "w.json")])
    r1 = runner.invoke(app, [*args, "--chunk-rows", "7", "--json", str(tmp_path / "c.json")])
    assert r0.exit_code == 0 and r1.exit_code == 0, r0.output + r1.output
    whole = json.loads((tmp_path / "w.json").read_text())
    got = json.loads((tmp_path / "c.json").read_text())
    _assert_same(_numbers(whole), _numbers(got))
    assert r0.output == r1.output


@given(
    blocks=st.lists(st.integers(0, 9), max_size=12),
    chunk=st.integers(1, 12),
)
def test_blocks_regrouped_into_chunks_of_exactly_the_chunk_size(
    blocks: list[int], chunk: int
) -> None:
    from odolab.io.tabular import _rechunk

    start = np.cumsum([0, *blocks])
    parts = [
        {"a": np.arange(s, s + n, dtype=np.float64), "b": -np.arange(s, s + n, dtype=np.float64)}
        for s, n in zip(start, blocks, strict=False)
    ]
    got = list(_rechunk(iter(parts), ("a", "b"), chunk))
    sizes = [len(c["a"]) for c in got]
    assert all(n == chunk for n in sizes[:-1]) and (not sizes or 0 < sizes[-1] <= chunk)
    whole = np.arange(sum(blocks), dtype=np.float64)
    for col, sign in (("a", 1.0), ("b", -1.0)):
        joined = np.concatenate([c[col] for c in got]) if got else np.zeros(0)
        np.testing.assert_array_equal(joined, sign * whole)


def test_a_chunk_of_equal_stamps_is_not_a_file_whose_time_stands_still(tmp_path: Path) -> None:
    """Coarse stamps repeat: a chunk holding only repeats is fine when the file's time advances
    (the chunked reader refused it, the whole reader did not); a file whose every time is the
    same is refused by both, with one sentence."""
    p = tmp_path / "coarse.csv"
    p.write_text("t,x,y,theta\n0.0,0,0,0\n0.1,1,0,0\n0.1,2,0,0\n0.2,3,0,0\n")
    whole = read_trajectory(p)
    for size in (1, 2, 3):
        got = np.concatenate([c.x for c in iter_trajectory_chunks(p, chunk_rows=size)])
        np.testing.assert_array_equal(got, whole.x)
    still = tmp_path / "still.csv"
    still.write_text("t,x,y,theta\n0.3,0,0,0\n0.3,1,0,0\n0.3,2,0,0\n")
    with pytest.raises(LogFormatError, match="expected times that advance") as whole_err:
        read_trajectory(still)
    for size in (1, 2):
        with pytest.raises(LogFormatError, match="expected times that advance") as err:
            list(iter_trajectory_chunks(still, chunk_rows=size))
        assert str(err.value) == str(whole_err.value)


def test_a_position_only_truth_is_read_whole_by_the_chunked_reader(tmp_path: Path) -> None:
    """``t,x,y`` (odolab track-photo's ground truth): its heading is the whole path's tangent, so
    the chunked reader gives it as one chunk, the whole reader's poses (it raised KeyError)."""
    p = tmp_path / "photo_gt.csv"
    p.write_text(
        "t,x,y\n" + "".join(f"{0.1 * i!r},{0.05 * i!r},{0.01 * i * i!r}\n" for i in range(30))
    )
    chunks = list(iter_trajectory_chunks(p, chunk_rows=4))
    whole = read_trajectory(p)
    assert len(chunks) == 1
    np.testing.assert_array_equal(chunks[0].heading, whole.heading)
