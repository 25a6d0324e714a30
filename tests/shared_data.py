"""Where the tests find the real data (OptiOdom runs, evo's test trajectories), and what happens
when it is missing.

The data folder is ``$ODOLAB_TEST_DATA`` when set, else ``../shared/data`` beside the project's
root (the layout of a clone next to the team's shared folder). It must hold ``optiodom/`` and
``evo-testdata/``.

A test that needs the data asks :func:`require`. Where the data is missing it is *skipped* on a
developer's machine (with the path it looked for), but it *fails* when ``CI`` is set or
``ODOLAB_REQUIRE_TEST_DATA=1``: a CI run without the data would otherwise pass having tested none
of it.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def data_dir() -> Path:
    """The folder holding the real data (it may not exist)."""
    named = os.environ.get("ODOLAB_TEST_DATA")
    return Path(named).expanduser().resolve() if named else ROOT.parent / "shared" / "data"


def data_required() -> bool:
    """Whether a missing data folder fails the test instead of skipping it."""
    return bool(os.environ.get("CI")) or os.environ.get("ODOLAB_REQUIRE_TEST_DATA", "") not in (
        "",
        "0",
    )


def require(sub: str) -> Path:
    """The data folder ``sub`` (``optiodom``, ``evo-testdata``): skip or fail when it is missing."""
    path = data_dir() / sub
    if path.is_dir():
        return path
    message = (
        f"real test data not found at {path}: set ODOLAB_TEST_DATA to the folder holding "
        "optiodom/ and evo-testdata/ (the team's shared/data)"
    )
    if data_required():
        pytest.fail(message + " (required because CI or ODOLAB_REQUIRE_TEST_DATA is set)")
    pytest.skip(message)
