"""calibrate ratios/umbmark --db: [noise] from the trials that identify each constant (issue 26)."""

from __future__ import annotations

import sys
import tomllib
from pathlib import Path

import pytest

from odolab.analysis import analyze_trials
from odolab.calibration import ratios_from_analysis
from odolab.calibration.ratios import describe_noise
from odolab.cli import main
from odolab.core.params import load_params
from odolab.store import Notebook

sys.path.insert(0, str(Path(__file__).parents[1] / "analysis"))
sys.path.insert(0, str(Path(__file__).parent))
from synth_trials import lab_trials
from test_umbmark_iterated import NOM, _square_trials, _truth


def _db(tmp_path: Path, trials: list) -> Path:
    db = tmp_path / "lab.db"
    with Notebook(db) as nb:
        nb.add_trials(trials)
    return db


def test_ratios_write_each_constant_from_its_own_trials(tmp_path: Path) -> None:
    db = _db(tmp_path, lab_trials(3))
    out = tmp_path / "new.toml"
    assert main(["calibrate", "ratios", "-p", "jaguar-lite", "--db", str(db), "-o", str(out)]) == 0
    noise = load_params(out).noise
    assert noise is not None
    # the synthetic rotations spread far more than wheel noise explains: scrub, not pooled k
    # measured k_scrub 0.12-0.20 and k_left 1.1e-4-2.4e-4 over seed shifts 0-3; bound 1e-2
    assert noise.k_scrub > 0 and noise.k_left < 1e-2
    fit = tomllib.loads(out.read_text())["provenance"]["noise_fit"]
    assert {t.split("-")[0] for t in fit["k_left"]["trials"]} == {"translation", "outdoor"}
    assert {t.split("-")[0] for t in fit["k_scrub"]["trials"]} == {"rotation"}
    assert fit["k_scrub"]["ci95"][0] < noise.k_scrub < fit["k_scrub"]["ci95"][1]
    line = describe_noise(ratios_from_analysis(analyze_trials(lab_trials(3))))
    assert line is not None and "k_scrub = " in line and "rad [" in line
    with Notebook(db) as nb:
        version = nb.params_versions("jaguar-lite")[-1]
    assert set(fit["k_scrub"]["trials"]) <= set(version.source_trials)
    assert "k_scrub from" in version.notes


def test_umbmark_without_straight_runs_says_the_noise_is_unknown(tmp_path: Path) -> None:
    from odolab.analysis import analyze_trials
    from odolab.calibration import umbmark_iterated

    squares = _square_trials(_truth(1.12, 1.01), runs=2)
    umb = umbmark_iterated(squares, NOM).with_noise(analyze_trials(squares))
    assert umb.params.noise is None  # nothing pooled, nothing guessed
    line = describe_noise(umb.calibration)
    assert line is not None and "k_left unknown (0 measured straight runs" in line
    assert "k_scrub unknown" in line
    doc = tomllib.loads(umb.calibration.save(tmp_path / "umb.toml").read_text())
    assert "noise" not in doc
    assert doc["provenance"]["noise"].startswith("no [noise]")


def test_umbmark_carries_the_notebooks_noise() -> None:
    from odolab.analysis import analyze_trials
    from odolab.calibration import umbmark_iterated

    squares = _square_trials(_truth(1.12, 1.01), runs=2)
    analysis = analyze_trials(lab_trials(3) + squares)
    umb = umbmark_iterated(squares, NOM).with_noise(analysis)
    got = umb.params
    assert got.noise is not None and got.noise.k_scrub > 0
    assert umb.calibration.params == got
    split = analysis.noise_split
    assert split is not None and split.k_left.value is not None
    # UMBmark keeps the mean radius: the wheel constants keep their scale; the wider track
    # makes each radian of commanded turning a larger one, k_scrub shrinks by that much
    q_d = (got.left_wheel_radius + got.right_wheel_radius) / (2 * NOM.left_wheel_radius)
    assert got.noise.k_left == pytest.approx(split.k_left.value * q_d, rel=1e-9)
    q_r = q_d * NOM.track_width / got.track_width
    assert got.noise.k_scrub == pytest.approx(split.k_scrub.value / q_r, rel=1e-9)  # type: ignore[operator]


def test_the_cli_says_each_constant_and_umbmark_writes_them(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from dataclasses import replace

    lab = lab_trials(3)  # one robot: the squares driven with the lab trials' parameters
    squares = [replace(t, params=lab[0].params) for t in _square_trials(_truth(1.12, 1.01), runs=2)]
    db = _db(tmp_path, lab + squares)
    out = tmp_path / "umb.toml"
    assert main(["calibrate", "umbmark", "-p", "jaguar-lite", "--db", str(db), "-o", str(out)]) == 0
    text = " ".join(capsys.readouterr().out.split())  # the console may wrap lines
    assert "[noise] k_left = " in text and "k_scrub = " in text and "rad [" in text
    got = load_params(out)
    assert got.noise is not None and got.noise.k_scrub > 0
    fit = tomllib.loads(out.read_text())["provenance"]["noise_fit"]
    assert all(t.startswith("rotation") for t in fit["k_scrub"]["trials"])
    with Notebook(db) as nb:
        version = nb.params_versions("jaguar-lite")[-1]
    assert set(fit["k_left"]["trials"]) <= set(version.source_trials)
    assert any(t.startswith("sq-") for t in version.source_trials)
