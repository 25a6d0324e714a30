"""Fixtures for the analysis tests: a synthetic lab campaign with known truth."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

from synth_trials import lab_trials

from odolab.core.trials import Trial


@pytest.fixture(scope="session")
def lab() -> list[Trial]:
    return lab_trials(seed=1)
