"""The one progress callback type: ``progress(done, total, what)``.

Library code never prints; long work reports through a callback of this type. ``done`` of
``total`` units are finished (``total`` 0: not known in advance, ``done`` counts the steps so far);
``what`` names the step or the item just finished ("" when there is nothing to say).
:func:`no_progress` is the do-nothing default; :func:`steps` turns one into a message callback.
"""

from __future__ import annotations

from collections.abc import Callable

__all__ = ["Progress", "no_progress", "steps"]

#: ``progress(done, total, what)``: ``done`` of ``total`` units finished, ``what`` the step/item.
Progress = Callable[[int, int, str], None]


def no_progress(done: int, total: int, what: str) -> None:
    """The default progress callback: does nothing."""


def steps(progress: Progress | None) -> Callable[[str], None]:
    """``say(what)``: report one more step of unknown total to ``progress`` (None: nothing)."""
    report = progress or no_progress
    done = 0

    def say(what: str) -> None:
        nonlocal done
        done += 1
        report(done, 0, what)

    return say
