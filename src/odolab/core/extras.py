"""What each optional part of odolab needs installed, and the one sentence when it is missing.

``pip install odolab`` installs the core: integrate, drive a robot, keep the notebook, analyse
(Table I), calibrate, evaluate. The extras add what the name says (pyproject.toml's
``[project.optional-dependencies]``, docs/architecture.md "What the core installs"). No core
module imports an extra's package when it is imported; a command that needs a missing extra is
refused here, before it writes anything:
``odolab track needs the video extra: pip install 'odolab[video]'``.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Iterable

from odolab.core.errors import OdolabError

__all__ = [
    "COMMAND_EXTRAS",
    "COMMAND_PREFERS",
    "COMPILING_NOTE",
    "EXTRAS",
    "NO_NUMBA_NOTE",
    "MissingExtraError",
    "command_extra",
    "extra_of_missing",
    "install_line",
    "missing_modules",
    "require",
]

#: Each extra -> the top-level modules it brings (import names, as pyproject.toml's packages
#: install them; tests/core/test_extras.py checks the two agree).
EXTRAS: dict[str, tuple[str, ...]] = {
    "report": ("matplotlib", "jinja2"),
    "web": ("starlette", "uvicorn", "multipart", "jinja2", "matplotlib"),
    "ros": ("rosbags", "mcap", "mcap_ros2", "foxglove"),
    "video": ("cv2", "matplotlib"),
    "laser": ("small_gicp", "rosbags", "mcap", "mcap_ros2"),
    "parquet": ("pyarrow",),
    "fleet": ("dask", "distributed", "cryptography"),
    "pandas": ("pandas",),
    "fast": ("numba", "llvmlite"),
}

#: Commands (their words) that cannot start without an extra: checked before they run. Others
#: need one only for some inputs (a Parquet file, a bag, --foxglove, a Dask scheduler): those
#: are refused where the package is first imported, before the output is written.
COMMAND_EXTRAS: dict[tuple[str, ...], str] = {
    ("report",): "report",
    ("demo",): "report",  # it ends in the lab report
    ("serve",): "web",
    ("track",): "video",
    ("track-photo",): "video",
    ("markers",): "video",
    ("camera",): "video",
    ("sim", "video"): "video",
    ("sim", "photo"): "video",
    ("scans",): "laser",
    ("sim", "scans"): "laser",
    ("export", "mcap"): "ros",
    ("fleet", "report"): "report",
}

#: Commands that need an extra only for some inputs, where a missing package that several extras
#: bring is to be named by this one (``calibrate sensor`` on a bag: laser, not ros).
COMMAND_PREFERS: dict[tuple[str, ...], str] = {
    ("calibrate", "sensor"): "laser",
}


class MissingExtraError(OdolabError):
    """Something asked for a package of an extra that is not installed."""

    def __init__(self, extra: str, what: str = "this") -> None:
        self.extra = extra
        self.what = what
        super().__init__(f"{what} needs the {extra} extra: {install_line(extra)}")


def install_line(extra: str) -> str:
    """The exact command that installs ``extra``."""
    return f"pip install 'odolab[{extra}]'"


#: Said once a process, on stderr, when a kernel first runs without numba (odolab.core._jit): the
#: fast extra is the one extra whose absence changes speed, not what runs.
NO_NUMBA_NOTE = (
    "odolab: numba is not installed, so the kernels run as plain Python (slower on long logs); "
    f"for the compiled kernels: {install_line('fast')}"
)

#: Said once a process, on stderr when it is a terminal, when numba starts compiling a kernel
#: that its cache does not hold (odolab.core._jit): a fresh install's first covariance or
#: simulation is otherwise 10-20 s of silence.
COMPILING_NOTE = (
    "odolab: compiling its numerical kernels for this machine, once: the first use of each takes "
    "seconds (all of them together up to a minute), later runs load them from numba's cache"
)


def _importable(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):  # a finder that refuses it; a module without a spec
        return False


def missing_modules(extra: str) -> list[str]:
    """The modules of ``extra`` that cannot be imported (without importing any)."""
    return [m for m in EXTRAS[extra] if not _importable(m)]


def require(extra: str, what: str) -> None:
    """Raise :class:`MissingExtraError` (``what needs the EXTRA extra: pip install ...``)
    unless every package of ``extra`` can be imported."""
    if missing_modules(extra):
        raise MissingExtraError(extra, what)


def command_extra(
    words: Iterable[str], table: dict[tuple[str, ...], str] | None = None
) -> str | None:
    """The extra the command ``odolab WORDS...`` cannot start without (or, with ``table``, the
    one that table gives it), or None."""
    table = COMMAND_EXTRAS if table is None else table
    ws = tuple(w for w in words if not w.startswith("-"))
    for n in (2, 1):
        if len(ws) >= n and ws[:n] in table:
            return table[ws[:n]]
    return None


def extra_of_missing(err: ImportError, prefer: str | None = None) -> str | None:
    """The extra whose package ``err`` (a failed import) is missing: ``prefer`` where that extra
    brings it, else the first extra that does; None for a module no extra brings."""
    name = (err.name or "").partition(".")[0]
    if not name:
        return None
    if prefer is not None and name in EXTRAS.get(prefer, ()):
        return prefer
    return next((e for e, mods in EXTRAS.items() if name in mods), None)
