"""``calibrate compare --json`` and ``evaluate --json`` write strict JSON: a number not defined
for a run (the drift of a window too short to have one) is ``null``, never ``NaN``, so
JavaScript's JSON.parse, jq, Go and serde read the file (docs/models.md)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from tests.arch.test_strict_json import strict_loads
from tests.io.test_windows import _write_table

from odolab.cli import main
from odolab.core.params import RobotParams, save_params


@pytest.fixture
def short_windows(tmp_path: Path) -> tuple[Path, Path]:
    """Six 1.5 s windows of a DRIVE-style table (0.2-0.3 m each: no 1 m piece, no drift) and
    a nominal a little off."""
    table = _write_table(tmp_path / "w.csv", [(w, w, 30) for w in range(6)], hold=1)
    params = tmp_path / "p.toml"
    save_params(
        params,
        RobotParams(
            left_wheel_radius=0.11, right_wheel_radius=0.1, track_width=0.55, ticks_per_rev=100.0
        ),
    )
    return table, params


def test_compare_json_of_windows_too_short_for_drift_is_strict(
    tmp_path: Path, short_windows: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    table, params = short_windows
    out = tmp_path / "cmp.json"
    code = main(
        ["calibrate", "compare", f"{table}#even", "--validate", f"{table}#odd",
         "--params", str(params), "--models", "diff", "--workers", "1", "--json", str(out)]
    )  # fmt: skip
    assert code == 0, capsys.readouterr().err
    doc = strict_loads(out.read_text(encoding="utf-8"))  # it wrote 18 NaN tokens before
    assert isinstance(doc, dict)
    held = doc["models"][0]["held_out"]
    assert doc["segments"] == 0
    # drift of held-out windows 0.2-0.3 m long is not defined: null, with its interval
    assert held["drift_pct"] == {"value": None, "ci95": [None, None]}
    assert held["rpe_rmse"]["value"] is None


def test_evaluate_json_of_the_same_windows_is_strict(
    tmp_path: Path, short_windows: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    table, params = short_windows
    out = tmp_path / "ev.json"
    code = main(
        ["evaluate", "-f", "drive", str(table), "--params", str(params), "--workers", "1",
         "--json", str(out)]
    )  # fmt: skip
    assert code == 0, capsys.readouterr().err
    doc = strict_loads(out.read_text(encoding="utf-8"))
    assert isinstance(doc, dict) and len(doc["runs"]) == 6
    assert all(r["rpe"]["rmse"] is None and r["notes"] for r in doc["runs"])
    assert json.loads(out.read_text(encoding="utf-8")) == doc
