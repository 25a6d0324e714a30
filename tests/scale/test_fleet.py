"""Fleets: the simulated data set, the fleet table and summary, runs on a Dask cluster."""

from __future__ import annotations

import json
import math
import os
import signal
from pathlib import Path

import numpy as np
import pytest

from odolab.cli import main
from odolab.core.params import PRESETS
from odolab.fleet import FleetSpec, fleet_rows, robot_and_date, simulate_fleet, summarize
from odolab.fleet.table import COLUMNS, read_fleet_table
from odolab.io.run import ReadOptions
from odolab.metrics import evaluate
from odolab.metrics.cluster import Cluster, MapReport
from odolab.metrics.runs import RUN_OPTIONS, evaluate_runs

from .dask_cli import dask_cluster

NOMINAL = PRESETS["jaguar-lite"]
READ = ReadOptions(modulus=NOMINAL.encoder_modulus)
#: CI-sized: 200 runs (the 2,000-run figure comes from benchmarks/bench_fleet.py)
SPEC = FleetSpec(robots=4, days=5, runs_per_day=10, run_seconds=8.0, wearing=1, seed=11)


@pytest.fixture(scope="module")
def fleet(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    return simulate_fleet(tmp_path_factory.mktemp("fleet"), SPEC)


@pytest.fixture(scope="module")
def local(fleet: list[Path]) -> list:  # type: ignore[type-arg]
    return evaluate_runs(
        fleet, "csv", params=NOMINAL, read_options=READ, cluster=Cluster(workers=1)
    )


def _numbers(outcomes: list) -> np.ndarray:  # type: ignore[type-arg]
    rows = fleet_rows(outcomes)
    return np.array([[float(v) for v in rows[c]] for c in COLUMNS[5:]])


def test_layout_manifest_and_robot_date(fleet: list[Path]) -> None:
    assert len(fleet) == SPEC.runs == 200
    root = fleet[0].parents[2]
    manifest = json.loads((root / "fleet.json").read_text())
    assert [r["wear_per_day"] for r in manifest["robots"]] == [0.0, 0.0, 0.0, 0.003]
    assert robot_and_date(fleet[0]) == ("robot-01", "2026-03-02")
    assert robot_and_date(fleet[-1]) == ("robot-04", "2026-03-06")
    assert robot_and_date("/logs/run.csv") == ("logs", "")
    assert all(p.with_name(p.stem + "_gt.csv").is_file() for p in fleet)


def test_rows_are_the_evaluation_numbers(fleet: list[Path], local: list) -> None:  # type: ignore[type-arg]
    from odolab.io import read_run

    run = read_run(fleet[7], "csv", READ)
    ev = evaluate(run.require_ground_truth(), run.odometry(NOMINAL), RUN_OPTIONS)
    rows = fleet_rows(local)
    assert rows["source"][7] == str(fleet[7])
    assert rows["ape_rmse_m"][7] == ev.ape.rmse
    assert rows["rpe_rot_rmse_deg"][7] == pytest.approx(math.degrees(ev.rpe_rot.rmse), abs=0)
    assert rows["drift_pct"][7] == ev.drift.translation_pct
    assert rows["endpoint_error_m"][7] == ev.drift.endpoint_error
    assert rows["length_m"][7] == ev.drift.path_length
    assert rows["duration_s"][7] == pytest.approx(8.0)


def test_summary_per_robot_and_worn_robot_drifts_more_each_day(local: list) -> None:  # type: ignore[type-arg]
    rows = fleet_rows(local)
    s = summarize(rows, worst=3)
    drift = np.array(rows["drift_pct"])
    robots = np.array(rows["robot"])
    for r in s.per_robot:
        assert r["runs"] == 50
        assert r["drift_pct_mean"] == pytest.approx(float(np.mean(drift[robots == r["robot"]])))
    assert s.worst[0]["drift_pct"] == pytest.approx(float(np.nanmax(drift)))
    worn = [d["drift_pct_mean"] for d in s.per_day if d["robot"] == "robot-04"]
    assert worn[-1] > 1.5 * worn[0]  # 1.2 % of left radius lost by day 5: the drift grows


def test_section_flags_the_worn_robot_with_its_evidence(local: list, tmp_path: Path) -> None:  # type: ignore[type-arg]
    from odolab.fleet.section import fleet_section

    rows = fleet_rows(local)
    sec = fleet_section(rows)
    assert sec.flagged == ["robot-04"]
    v = next(v for v in sec.verdicts if v.robot == "robot-04")
    sel = np.array(rows["robot"]) == "robot-04"
    day = np.array([int(d[-2:]) for d in rows["date"]])[sel]
    slope = np.polyfit(day, np.array(rows["drift_pct"])[sel], 1)[0]  # independent fit
    assert v.slope_pct_per_day == pytest.approx(slope, rel=1e-9)
    assert v.runs == 50 and v.days == 5
    page = sec.save(tmp_path / "report")
    assert (tmp_path / "report" / "fleet_drift_per_day.png").stat().st_size > 10_000
    assert "robot-04</td>" in page.read_text() and "<strong>recalibrate</strong>" in sec.html
    rows["robot"] = ["<script>x</script>"] * len(rows["robot"])
    assert "<script>" not in fleet_section(rows, figures=False).html


def test_failures_are_reported_per_run_and_the_rest_kept(
    tmp_path: Path,
    fleet: list[Path],
    local: list,
    capsys: pytest.CaptureFixture[str],  # type: ignore[type-arg]
) -> None:
    folder = tmp_path / "robot-09" / "2026-03-09"
    folder.mkdir(parents=True)
    for p in fleet[:3]:
        (folder / p.name).write_bytes(p.read_bytes())
        gt = p.with_name(p.stem + "_gt.csv")
        (folder / gt.name).write_bytes(gt.read_bytes())
    (folder / "run-002.csv").write_text("t,left_ticks,right_ticks\n0,1,1\n0.1,abc,2\n")
    table = tmp_path / "fleet.parquet"
    code = main(["evaluate", str(tmp_path), "--format", "csv", "-p", "jaguar-lite",
                 "--workers", "1", "--results", str(table)])  # fmt: skip
    assert code == 1
    err = capsys.readouterr().err
    assert "run-002.csv: line 3, column 'left_ticks' is 'abc'" in err
    assert "1 of 3 runs failed" in err
    rows = read_fleet_table(table)
    assert rows["error"][0] is None and rows["error"][2] is None
    assert "line 3" in rows["error"][1]
    assert rows["robot"] == ["robot-09"] * 3
    assert rows["ape_rmse_m"][0] == fleet_rows(local)["ape_rmse_m"][0]
    assert math.isnan(rows["ape_rmse_m"][1])


def test_local_dask_cluster_equals_in_process(fleet: list[Path], local: list) -> None:  # type: ignore[type-arg]
    got = evaluate_runs(fleet[:24], "csv", params=NOMINAL, read_options=READ,
                        cluster=Cluster(workers=2))  # fmt: skip
    np.testing.assert_allclose(_numbers(got), _numbers(local[:24]), rtol=0, atol=1e-12)


def test_dask_cli_cluster_equals_local_and_survives_a_killed_worker(
    tmp_path: Path,
    fleet: list[Path],
    local: list,  # type: ignore[type-arg]
) -> None:
    with dask_cluster(tmp_path / "dask", workers=2) as procs:
        cluster = Cluster(scheduler=procs.address)
        got = evaluate_runs(fleet, "csv", params=NOMINAL, read_options=READ, cluster=cluster)
        assert all(o.ok for o in got)
        np.testing.assert_allclose(_numbers(got), _numbers(local), rtol=0, atol=1e-12)

        victim = procs.workers[0]
        killed: list[int] = []

        def kill_midway(done: int, total: int, name: str) -> None:
            if done >= 20 and not killed:
                os.kill(victim.pid, signal.SIGKILL)
                killed.append(done)

        rep = MapReport("")
        again = evaluate_runs(fleet, "csv", params=NOMINAL, read_options=READ, cluster=cluster,
                              progress=kill_midway, report=rep)  # fmt: skip
        assert killed and victim.wait(timeout=10) == -signal.SIGKILL
        assert len(again) == 200 and all(o.ok for o in again), [o.error for o in again if o.error]
        np.testing.assert_allclose(_numbers(again), _numbers(local), rtol=0, atol=1e-12)
        assert len(rep.lost_workers) == 1
        assert "1 worker(s) lost" in rep.loss_text()


def test_bad_scheduler_address_is_one_sentence() -> None:
    from odolab.core.errors import OdolabError

    with pytest.raises(OdolabError, match="expected an address like tcp://HOST:PORT"):
        Cluster(scheduler="127.0.0.1:8786")
    for bad in (0, -3, 1.5, True):
        with pytest.raises(OdolabError, match="expected a whole number >= 1"):
            Cluster(workers=bad)  # type: ignore[arg-type]


def test_fleet_spec_refuses_nonsense() -> None:
    from odolab.core.errors import OdolabError

    with pytest.raises(OdolabError, match="fleet robots is 0"):
        FleetSpec(robots=0)
    with pytest.raises(OdolabError, match="fleet start date"):
        FleetSpec(start_date="March")


def test_a_local_cluster_beside_another_does_not_warn(fleet: list[Path]) -> None:
    """The local cluster's web server takes a free loopback port: with 127.0.0.1:8787 taken
    (another odolab run, a notebook's cluster), nothing is printed about it."""
    import socket
    import warnings

    with socket.socket() as taken:
        try:
            taken.bind(("127.0.0.1", 8787))
        except OSError:
            pytest.skip("127.0.0.1:8787 is in use here already")
        taken.listen()
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a UserWarning about the port fails the test
            got = evaluate_runs(
                fleet[:4], "csv", params=NOMINAL, read_options=READ, cluster=Cluster(workers=2)
            )
    assert all(o.result is not None for o in got)
