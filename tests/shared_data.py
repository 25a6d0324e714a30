"""Where the tests find the real data (OptiOdom runs, evo's test trajectories), and what happens
when it is missing.

The data folder is ``$ODOLAB_TEST_DATA`` when set, else ``../shared/data`` beside the project's
root (the layout of a clone next to the team's shared folder). It holds one folder a data set,
each from a public source (:data:`SOURCES`; README.md's "Tests" section says how to make a copy).

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


#: data set folder -> where it comes from (its README in the folder says more)
SOURCES: dict[str, str] = {
    "optiodom": (
        "real differential-drive runs with motion capture, from the public repository "
        "sousarbarb/optiodom (data/diff; MIT)"
    ),
    "evo-testdata": (
        "evo's test trajectories (TUM RGB-D) and a ROS 2 MCAP bag, from the public repository "
        "MichaelGrupp/evo (test/data; GPL-3.0)"
    ),
    "drive-husky": (
        "a Clearpath Husky's wheel speeds, IMU and lidar-ICP poses, from the public repository "
        "norlab-ulaval/DRIVE (calib_data/test_husky, re-written as husky_windows.csv; BSD-3)"
    ),
}


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
    """The data folder ``sub`` (a key of :data:`SOURCES`): skip or fail when it is missing."""
    path = data_dir() / sub
    if path.is_dir():
        return path
    source = SOURCES.get(sub, "see README.md's Tests section")
    message = (
        f"real test data {sub}/ not found: looked for the folder {path}; it holds {source}. "
        f"Set ODOLAB_TEST_DATA to a folder holding {sub}/ (README.md, Tests)"
    )
    if data_required():
        pytest.fail(message + " (required because CI or ODOLAB_REQUIRE_TEST_DATA is set)")
    pytest.skip(message)
