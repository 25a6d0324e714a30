"""Rewrite the test modules' asserts once, before xdist starts its workers (a pytest plugin,
loaded by tests/conftest.py).

pytest rewrites each test module's ``assert`` statements at import and keeps the result in
``__pycache__`` (``*.pytest-*.pyc``). In a fresh clone that cache is empty, and xdist's workers
all start at once and collect every module: each of them rewrites the whole suite itself, about
9 s of CPU a worker on this project (a cached collection takes 7.5 s, an uncached one 16.5 s).
Here the controller process rewrites each module once, split over the machine's cores, and
writes pytest's own cache files; the workers then read them, as on any second run.

It only fills pytest's cache, with pytest's own functions and the run's own configuration (so a
run with ``enable_assertion_pass_hook`` writes what that run would), and changes nothing a test
sees: it looks only in the folders pytest would enter (not a virtual environment, not a hidden
or ``norecursedirs`` folder), a module whose cache file is already valid is left alone, and a
module that fails to parse or whose rewriting warns (an assert that is always true) is left
for the worker to rewrite and report; anything unexpected (another pytest's private names)
turns the warm-up off. ``PYTHONDONTWRITEBYTECODE`` turns it off, as it turns off pytest's own writing.
"""

from __future__ import annotations

import fnmatch
import os
import signal
import sys
import threading
import warnings
from pathlib import Path
from typing import Any

import pytest


def _is_controller(config: pytest.Config) -> bool:
    """Whether this process is xdist's controller about to start workers."""
    if hasattr(config, "workerinput"):
        return False
    try:
        workers = config.getoption("numprocesses")
    except ValueError:  # no xdist
        return False
    return bool(workers) and not config.getoption("collectonly")


def modules_to_rewrite(config: pytest.Config) -> list[Path]:
    """The files pytest would rewrite below the run's arguments: its test modules (the
    ``python_files`` patterns) and every ``conftest.py``, in the folders pytest would enter
    (not hidden ones, not ``norecursedirs``, not a virtual environment, not ``--ignore``d)."""
    patterns = config.getini("python_files") or ["test_*.py", "*_test.py"]
    skip_dirs = config.getini("norecursedirs") or []
    ignored = {Path(p).absolute() for p in (config.getoption("ignore", None) or [])}
    ignored_globs = config.getoption("ignore_glob", None) or []

    def wanted(f: Path) -> bool:
        return f.name == "conftest.py" or any(fnmatch.fnmatch(f.name, p) for p in patterns)

    def entered(d: Path) -> bool:
        return not (
            d.name.startswith(".")
            or d.name == "__pycache__"
            or any(fnmatch.fnmatch(d.name, p) for p in skip_dirs)
            or (d / "pyvenv.cfg").exists()  # a virtual environment, as pytest tells one
            or d.absolute() in ignored
            or any(fnmatch.fnmatch(str(d), g) for g in ignored_globs)
        )

    def entered_file(f: Path) -> bool:
        return f not in ignored and not any(fnmatch.fnmatch(str(f), g) for g in ignored_globs)

    found: set[Path] = set()
    for arg in config.args:
        path = Path(arg.split("::")[0])
        path = (path if path.is_absolute() else config.invocation_params.dir / path).absolute()
        if path.is_file():
            found.add(path)
            continue
        if not path.is_dir():
            continue
        for root, dirs, files in os.walk(path):
            here = Path(root)
            dirs[:] = [d for d in dirs if entered(here / d)]
            for name in files:
                f = here / name
                if name.endswith(".py") and wanted(f) and entered_file(f):
                    found.add(f)
    return sorted(found)


def warm(config: pytest.Config, files: list[Path], processes: int) -> int:
    """Rewrite and cache ``files`` whose cache is missing or stale, in ``processes`` forked
    processes; returns how many this process wrote (0 when the warm-up is off)."""
    if sys.dont_write_bytecode or not files:
        return 0
    try:
        from _pytest.assertion import rewrite
    except ImportError:  # pragma: no cover - a pytest without the rewriter
        return 0
    needed = ("PYC_TAIL", "_read_pyc", "_rewrite_test", "_write_pyc", "get_cache_dir")
    if not all(hasattr(rewrite, name) for name in needed):
        return 0  # another pytest's private names: leave the rewriting to pytest
    key = getattr(rewrite, "assertstate_key", None)
    state = config.stash.get(key, None) if key is not None else None
    if state is None:  # asserts not rewritten at all (--assert=plain)
        return 0
    processes = max(1, min(processes, len(files)))
    if threading.active_count() > 1:  # a fork copies one thread: another's lock would hang it
        processes = 1
    children = []
    for k in range(1, processes):
        pid = os.fork()
        if pid == 0:  # a child: its share, then out without running the parent's exit handlers
            code = 1
            try:
                signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
                _rewrite_share(rewrite, state, config, files[k::processes])
                code = 0
            finally:
                os._exit(code)
        children.append(pid)
    try:
        return _rewrite_share(rewrite, state, config, files[0::processes])
    finally:
        for pid in children:
            os.waitpid(pid, 0)


def _rewrite_share(rewrite: Any, state: Any, config: pytest.Config, files: list[Path]) -> int:
    """What ``AssertionRewritingHook.exec_module`` does for a module it has not cached, without
    executing the module."""
    done = 0
    for fn in files:
        cache_dir = rewrite.get_cache_dir(fn)
        pyc = cache_dir / (fn.name[:-3] + rewrite.PYC_TAIL)
        if rewrite._read_pyc(fn, pyc) is not None:
            continue
        try:
            cache_dir.mkdir(parents=True, exist_ok=True)
            with warnings.catch_warnings(record=True) as said:
                warnings.simplefilter("always")
                source_hash, co = rewrite._rewrite_test(fn, config)
        except (OSError, SyntaxError, ValueError):
            continue  # pytest meets it again at import and reports it there
        if said:  # (an assert that is always true): left for the worker, whose run reports it
            continue
        if rewrite._write_pyc(state, co, source_hash, pyc):
            done += 1
    return done


def pytest_configure(config: pytest.Config) -> None:
    if not _is_controller(config):
        return
    try:
        warm(config, modules_to_rewrite(config), len(os.sched_getaffinity(0)))
    except Exception:  # a faster start is not worth a failed run
        return
