"""Clocks for the control loop: the real monotonic clock, and a simulated one.

A clock has ``now()`` (seconds, monotonic) and ``sleep_until(t)``. The loop only ever asks a clock
for the time and sleeps on absolute deadlines, so swapping :class:`RealClock` for
:class:`SimClock` runs the same code faster than real time.
"""

from __future__ import annotations

import os
import time
from typing import Protocol

from odolab.robot.errors import RobotConfigError

__all__ = ["Clock", "RealClock", "SimClock", "set_realtime"]


class Clock(Protocol):
    """What the loop, driver and watchdog need from a clock."""

    def now(self) -> float:
        """Current time (s), monotonic."""
        ...

    def sleep_until(self, t: float) -> None:
        """Return at time ``t`` or as soon after as possible (at once if ``t`` is past)."""
        ...


class RealClock:
    """The host's monotonic clock (``time.perf_counter``).

    ``spin`` (s): the last part of each sleep is spent polling the clock instead of in the OS
    sleep, trading CPU for wake-up accuracy. 0 (the default) never spins.
    """

    def __init__(self, spin: float = 0.0) -> None:
        if spin < 0:
            raise RobotConfigError(f"clock spin is {spin!r} s, expected >= 0")
        self.spin = float(spin)

    def now(self) -> float:
        return time.perf_counter()

    def sleep_until(self, t: float) -> None:
        remaining = t - time.perf_counter()
        if remaining > self.spin:
            time.sleep(remaining - self.spin)
        if self.spin > 0:
            while time.perf_counter() < t:
                pass


class SimClock:
    """Simulated time: ``sleep_until`` jumps straight to the deadline."""

    def __init__(self, start: float = 0.0) -> None:
        self._t = float(start)

    def now(self) -> float:
        return self._t

    def sleep_until(self, t: float) -> None:
        if t > self._t:
            self._t = float(t)

    def advance(self, dt: float) -> None:
        """Move time forward by ``dt`` seconds (e.g. the cost of work, in a test)."""
        if dt < 0:
            raise RobotConfigError(f"clock advance is {dt!r} s, expected >= 0")
        self._t += float(dt)


def set_realtime(enable: bool = True, priority: int = 10) -> bool:
    """Put the calling thread in the SCHED_FIFO real-time class (or back to normal).

    Returns False when the OS refuses (no privilege, not Linux); the loop then runs as a normal
    thread. The loop sleeps between cycles, so a real-time loop does not starve the machine.
    """
    try:
        if enable:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
        else:
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    except (AttributeError, OSError, ValueError):
        return False
    return True
