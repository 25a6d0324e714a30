"""``app.validate``: which old parameters ``odolab validate`` compares, by the one rule of
``app.odometry.choose_params`` (--old, else the log's run.json, else the default robot)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from odolab.app.validate import ValidateRequest, validate_log
from odolab.core.defaults import DEFAULT_ROBOT
from odolab.core.params import PRESETS
from odolab.validation import write_demo


@pytest.fixture(scope="module")
def demo(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return write_demo(tmp_path_factory.mktemp("demo"), clock_offset=7217.25, turns=1.0)  # small


def _request(demo: dict[str, Path], log: Path, old: str | None = None) -> ValidateRequest:
    return ValidateRequest(
        log, demo["imu_log"], str(demo["new_params"]), old, offset=7217.25, max_offset=0.0
    )


def test_old_parameters_come_from_the_logs_run_json(demo: dict[str, Path], tmp_path: Path) -> None:
    log = tmp_path / "encoders.csv"
    shutil.copy(demo["encoder_log"], log)
    # a robot's run folder names its own parameters: wider track than the default robot's
    mine = {**PRESETS[DEFAULT_ROBOT].to_dict(), "name": "robot-7", "track_width": 0.6}
    (tmp_path / "run.json").write_text(json.dumps({"params": mine}), encoding="utf-8")
    found = validate_log(_request(demo, log))
    assert found.old.by == "log" and found.old.source == str(tmp_path / "run.json")
    assert found.result.old.params.name == "robot-7"
    assert found.result.old.params.track_width == 0.6


def test_old_parameters_default_to_the_default_robot(demo: dict[str, Path]) -> None:
    found = validate_log(_request(demo, demo["encoder_log"]))
    assert found.old.by == "default"
    assert found.result.old.params.name == DEFAULT_ROBOT


def test_old_parameters_given_win_over_the_logs_own(demo: dict[str, Path]) -> None:
    found = validate_log(_request(demo, demo["encoder_log"], old=str(demo["new_params"])))
    assert found.old.by == "user" and found.old.source == str(demo["new_params"])
