"""Where many runs are computed when the user says nothing (no scheduler, no --workers): in the
command's process below IN_PROCESS_BELOW runs (a local cluster's start would take longer than
they do); from there on the first PROBE_ITEMS are timed here, and a local Dask cluster takes the
rest only where all of them would take LOCAL_CLUSTER_PAYS_S or more here; the output says which
and why."""

from __future__ import annotations

import itertools
import re
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

from odolab.cli import main
from odolab.metrics.cluster import (
    DEFAULT_WORKERS,
    IN_PROCESS_BELOW,
    LOCAL_CLUSTER_PAYS_S,
    PROBE_ITEMS,
    Cluster,
    MapReport,
    map_outcomes,
)


@contextmanager
def _in_process_cluster(workers: int) -> Iterator[Any]:
    """An in-process Dask cluster standing for the local one, its web server on a free loopback
    port (``dashboard_address=None`` gives distributed's default, 8787 on every interface)."""
    from distributed import LocalCluster

    with LocalCluster(
        processes=False, n_workers=workers, threads_per_worker=1, dashboard_address="127.0.0.1:0"
    ) as local:
        yield local


def _timeless(where: str) -> str:
    """``where`` with its durations (the first items' times, the threshold) as T: what a test may
    assert of it on any machine (tests/determinism.py compares the numbers asserted)."""
    return re.sub(r"\d[\d.,e+-]* (?:ms|s)\b", "T", where)


def _square(x: int) -> int:
    return x * x


def test_the_default_runs_few_items_here_and_many_on_a_local_cluster() -> None:
    auto = Cluster()
    assert auto.here_for(1) and auto.here_for(IN_PROCESS_BELOW - 1)
    assert not auto.here_for(IN_PROCESS_BELOW)
    assert auto.chooses(2) and not auto.chooses(1)
    assert auto.where(3).startswith("this process (3 runs, fewer than 64")
    assert "{{workers}} 2 starts one" in auto.where(3)
    many = auto.where(IN_PROCESS_BELOW)  # until the first are timed (map_outcomes)
    assert many == (
        "this process or a local Dask cluster (64 runs, 64 or more: the first 8, timed here, "
        "decide)"
    )
    # what the user gave is kept, and then nothing is explained
    assert Cluster(workers=2).here_for(1) and not Cluster(workers=2).here_for(3)
    assert not Cluster(workers=2).chooses(3) and Cluster(workers=2).where(3).startswith("local")
    assert Cluster(workers=1).here_for(10**6) and Cluster(workers=1).where(9) == "this process"
    assert not Cluster(scheduler="tcp://127.0.0.1:1").here_for(1)


def test_few_items_are_computed_here_without_dask(monkeypatch: pytest.MonkeyPatch) -> None:
    import odolab.metrics.cluster as cl

    def no_dask(_cluster: Cluster) -> None:
        raise AssertionError("a local cluster was started for a few items")

    monkeypatch.setattr(cl, "_client", no_dask)
    outcomes = map_outcomes(_square, list(range(10)))
    assert [o.result for o in outcomes] == [x * x for x in range(10)]


