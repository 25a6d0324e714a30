"""Fixtures of the metrics tests."""

from __future__ import annotations

import pytest
from metrics_drives import noisy_copy, random_drive

from odolab.core.trajectory import Trajectory


@pytest.fixture
def drive_pair() -> tuple[Trajectory, Trajectory]:
    ref = random_drive(1500, seed=1)
    return ref, noisy_copy(ref, seed=2)
