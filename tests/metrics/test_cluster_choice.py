"""Where many runs are computed when the user says nothing (no scheduler, no --workers): in the
command's process below IN_PROCESS_BELOW runs (a local cluster's start would take longer than
they do), a local Dask cluster from there on; the output says which and why."""

from __future__ import annotations

from pathlib import Path

import pytest

from odolab.cli import main
from odolab.metrics.cluster import DEFAULT_WORKERS, IN_PROCESS_BELOW, Cluster, map_outcomes


def _square(x: int) -> int:
    return x * x


def test_the_default_runs_few_items_here_and_many_on_a_local_cluster() -> None:
    auto = Cluster()
    assert auto.here_for(1) and auto.here_for(IN_PROCESS_BELOW - 1)
    assert not auto.here_for(IN_PROCESS_BELOW)
    assert auto.chooses(2) and not auto.chooses(1)
    assert auto.where(3).startswith("this process (3 runs, fewer than 64")
    assert "{{workers}} 2 starts one" in auto.where(3)
    many = auto.where(IN_PROCESS_BELOW)
    assert many.startswith(f"local Dask cluster, {DEFAULT_WORKERS} worker processes (64 runs")
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