def test_evaluate_says_where_it_chose_to_compute(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from odolab.fleet.dataset import FleetSpec, simulate_fleet

    simulate_fleet(
        tmp_path / "runs", FleetSpec(robots=1, days=1, runs_per_day=3, run_seconds=4.0, seed=3)
    )
    assert main(["evaluate", str(tmp_path / "runs"), "--format", "csv", "-p", "jaguar-lite"]) == 0
    out = capsys.readouterr().out
    assert "note: computed in this process (3 runs, fewer than 64" in out
    assert "--workers 2 starts one" in out


def test_many_quick_items_stay_here_after_the_first_are_timed(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import odolab.metrics.cluster as cl

    def no_dask(_cluster: Cluster) -> None:
        raise AssertionError("a local cluster was started for quick items")

    monkeypatch.setattr(cl, "_client", no_dask)
    report, seen = MapReport(""), []
    items = list(range(IN_PROCESS_BELOW + 36))
    outcomes = map_outcomes(
        _square, items, report=report, progress=lambda k, n, _: seen.append((k, n))
    )
    assert [o.result for o in outcomes] == [x * x for x in items]
    assert seen == [(k, len(items)) for k in range(1, len(items) + 1)]
    assert report.chosen and LOCAL_CLUSTER_PAYS_S == 30
    assert _timeless(report.where) == (
        "this process (100 runs: the first 8 took T each here (median), all of them about T, "
        "less than the T from which a local Dask cluster pays; {{workers}} 2 starts one)"
    )


def test_slow_items_go_to_a_local_cluster_after_the_first_are_timed(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import odolab.metrics.cluster as cl

    started: list[Cluster] = []

    class NoCluster(Exception):
        pass

    def cluster_started(cluster: Cluster) -> None:
        started.append(cluster)
        raise NoCluster  # (the cluster itself: tests/scale)

    monkeypatch.setattr(cl, "_client", cluster_started)
    monkeypatch.setattr(cl, "LOCAL_CLUSTER_PAYS_S", 0.0)  # every item is slow enough
    report, ran = MapReport(""), []

    def square_here(x: int) -> int:
        ran.append(x)
        return x * x

    with pytest.raises(NoCluster):
        map_outcomes(square_here, list(range(IN_PROCESS_BELOW)), report=report)
    assert ran == list(range(PROBE_ITEMS)) and len(started) == 1 and DEFAULT_WORKERS == 2
    assert _timeless(report.where) == (
        "local Dask cluster, 2 worker processes (64 runs: the first 8 took T each here (median), "
        "all of them about T, T or more; {{workers}} 1 keeps them in this process)"
    )


def test_the_rule_estimates_all_the_items_from_the_first() -> None:
    # the median item stands for all of them, not the first, which loads what a process loads once
    stay, why = Cluster().after_probe(1000, [2.0, 0.05, 0.04, 0.06, 0.05])  # 50 s
    assert not stay and "took 50 ms each here (median), all of them about 50.0 s" in why
    stay, why = Cluster().after_probe(1000, [2.0, 0.01, 0.01, 0.01])  # 10 s
    assert stay and "took 10 ms each here (median), all of them about 10.0 s" in why
    assert Cluster().after_probe(64, [0.25] * 8) == (
        True,
        "this process (64 runs: the first 8 took 0.25 s each here (median), all of them about "
        "16.0 s, less than the 30 s from which a local Dask cluster pays; {{workers}} 2 starts "
        "one)",
    )
    assert "all of them about 2,000 s" in Cluster().after_probe(2000, [1.0])[1]


def _square_or_refuse(x: int) -> int:
    if x == 3:
        raise ValueError("three is refused")
    return x * x


def test_the_cluster_takes_the_items_after_the_timed_ones_in_order(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The first items' outcomes (computed here) and the cluster's are one list, in order, and
    the progress counts on from the first items (an in-process Dask cluster stands for the
    local one: tests/scale start real ones)."""
    import odolab.metrics.cluster as cl

    @contextmanager
    def in_process(_cluster: Cluster):  # type: ignore[no-untyped-def]
        from distributed import Client

        with Client(
            processes=False, n_workers=2, threads_per_worker=1, dashboard_address="127.0.0.1:0"
        ) as client:
            yield client

    monkeypatch.setattr(cl, "_client", in_process)
    monkeypatch.setattr(cl, "LOCAL_CLUSTER_PAYS_S", 0.0)
    report, seen = MapReport(""), []
    items = list(range(70))
    out = map_outcomes(
        _square_or_refuse, items, report=report, progress=lambda k, n, _: seen.append((k, n))
    )
    assert [o.label for o in out] == [str(x) for x in items]
    assert [o.result for o in out if o.ok] == [x * x for x in items if x != 3]
    assert out[3].error == "3: ValueError: three is refused"
    assert seen[:PROBE_ITEMS] == [(k, 70) for k in range(1, PROBE_ITEMS + 1)]
    assert seen[-1] == (70, 70) and all(a[0] < b[0] for a, b in itertools.pairwise(seen))
    assert _timeless(report.where).startswith("local Dask cluster") and not report.lost_workers


def _refuse_the_first_four(x: int) -> int:
    if x < 4:
        raise ValueError("refused at once")
    time.sleep(0.05)
    return x


def test_items_refused_at_once_do_not_stand_for_the_others(monkeypatch: pytest.MonkeyPatch) -> None:
    """Of the first 8, 4 are refused in microseconds and 4 take 0.05 s: the median of all 8
    (about 0.025 s: 64 x 0.025 = 1.6 s) would keep 64 runs here against a 2 s threshold; the
    median of those that ran (0.05 s or more: 3.2 s) sends them to the cluster."""
    import odolab.metrics.cluster as cl

    class NoCluster(Exception):
        pass

    def cluster_started(_cluster: Cluster) -> None:
        raise NoCluster

    monkeypatch.setattr(cl, "_client", cluster_started)
    monkeypatch.setattr(cl, "LOCAL_CLUSTER_PAYS_S", 2.0)
    report = MapReport("")
    with pytest.raises(NoCluster):
        map_outcomes(_refuse_the_first_four, list(range(64)), report=report)
    assert _timeless(report.where) == (
        "local Dask cluster, 2 worker processes (64 runs: the first 8 took T each here (median "
        "of the 4 that ran), all of them about T, T or more; {{workers}} 1 keeps them in this "
        "process)"
    )


def test_parallel_map_hands_the_choice_to_its_caller_to_say() -> None:
    """calibrate lsq and compare read their runs through parallel_map: where odolab chose
    where they ran, the caller gets the note to print; where the user chose, nothing."""
    from odolab.metrics.runs import parallel_map

    where: list[str] = []
    assert parallel_map(_square, list(range(100)), where=where) == [x * x for x in range(100)]
    assert [_timeless(w) for w in where] == [
        "this process (100 runs: the first 8 took T each here (median), all of them about T, "
        "less than the T from which a local Dask cluster pays; {{workers}} 2 starts one)"
    ]
    said: list[str] = []
    parallel_map(_square, list(range(100)), workers=1, where=said)
    parallel_map(_square, [1, 2], where=said)
    assert said == [  # workers=1: the user's choice, unsaid; two runs: odolab's, said
        "this process (2 runs, fewer than 64: a local Dask cluster would take longer to start "
        "than they take; {{workers}} 2 starts one)"
    ]


def test_one_block_starts_one_local_cluster_for_all_its_maps(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """``calibrate lsq`` maps its fitted runs, then its held-out ones: inside
    one_local_cluster they share the cluster the first map started, which stops at the block's
    end; outside, each map starts and stops its own (an in-process Dask cluster stands for the
    local one, counted)."""
    import odolab.metrics.cluster as cl

    started: list[int] = []
    running: list[int] = []

    @contextmanager
    def counted(workers: int):  # type: ignore[no-untyped-def]
        started.append(workers)
        running.append(workers)
        with _in_process_cluster(workers) as local:
            yield local
        running.remove(workers)

    monkeypatch.setattr(cl, "local_cluster", counted)
    two = Cluster(workers=2)
    with cl.one_local_cluster():
        first = map_outcomes(_square, [1, 2, 3], cluster=two)
        here = map_outcomes(_square, [5, 6], cluster=Cluster(workers=1))  # no cluster at all
        second = map_outcomes(_square, [4, 5], cluster=two)
        assert started == [2] and running == [2]  # one start; still up between the maps
    assert running == []  # stopped with the block
    assert [o.result for o in first + here + second] == [1, 4, 9, 25, 36, 16, 25]
    map_outcomes(_square, [1, 2], cluster=two)
    map_outcomes(_square, [1, 2], cluster=two)
    assert started == [2, 2, 2] and running == []  # outside a block: one a map


def test_calibrate_lsq_files_starts_one_local_cluster(
    monkeypatch: pytest.MonkeyPatch, optiodom_dir: Path
) -> None:
    """The fitted runs and the held-out ones on the same local cluster (it started two)."""
    import odolab.metrics.cluster as cl
    from odolab.calibration.lsq import calibrate_lsq_files

    started: list[int] = []

    @contextmanager
    def counted(workers: int):  # type: ignore[no-untyped-def]
        started.append(workers)
        with _in_process_cluster(workers) as local:
            yield local

    monkeypatch.setattr(cl, "local_cluster", counted)
    square = sorted((optiodom_dir / "square").iterdir())[:3]
    held = sorted((optiodom_dir / "circular").iterdir())[:2]
    cal = calibrate_lsq_files(square, "optiodom", validate=held, workers=2)
    assert cal.runs and len(cal.validation) >= 2  # both maps ran (runs are the logs' segments)
    assert started == [2]
