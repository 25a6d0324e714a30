"""Test configuration: a fixed hypothesis profile in CI, the Agg backend, shared fixtures."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

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


@pytest.fixture(scope="session")
def tracked_demo(tmp_path_factory: pytest.TempPathFactory) -> Any:
    """The demo on the tracked truth with its defaults (odolab.lab.run_lab), run once per test
    process and only read (the tests that take it are marked with the xdist group
    "tracked_demo": `pytest --dist loadgroup` runs them on one worker, on one demo; `make test`
    keeps the default scheduling, which measured faster over the whole suite)."""
    from odolab.lab import run_lab

    return run_lab(tmp_path_factory.mktemp("tracked-demo"), truth="jaguar-lab-tracked")
