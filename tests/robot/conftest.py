"""Shared helpers for the robot tests: a tiny fake plant and an in-process board."""

from __future__ import annotations

import math
import socket
from collections.abc import Iterator
from typing import Any

import pytest

from odolab.core.trajectory import Pose


class FakePlant:
    """The smallest plant: records commands, moves its counters at the commanded speed.

    Counters advance by ``speed / metres_per_tick`` counts per second (floored) and wrap at 32768;
    the pose is not simulated (it stays at the origin).
    """

    def __init__(self, metres_per_tick: float = 0.001) -> None:
        self.mpt = metres_per_tick
        self.commands: list[tuple[float, float]] = []
        self.reset()

    def reset(self, start: Any = None) -> None:
        self._t = 0.0
        self._sl = 0.0
        self._sr = 0.0
        self._v = (0.0, 0.0)

    @property
    def time(self) -> float:
        return self._t

    @property
    def stalled(self) -> bool:
        return False

    @property
    def true_pose(self) -> Pose:
        return Pose(self._t, 0.0, 0.0, 0.0, 0.0)

    def set_wheel_speeds(self, left_mps: float, right_mps: float) -> None:
        self._v = (left_mps, right_mps)
        self.commands.append(self._v)

    def advance(self, duration: float) -> None:
        self._sl += self._v[0] * duration
        self._sr += self._v[1] * duration
        self._t += duration

    def encoder_counts(self) -> tuple[int, int]:
        return (
            math.floor(self._sl / self.mpt + 1e-9) % 32768,
            math.floor(self._sr / self.mpt + 1e-9) % 32768,
        )


@pytest.fixture
def fake_plant() -> FakePlant:
    return FakePlant()


@pytest.fixture
def listener() -> Iterator[socket.socket]:
    """A UDP socket on loopback standing in for a board: it must receive nothing."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.bind(("127.0.0.1", 0))
        sock.setblocking(False)
        yield sock
