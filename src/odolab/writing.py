"""One argument order for every writer: ``write_x(path, obj)``.

Writers used to disagree (``write_encoder_csv(log, path)`` but ``write_trials_csv(path, trials)``).
Every writer now takes the path first. For the callers written before, :func:`path_first` still
accepts the old ``(obj, path)`` order, with a :class:`DeprecationWarning`.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path
from typing import TypeVar

__all__ = ["path_first"]

T = TypeVar("T")


def path_first(first: object, second: object, cls: type[T], writer: str) -> tuple[Path, T]:
    """``(path, obj)`` from a writer's two arguments, in either order; ``obj`` must be a ``cls``.

    The old order ``(obj, path)`` is swapped with a :class:`DeprecationWarning` naming ``writer``.
    """
    if isinstance(first, cls) and isinstance(second, str | os.PathLike):
        warnings.warn(
            f"{writer}(obj, path) is the old argument order; call {writer}(path, obj)",
            DeprecationWarning,
            stacklevel=3,
        )
        first, second = second, first
    if not isinstance(first, str | os.PathLike) or not isinstance(second, cls):
        raise TypeError(
            f"{writer}(path, obj) takes a path and a {cls.__name__}, got "
            f"{type(first).__name__} and {type(second).__name__}"
        )
    return Path(first), second
