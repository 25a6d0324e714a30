"""``calibrate lsq DIR`` of odolab's own CSV runs (issue 30): the format is detected from the
files found and said, instead of defaulting to OptiOdom and asking for a metadata file."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from odolab.cli import main
from odolab.core.defaults import LogFormat
from odolab.core.errors import LogFormatError
from odolab.core.odometry import integrate_increments
from odolab.core.params import PRESETS, load_params
from odolab.io import write_trajectory
from odolab.io.registry import detect_format


def _csv_runs(folder: Path) -> Path:
    """Two weaving drives of a robot whose radii and track differ from jaguar-lite's."""
    nominal = PRESETS["jaguar-lite"]
    true = replace(
        nominal,
        left_wheel_radius=nominal.left_wheel_radius * 1.02,
        right_wheel_radius=nominal.right_wheel_radius * 0.99,
        track_width=nominal.track_width * 1.05,
    )
    folder.mkdir()
    t = np.arange(400) * 0.05
    for k, w in enumerate((0.4, 0.7)):
        dl = np.rint(30 + 20 * np.sin(w * t))
        dr = np.rint(30 - 20 * np.sin(w * t))
        dl[0] = dr[0] = 0
        rows = "\n".join(f"{a:.2f},{int(b)},{int(c)}" for a, b, c in zip(t, dl, dr, strict=True))
        (folder / f"r{k}.csv").write_text("t,dticks_left,dticks_right\n" + rows + "\n")
        write_trajectory(folder / f"r{k}_gt.csv", integrate_increments(t, dl, dr, true))
    return folder


def test_lsq_of_a_csv_folder_detects_csv(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    runs = _csv_runs(tmp_path / "runs")
    out = tmp_path / "p.toml"
    args = ["calibrate", "lsq", str(runs), "-p", "jaguar-lite", "-o", str(out), "--workers", "1"]
    assert main([*args, "--json", str(tmp_path / "r.json")]) == 0
    said = capsys.readouterr().out
    assert "format: csv, detected: odolab's own encoder log CSV" in said
    assert f"found at {runs}" in said
    doc = json.loads((tmp_path / "r.json").read_text())
    assert doc["fitted"] == [str(runs / "r0.csv"), str(runs / "r1.csv")]
    fitted = load_params(out)  # the drives are exact: the true robot comes back
    assert fitted.left_wheel_radius == pytest.approx(0.0835 * 1.02, rel=1e-9)
    assert fitted.right_wheel_radius == pytest.approx(0.0835 * 0.99, rel=1e-9)
    assert fitted.track_width == pytest.approx(0.56 * 1.05, rel=1e-9)


def test_detect_format(tmp_path: Path) -> None:
    runs = _csv_runs(tmp_path / "runs")
    assert detect_format([runs])[0] is LogFormat.CSV
    opti = tmp_path / "opti" / "1"
    opti.mkdir(parents=True)
    (opti / "1_metadata.csv").write_text("Di,0.084\n")
    (opti / "1_run-01.csv").write_text("0,0,0,0,0,0\n")
    (opti / "1_run-01_odo.csv").write_text("0,0,0\n")
    assert detect_format([tmp_path / "opti"])[0] is LogFormat.OPTIODOM
    assert detect_format([opti / "1_run-01.csv"])[0] is LogFormat.OPTIODOM
    assert detect_format([tmp_path / "x.mcap"])[0] is LogFormat.CSV  # (not there: a pattern)
    (tmp_path / "x.mcap").write_bytes(b"")
    assert detect_format([tmp_path / "x.mcap"])[0] is LogFormat.BAG
    with pytest.raises(LogFormatError, match=r"holds csv runs but .* holds optiodom runs"):
        detect_format([runs, tmp_path / "opti"])
