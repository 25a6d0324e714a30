"""``trials add`` without ``--params-version`` says which parameter version it recorded the trial
with (it took the robot's latest silently)."""

from __future__ import annotations

from pathlib import Path

import pytest

from odolab.cli import main
from odolab.core.params import PRESETS
from odolab.store import Notebook


def _add(trial_id: str, *extra: str) -> list[str]:
    return ["trials", "add", "--id", trial_id, "--campaign", "c1", "--kind", "rotation",
            "--angle-pi", "2", "--predicted-heading", "6.28", "--db", "lab.db", *extra]  # fmt: skip


def test_trials_add_says_which_version_it_chose(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["notebook", "init", "--db", "lab.db"]) == 0
    assert main(["trials", "campaign-add", "c1", "--kind", "rotation", "--terrain", "tile",
                 "--db", "lab.db"]) == 0  # fmt: skip
    capsys.readouterr()
    assert main(_add("T1")) == 0
    assert capsys.readouterr().out.endswith(
        "awaiting; parameters jaguar-lite v1 (the preset; give --params-version to choose)\n"
    )
    with Notebook("lab.db") as nb:
        calibrated = PRESETS["jaguar-lite"].with_(track_width=0.6)  # a calibration: version 2
        assert nb.add_params_version(calibrated, method="test") == 2
    assert main(_add("T2")) == 0
    assert capsys.readouterr().out.endswith(
        "parameters jaguar-lite v2 (the robot's latest; give --params-version to choose the "
        "version it was driven with)\n"
    )
    assert main(_add("T3", "--params-version", "1")) == 0
    assert capsys.readouterr().out.endswith("recorded in lab.db: awaiting\n")
    with Notebook("lab.db") as nb:
        assert [nb.trial_params_version(t)[1] for t in ("T1", "T2", "T3")] == [1, 2, 1]
