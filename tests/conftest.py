"""Test configuration: a fixed hypothesis profile in CI, the Agg backend, shared fixtures."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

from shared_data import data_dir, require

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

#: The real robot runs (OptiOdom): $ODOLAB_TEST_DATA/optiodom, by default ../shared/data/optiodom
#: beside the project root; missing data fails the test in CI (see shared_data.py).
OPTIODOM = data_dir() / "optiodom"


@pytest.fixture(scope="session")
def optiodom_dir() -> Path:
    return require("optiodom")
