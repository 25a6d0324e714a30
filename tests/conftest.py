"""Test configuration: a fixed hypothesis profile in CI, the Agg backend, shared fixtures."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

os.environ.setdefault("MPLBACKEND", "Agg")

settings.register_profile(
    "ci",
    derandomize=True,
    max_examples=60,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
    print_blob=True,
)
settings.register_profile("dev", max_examples=60, deadline=None)
settings.load_profile("ci" if os.environ.get("CI") else os.environ.get("HYPOTHESIS_PROFILE", "dev"))

#: The real robot runs (OptiOdom), beside the project root: ../shared/data/optiodom
SHARED = Path(__file__).resolve().parents[1].parent / "shared"
OPTIODOM = SHARED / "data" / "optiodom"


@pytest.fixture(scope="session")
def optiodom_dir() -> Path:
    if not OPTIODOM.is_dir():
        pytest.skip(f"real data not found at {OPTIODOM}")
    return OPTIODOM
