"""The rules of odolab.app.evaluate: the settings of GT EST and of runs, a unit given alone, which
parameters runs are integrated with, and the checks made before any file is read."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from tests.worded import raises_worded

from odolab.app.evaluate import (
    EvaluationRequest,
    LsqRequest,
    calibrate_lsq_runs,
    evaluate_trajectories,
    evaluation_options,
    params_source,
)
from odolab.core.errors import OdolabError
from odolab.io.run import ReadOptions
from odolab.metrics import RUN_OPTIONS, Alignment, DeltaUnit, EvaluationOptions
from odolab.metrics.cluster import Cluster

GT_EST = (Path("gt.tum"), Path("est.tum"))


def test_defaults_are_evos_for_two_trajectories_and_a_runs_for_runs() -> None:
    assert evaluation_options(EvaluationRequest(GT_EST)) == EvaluationOptions()
    runs = evaluation_options(EvaluationRequest((Path("r"),), fmt="optiodom"))
    assert runs == RUN_OPTIONS
    assert runs.alignment is Alignment.ORIGIN and runs.delta_unit is DeltaUnit.METRES


@pytest.mark.parametrize(
    ("unit", "delta"),
    [("frames", 1.0), ("m", 1.0), ("deg", 90.0), ("rad", math.pi / 2)],
)
def test_a_unit_alone_means_one_step_of_it(unit: str, delta: float) -> None:
    o = evaluation_options(EvaluationRequest(GT_EST, delta_unit=unit))
    assert o.delta_unit is DeltaUnit(unit) and o.delta == delta
    assert evaluation_options(EvaluationRequest(GT_EST, delta=30, delta_unit=unit)).delta == 30


def test_drift_turn_is_given_in_degrees() -> None:
    o = evaluation_options(EvaluationRequest(GT_EST, drift_turn_deg=45.0))
    assert o.drift_turn_rad == pytest.approx(math.pi / 4)


def test_the_parameters_used_are_said() -> None:
    assert params_source("robot.toml") == "parameters: robot.toml"
    assert "each run's own" in params_source(None)


@pytest.mark.parametrize(
    ("request_", "sentence"),
    [
        (EvaluationRequest(GT_EST, drift_turn_deg=0.0), "--drift-turn is 0; expected a positive"),
        (EvaluationRequest((Path("a"),)), "evaluate takes GT EST (two trajectory files), got 1 "),
        (EvaluationRequest(GT_EST, nees=True), "--nees needs runs"),
        (EvaluationRequest(GT_EST, chunk_rows=-1), "--chunk-rows is -1"),
    ],
)
def test_checked_before_any_file_is_read(request_: EvaluationRequest, sentence: str) -> None:
    """The files do not exist: the option's sentence comes first."""
    with raises_worded(OdolabError, match=sentence.replace("(", r"\(").replace(")", r"\)")):
        evaluate_trajectories(request_)


def test_ground_truth_is_one_runs(tmp_path: Path) -> None:
    request = LsqRequest(
        runs=(Path("a.csv"), Path("b.csv")), fmt="optiodom", ground_truth=tmp_path / "gt.csv"
    )
    with raises_worded(OdolabError, match="expected exactly one run and no --validate, got 2 runs"):
        calibrate_lsq_runs(request, read_options=ReadOptions(), cluster=Cluster(workers=1))
