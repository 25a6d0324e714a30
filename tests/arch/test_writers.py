"""Every writer takes ``(path, obj)``; the old ``(obj, path)`` order still works, with a warning."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from odolab.io import write_encoder_csv, write_trajectory, write_trajectory_csv, write_tum
from odolab.params import PRESETS, save_params
from odolab.sim.export import write_encoder_logs
from odolab.store.csvio import write_trials_csv
from odolab.trajectory import Trajectory
from odolab.trials import EncoderLog

LOG = EncoderLog(np.array([0.0, 0.05]), np.array([0, 7]), np.array([0, 9]), 32768)
TRAJ = Trajectory.from_xytheta(np.array([0.0, 1.0]), np.array([0.0, 0.5]), np.zeros(2), np.zeros(2))
PARAMS = PRESETS["jaguar-lite"]

WRITERS = [
    (write_encoder_csv, LOG, "e.csv"),
    (write_trajectory_csv, TRAJ, "t.csv"),
    (write_tum, TRAJ, "t.tum"),
    (write_trajectory, TRAJ, "t2.csv"),
    (save_params, PARAMS, "p.toml"),
]


@pytest.mark.parametrize(("writer", "obj", "name"), WRITERS)
def test_path_first_and_the_old_order_write_the_same_file(
    tmp_path: Path, writer: object, obj: object, name: str
) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the new order never warns
        new = writer(tmp_path / "new" / name, obj)  # type: ignore[operator]
    with pytest.warns(DeprecationWarning, match=r"\(path, obj\)"):
        old = writer(obj, tmp_path / "old" / name)  # type: ignore[operator]
    assert new == tmp_path / "new" / name
    assert old == tmp_path / "old" / name
    assert new.read_bytes() == old.read_bytes() and new.stat().st_size > 0


@pytest.mark.parametrize(("writer", "obj", "name"), WRITERS)
def test_two_paths_or_two_objects_are_refused(
    tmp_path: Path, writer: object, obj: object, name: str
) -> None:
    with pytest.raises(TypeError, match=r"\(path, obj\) takes a path"):
        writer(tmp_path / name, tmp_path / name)  # type: ignore[operator]


def test_the_trial_writers_take_the_path_first(tmp_path: Path) -> None:
    assert write_trials_csv(tmp_path / "t.csv", []).read_text().startswith("trial_id,")
    assert write_encoder_logs(tmp_path / "logs", []) == []
    with pytest.warns(DeprecationWarning):
        assert write_encoder_logs([], tmp_path / "logs") == []


def test_the_named_defaults_are_presets() -> None:
    from odolab.defaults import DEFAULT_ROBOT, DEFAULT_TRUTH
    from odolab.sim.presets import TRUTH_PRESETS

    assert PRESETS[DEFAULT_ROBOT].name == DEFAULT_ROBOT
    assert TRUTH_PRESETS[DEFAULT_TRUTH].name == DEFAULT_TRUTH
