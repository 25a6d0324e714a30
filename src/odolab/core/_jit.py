"""numba's names for the kernel modules, or plain Python where numba is not installed.

numba comes with the ``fast`` extra (numba and llvmlite are 211 MB of the core's site-packages
otherwise: docs/architecture.md, "What the core installs"). The kernels are numba-compatible
Python, so without numba they run unchanged in CPython, the way ``NUMBA_DISABLE_JIT=1`` runs
them, with the same results (to the last bit or two where numba fuses ``a * b + c``), slower on
long logs. With numba, every name here is numba's own.

Without numba, :func:`njit` leaves a function as it is, except that a kernel called from Python
(one not marked ``inline="always"``: the batch passes, the simulator's loop, the metrics) says
once a process, on stderr, :data:`odolab.core.extras.NO_NUMBA_NOTE`. The inlined helpers stay bare
functions (no wrapper in the plain kernels' inner loops); called one by one from Python (the
streaming odometry's steps), they cost what a numba dispatcher call costs, and no note is due.
"""

from __future__ import annotations

import functools
import importlib.util
import sys
import threading
import types
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, TextIO, TypeVar, cast

__all__ = [
    "HAVE_NUMBA",
    "get_num_threads",
    "njit",
    "note_compiling",
    "parallel_chunksize",
    "prange",
    "twin",
]

F = TypeVar("F", bound=Callable[..., object])

#: Whether the kernels are compiled (numba installed) or run as plain Python.
HAVE_NUMBA: bool = importlib.util.find_spec("numba") is not None

_noted = False
_note_lock = threading.Lock()


def _note() -> None:
    """Say :data:`odolab.core.extras.NO_NUMBA_NOTE` on stderr, the first time only."""
    global _noted
    with _note_lock:
        if _noted:
            return
        _noted = True
    from odolab.core.extras import NO_NUMBA_NOTE

    sys.stderr.write(NO_NUMBA_NOTE + "\n")
    sys.stderr.flush()


def _plain(func: F, inline: object) -> F:
    if inline == "always":
        return func

    @functools.wraps(func)
    def kernel(*args: object, **kwargs: object) -> object:
        if not _noted:
            _note()
        return func(*args, **kwargs)

    kernel.py_func = func  # type: ignore[attr-defined]  # as a numba dispatcher has it
    return kernel  # type: ignore[return-value]


def _plain_njit(*args: object, **options: object) -> object:
    """``@njit`` and ``@njit(...)`` without numba: the function itself (see the module)."""
    if len(args) == 1 and callable(args[0]) and not options:
        return _plain(args[0], None)
    inline = options.get("inline")
    return lambda func: _plain(func, inline)


def twin(func: F, namespace: dict[str, object], *, inline: bool = True) -> F:
    """The compiled twin of the plain kernel ``func``: ``njit(cache=True, inline="always")`` of a
    copy of it whose global names are looked up in ``namespace``, which gets the twin under
    ``func``'s name (``inline=False``: a kernel of its own, ``njit(cache=True)``, for a loop
    that Python calls).

    A plain module's kernels call each other by name (:mod:`odolab.core._step_kernels`), and a
    compiled kernel can only call compiled ones: the twins share a namespace made from the plain
    module's and see each other there (numba reads a name when it first compiles, so the order
    they are made in does not matter). The plain functions stay as they are."""
    copy = types.FunctionType(
        func.__code__, namespace, func.__name__, func.__defaults__, func.__closure__
    )
    copy.__qualname__ = func.__qualname__  # numba's cache files are named by these
    copy.__module__ = func.__module__
    copy.__doc__ = func.__doc__
    made = njit(cache=True, inline="always") if inline else njit(cache=True)
    compiled = cast(F, made(copy))
    namespace[func.__name__] = compiled
    return compiled


@contextmanager
def _plain_chunksize(size: int) -> Iterator[None]:
    yield


def _one_thread() -> int:
    return 1


_compiling_noted = False


def note_compiling(stream: TextIO | None = None) -> None:
    """Say :data:`odolab.core.extras.COMPILING_NOTE` once a process, where a person waits at a
    terminal (``stream``, default stderr, is a TTY); elsewhere (a pipe, a log file, a test's
    capture) nothing."""
    global _compiling_noted
    out = stream if stream is not None else sys.stderr
    try:
        tty = out.isatty()
    except (AttributeError, ValueError):  # a closed or odd stream
        tty = False
    if not tty:
        return
    with _note_lock:
        if _compiling_noted:
            return
        _compiling_noted = True
    from odolab.core.extras import COMPILING_NOTE

    out.write(COMPILING_NOTE + "\n")
    out.flush()


if TYPE_CHECKING or HAVE_NUMBA:  # numba's own names (untyped, as the kernels always saw them)
    from numba import get_num_threads, njit, parallel_chunksize, prange
    from numba.core import event as _event

    class _Compiling(_event.Listener):
        """numba's "numba:compile" event comes only when a kernel is compiled, not when it is
        loaded from the cache."""

        def on_start(self, event: object) -> None:
            note_compiling()

        def on_end(self, event: object) -> None:
            pass

    _event.register("numba:compile", _Compiling())  # type: ignore[no-untyped-call]
else:
    njit = _plain_njit
    prange = range
    get_num_threads = _one_thread
    parallel_chunksize = _plain_chunksize
