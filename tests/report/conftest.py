"""Fixtures for the report tests: the synthetic lab campaign and its analysis."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parents[1] / "analysis"))

import numpy as np
from synth_trials import rotation_trials, translation_trials

from odolab.analysis import LabAnalysis, analyze_trials
from odolab.core.trials import Trial


@pytest.fixture(scope="session")
def lab() -> list[Trial]:
    """A smaller campaign than the lab's (fewer figures to draw): rotation, tile, concrete."""
    rng = np.random.default_rng(2)
    trials = rotation_trials(rng, repeats_at_20pi=9)
    trials += translation_trials(rng)
    trials += translation_trials(
        rng, terrain="concrete", distances=(1.0, 2.0, 3.0, 4.0), repeats=2, measure_y=False
    )
    return trials


@pytest.fixture(scope="session")
def analysis(lab: list[Trial]) -> LabAnalysis:
    return analyze_trials(lab)
