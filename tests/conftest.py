"""Test configuration: a fixed hypothesis profile in CI, the Agg backend, shared fixtures."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, settings

from fixture_cache import cached, demo_builder
from shared_data import data_dir, require

#: the suite's own rules (no skips in CI, the opt-in bound measurements: tests/bounds.py), and the
#: asserts of the test modules rewritten once before xdist starts its workers (a fresh clone)
pytest_plugins = ["suite_plugin", "rewrite_warmup"]

os.environ.setdefault("MPLBACKEND", "Agg")
#: One BLAS thread per test process: xdist already runs a process per core, and OpenBLAS's own
#: threads (one per core in each process) spin while they wait, which cost a quarter more CPU
#: for the same work (test_slip_goals, two tests: 41.0 s -> 30.4 s of CPU). Set before xdist
#: starts its workers, which inherit it (a process that loaded NumPy already keeps its threads:
#: the Makefile sets it too).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

settings.register_profile(
    "ci",
    derandomize=True,
    database=None,  # no example replayed from an earlier run on this machine: every CI run alike
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
def default_demo(tmp_path_factory: pytest.TempPathFactory) -> Any:
    """The demo with its defaults (`odolab demo`, truth jaguar-lab), as ``(LabResult, the
    progress steps it reported)``: built once for every test process (tests/fixture_cache.py),
    each process reading and writing its own copy."""
    return cached(
        "default-demo", demo_builder("jaguar-lab"), tmp_path_factory.mktemp("default-demo")
    )


@pytest.fixture(scope="session")
def tracked_demo(tmp_path_factory: pytest.TempPathFactory) -> Any:
    """The demo on the tracked truth with its defaults (odolab.app.demo.run_lab), built once for
    every test process (tests/fixture_cache.py), each reading its own copy."""
    result, _steps = cached(
        "tracked-demo", demo_builder("jaguar-lab-tracked"), tmp_path_factory.mktemp("tracked-demo")
    )
    return result
