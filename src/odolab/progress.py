"""The one progress callback type: ``progress(done, total, what)``.

Library code never prints; long work reports through a callback of this type. ``done`` of
``total`` units are finished; ``what`` names the step or the item just finished ("" when there is
nothing to say). :func:`no_progress` is the do-nothing default.
"""

from __future__ import annotations

from collections.abc import Callable

__all__ = ["Progress", "no_progress"]

#: ``progress(done, total, what)``: ``done`` of ``total`` units finished, ``what`` the step/item.
Progress = Callable[[int, int, str], None]


def no_progress(done: int, total: int, what: str) -> None:
    """The default progress callback: does nothing."""
