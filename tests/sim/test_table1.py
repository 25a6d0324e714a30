"""The full jaguar-lab campaign reproduces the lab report's Table I (fitted with plain numpy)."""

from __future__ import annotations

import numpy as np
import pytest

from odolab.core.params import PRESETS
from odolab.sim.presets import LAB_REPORT_SEED, TABLE_I, TRUTH_PRESETS, predicted_sigma_y
from odolab.sim.protocols import load_protocol, run_protocol

from .table1 import TABLE_I as TABLE
from .table1 import misses, table1

NOM = PRESETS["jaguar-lite"]


@pytest.fixture(scope="module")
def campaign() -> dict[str, float]:
    trials = run_protocol(
        load_protocol("lab-report"), TRUTH_PRESETS["jaguar-lab"], NOM, seed=LAB_REPORT_SEED
    )
    assert len(trials) == 77  # 20 + 17 rotations, 20 indoor and 20 outdoor straight runs
    return table1(trials)


def test_default_seed_reproduces_table_1(campaign: dict[str, float]) -> None:
    assert misses(campaign) == [], campaign
    for key, (value, unc) in TABLE.items():
        assert abs(campaign[key] - value) <= unc + 1e-12, key


def test_systematic_figures_hold_without_noise() -> None:
    # without any random term the systematic figures are met by construction, not by the seed
    trials = run_protocol(load_protocol("lab-report"), TRUTH_PRESETS["jaguar-lab"].noiseless, NOM)
    s = table1(trials)
    for key in ("rotation_ratio", "x_ratio_tile", "x_ratio_concrete", "x_ratio_grass"):
        assert s[key] == pytest.approx(TABLE[key][0], abs=0.0015), key
    for key in ("y_drift_forward", "y_drift_reverse"):  # meterstick noise only
        assert s[key] == pytest.approx(TABLE[key][0], abs=0.004), key


def test_noise_model_sigmas() -> None:
    truth = TRUTH_PRESETS["jaguar-lab"]
    assert predicted_sigma_y(truth, TABLE_I.long_distance) == pytest.approx(0.07, abs=1e-9)
    assert predicted_sigma_y(truth, TABLE_I.short_distance) == pytest.approx(0.03, abs=0.005)


@pytest.mark.parametrize(
    ("preset", "growth"), [("jaguar-lab", 10**0.5), ("jaguar-lab-track", 10.0)]
)
def test_rotation_sigma_at_20pi_and_its_growth(preset: str, growth: float) -> None:
    # both presets give Table I's 2.94 rad at 20 pi; they differ in how it grows with the angle
    from odolab.sim.protocols import parse_protocol

    n = 1500
    doc = {
        "protocol": {"campaign": "r"},
        "trials": [{"motion": "rotation", "angle_pi": [2, 20], "repeats": n}],
    }
    trials = run_protocol(parse_protocol(doc, "r.toml"), TRUTH_PRESETS[preset], NOM, seed=8)
    rot = np.array([t.measured.rotation for t in trials])  # type: ignore[union-attr]
    s2, s20 = rot[:n].std(ddof=1), rot[n:].std(ddof=1)
    rel = 4 / (2 * n) ** 0.5
    assert s20 == pytest.approx(2.94, rel=rel)
    assert s20 / s2 == pytest.approx(growth, rel=2 * rel)


def test_cli_default_seed_is_the_documented_seed() -> None:
    from odolab.cli.sim import _LAB_REPORT_SEED
    from odolab.sim.presets import LAB_REPORT_SEED

    assert _LAB_REPORT_SEED == LAB_REPORT_SEED
