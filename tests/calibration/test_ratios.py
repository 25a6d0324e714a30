"""Ratios calibration: the multiply convention, a round trip through odometry, the CLI."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from odolab.calibration import ratios, ratios_from_analysis
from odolab.cli import main
from odolab.core.errors import CalibrationError
from odolab.core.odometry import integrate_increments
from odolab.core.params import PRESETS, load_params

sys.path.insert(0, str(Path(__file__).parents[1] / "analysis"))
from synth_trials import lab_trials

OLD = PRESETS["jaguar-lite"]


def test_convention_multiplies_radius_and_scales_track() -> None:
    """Guard: 0.905 and 0.875 give 0.905 r and 1.0343 w (the lab report divided instead)."""
    res = ratios(OLD, 0.905, 0.875)
    assert res.params.left_wheel_radius == pytest.approx(0.905 * OLD.left_wheel_radius)
    assert res.params.right_wheel_radius == pytest.approx(0.905 * OLD.right_wheel_radius)
    # measured |value - expected| 8e-06 over seed shifts 0-3; tolerance 5.8e-05; the same at every
    # seed
    assert res.params.track_width == pytest.approx(1.0343 * OLD.track_width, rel=1e-4)
    assert res.params.ticks_per_rev == OLD.ticks_per_rev
    assert res.provenance["method"] == "ratios"
    assert res.provenance["distance_ratio"] == 0.905


def _drive(params, dl, dr):
    t = np.arange(dl.size) * 0.05
    return integrate_increments(t, dl, dr, params).final


def test_new_params_reproduce_the_true_motion() -> None:
    """Ticks from a true robot; the ratios measured with the old params; new params = truth."""
    true = OLD.with_(left_wheel_radius=0.0757, right_wheel_radius=0.0757, track_width=0.61)
    straight = np.r_[0.0, np.full(100, 25.0)]
    turn_l, turn_r = np.r_[0.0, np.full(200, -30.0)], np.r_[0.0, np.full(200, 30.0)]
    q_d = _drive(true, straight, straight).x / _drive(OLD, straight, straight).x
    q_r = _drive(true, turn_l, turn_r).heading / _drive(OLD, turn_l, turn_r).heading
    new = ratios(OLD, q_d, q_r).params
    assert new.left_wheel_radius == pytest.approx(true.left_wheel_radius, rel=1e-9)
    assert new.track_width == pytest.approx(true.track_width, rel=1e-9)
    assert _drive(new, turn_l, turn_r).heading == pytest.approx(
        _drive(true, turn_l, turn_r).heading, rel=1e-9
    )


@pytest.mark.parametrize("bad", [0.0, -0.9, math.nan, 10.0])
def test_bad_ratio_is_refused(bad: float) -> None:
    with pytest.raises(CalibrationError, match="actual/predicted"):
        ratios(OLD, bad, 0.875)


def test_ratios_from_the_fits_carry_intervals() -> None:
    from odolab.analysis import analyze_trials

    analysis = analyze_trials(lab_trials(3))
    res = ratios_from_analysis(analysis)
    x = analysis.get("x", "tile")
    rot = analysis.get("rotation", "tile")
    assert res.provenance["distance_ratio"] == pytest.approx(x.ratio)
    assert res.provenance["rotation_ratio"] == pytest.approx(rot.ratio)
    lo, hi = res.provenance["track_width_ci95"]
    assert lo < res.params.track_width < hi
    assert "tile" in res.provenance["source"]
    # the measured random error travels with the parameters, scaled to the new geometry:
    # wheel noise from the straight runs alone, scrub from the turns (never pooled)
    split = analysis.noise_split
    assert split is not None and res.params.noise is not None
    assert split.k_left.value is not None and split.k_scrub.value is not None
    q = res.provenance["distance_ratio"]
    q_r = res.provenance["rotation_ratio"]
    assert res.params.noise.k_left == pytest.approx(split.k_left.value * q, rel=1e-9)
    assert res.params.noise.k_right == pytest.approx(split.k_right.value * q, rel=1e-9)  # type: ignore[operator]
    assert res.params.noise.k_scrub == pytest.approx(split.k_scrub.value / q_r, rel=1e-9)
    fit = res.provenance["noise_fit"]
    assert fit["k_left"]["trials"] == list(split.k_left.trials)
    assert all(t.startswith(("translation", "outdoor")) for t in fit["k_left"]["trials"])
    assert all(t.startswith("rotation") for t in fit["k_scrub"]["trials"])
    lo, hi = fit["k_left"]["ci95"]
    assert lo < res.params.noise.k_left < hi
    with pytest.raises(CalibrationError, match="rotation fit and an x fit"):
        ratios_from_analysis(analysis, terrain="grass")


def test_cli_writes_loadable_toml(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "new.toml"
    args = ["calibrate", "ratios", "--params", "jaguar-lite", "-o", str(out)]
    code = main([*args, "--distance-ratio", "0.905", "--rotation-ratio", "0.875"])
    assert code == 0
    p = load_params(out)
    assert p.track_width == pytest.approx(0.56 * 0.905 / 0.875)
    assert "[provenance]" in out.read_text()
    assert main([*args, "--distance-ratio", "0.905"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "both" in err


def test_ratios_refuse_a_model_that_ignores_the_track_width() -> None:
    # the ICR model turns by its own y_icr: the new track width was written and changed nothing
    from odolab.core.models import ExtendedDiffDrive, IcrModel

    nominal = PRESETS["jaguar-lite"]
    icr = nominal.with_(model=IcrModel(0.3, -0.3))
    with pytest.raises(CalibrationError, match=r"\[model\] is icr, which turns by its own .*lsq"):
        ratios(icr, 0.9, 0.875)
    # the extended model's track is track_scale x the track width: the correction applies
    ext = ratios(nominal.with_(model=ExtendedDiffDrive(1.0, 1.0, 1.2)), 0.9, 0.875).params
    assert ext.coefficients.denominator == pytest.approx(1.2 * 0.56 * 0.9 / 0.875, rel=1e-12)
