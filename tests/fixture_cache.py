"""Expensive session fixtures built once for all test processes (issue 36).

`make test` runs pytest on two xdist workers, and a session fixture is built by each worker that
needs it: the tracked demo (20 s) and the independent simulators' fits (80 s) were built twice.
:func:`cached` builds such a result once, under a file lock, in ``.test-cache/`` at the project's
root (git ignores it; a fresh clone starts empty), keyed by a hash of odolab's source, the files
the builder is defined in, the installed numeric libraries and the builder's arguments: a change
to any of them builds anew. Every caller gets its own copy of the folder the builder wrote (in its
own temporary folder), with the paths in the result moved there, so a test that writes into a demo's
notebook changes only its own copy, as before.

``ODOLAB_TEST_CACHE=0`` turns the cache off (every process builds, as pytest alone would);
``ODOLAB_TEST_CACHE_DIR`` puts it elsewhere (tests/determinism.py gives its run a fresh one).
"""

from __future__ import annotations

import copy
import dataclasses
import fcntl
import hashlib
import importlib.metadata
import os
import pickle
import shutil
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypeVar

T = TypeVar("T")

ROOT = Path(__file__).resolve().parents[1]
CACHE = Path(os.environ.get("ODOLAB_TEST_CACHE_DIR") or ROOT / ".test-cache")
_LIBS = ("numpy", "scipy", "numba", "statsmodels", "polars", "matplotlib")


def _digest(parts: Iterable[str], files: Iterable[Path]) -> str:
    h = hashlib.sha256()
    h.update(sys.version.encode())
    for lib in _LIBS:
        try:
            h.update(f"{lib}={importlib.metadata.version(lib)}".encode())
        except importlib.metadata.PackageNotFoundError:
            h.update(lib.encode())
    for part in parts:
        h.update(b"\0" + part.encode())
    for f in sorted(files):
        h.update(b"\0" + str(f.relative_to(ROOT)).encode() + b"\0" + f.read_bytes())
    return h.hexdigest()[:16]


def source_files() -> list[Path]:
    """odolab's own source, data and templates: what a build's result depends on."""
    src = ROOT / "src" / "odolab"
    return [p for p in src.rglob("*") if p.is_file() and "__pycache__" not in p.parts]


def relocate(obj: Any, old: Path, new: Path, _depth: int = 0) -> Any:
    """``obj`` with every path (and path-like string) under ``old`` moved under ``new``."""
    if _depth > 8:
        return obj
    d = _depth + 1
    if isinstance(obj, Path):
        try:
            return new / obj.relative_to(old)
        except ValueError:
            return obj
    if isinstance(obj, str):
        return str(new) + obj[len(str(old)) :] if obj.startswith(str(old)) else obj
    if isinstance(obj, dict):
        return {k: relocate(v, old, new, d) for k, v in obj.items()}
    if isinstance(obj, list):
        return [relocate(v, old, new, d) for v in obj]
    if isinstance(obj, tuple) and not hasattr(obj, "_fields"):
        return tuple(relocate(v, old, new, d) for v in obj)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        changes = {
            f.name: relocate(getattr(obj, f.name), old, new, d)
            for f in dataclasses.fields(obj)
            if f.init
        }
        return dataclasses.replace(obj, **changes)
    return obj


def cached(
    name: str,
    build: Callable[[Path], T],
    dest: Path,
    *,
    key: Iterable[str] = (),
    depends_on: Iterable[Path] = (),
) -> T:
    """``build(folder)``'s result, built once for every process and run with the same inputs;
    the folder it wrote is copied to ``dest`` and the result's paths point there."""
    if os.environ.get("ODOLAB_TEST_CACHE", "1") == "0":
        dest.mkdir(parents=True, exist_ok=True)
        return build(dest)
    shift = os.environ.get("ODOLAB_TEST_SEED_SHIFT", "0")  # (tests/bounds.py's other seeds)
    digest = _digest([name, f"seed shift {shift}", *key], [*source_files(), *depends_on])
    CACHE.mkdir(exist_ok=True)
    (CACHE / ".gitignore").write_text("*\n", encoding="utf-8")
    folder = CACHE / f"{name}-{digest}"
    done = folder / ".result.pickle"
    with (CACHE / f"{name}.lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # the other worker waits for one build
        if not done.is_file():
            for stale in CACHE.glob(f"{name}-*"):
                shutil.rmtree(stale, ignore_errors=True)
            (folder / "data").mkdir(parents=True)
            result = build(folder / "data")
            tmp = done.with_suffix(".partial")
            tmp.write_bytes(pickle.dumps(result))
            tmp.replace(done)
        result = pickle.loads(done.read_bytes())
        if dest.exists():
            shutil.rmtree(dest)
        shutil.copytree(folder / "data", dest, symlinks=True)
    return relocate(result, folder / "data", dest)  # type: ignore[no-any-return]


#: results :func:`memo` loaded or built in this process
_MEMO: dict[str, Any] = {}


def memo(
    name: str,
    build: Callable[[], T],
    *,
    key: Iterable[str] = (),
    depends_on: Iterable[Path] = (),
) -> T:
    """``build()``'s result (a value, no folder: a fit, a simulated run), built once for every
    process and run with the same ``name`` and ``key``: tests that need the same expensive fit
    share it across xdist's workers. ``build`` must be a pure function of its key and of
    odolab's source (the key names every input the caller varies)."""
    if os.environ.get("ODOLAB_TEST_CACHE", "1") == "0":
        return build()
    shift = os.environ.get("ODOLAB_TEST_SEED_SHIFT", "0")  # (tests/bounds.py's other seeds)
    digest = _digest([name, f"seed shift {shift}", *key], [*source_files(), *depends_on])
    if digest in _MEMO:
        return _MEMO[digest]  # type: ignore[no-any-return]
    folder = CACHE / "memo"
    folder.mkdir(parents=True, exist_ok=True)
    (CACHE / ".gitignore").write_text("*\n", encoding="utf-8")
    done = folder / f"{name}-{digest}.pickle"
    with (folder / f"{name}-{digest}.lock").open("w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # another worker building the same waits for it
        if done.is_file():
            result = pickle.loads(done.read_bytes())
        else:
            for stale in folder.glob(f"{name}-*"):  # other keys' and older sources' results
                if stale.stat().st_mtime < time.time() - 86400:
                    stale.unlink(missing_ok=True)
            result = build()
            tmp = done.with_suffix(".partial")
            tmp.write_bytes(pickle.dumps(result))
            tmp.replace(done)
    _MEMO[digest] = result
    return result  # type: ignore[no-any-return]


@contextmanager
def slip_fits_once() -> Iterator[None]:
    """While on, odolab's slip fit (:func:`odolab.calibration.slipfit.fit_slip_model`, a pure
    function, 3 s of CPU) returns the result of an earlier call with the same arguments
    (compared as pickled bytes) in any test process (:func:`memo`), instead of fitting again:
    the tracked demo, ``calibrate compare`` on the demo's runs and ``calibrate lsq --model slip``
    after ``compare`` fit the same models. Everything around the fit still runs, and arguments
    that differ in any byte fit anew, so a test comparing two paths still sees each path's own
    inputs. Not for tests that change how the fit computes (compiled kernels off, a patched
    function inside it): the memo would give them the unchanged fit's result."""
    from odolab.calibration import slipfit

    original = slipfit.fit_slip_model

    def fit_once(*args: Any, **kwargs: Any) -> Any:
        blob = pickle.dumps((args, sorted(kwargs.items())))
        key = hashlib.sha256(blob).hexdigest()
        result = memo("slip-fit", lambda: original(*args, **kwargs), key=[key])
        return copy.deepcopy(result)

    slipfit.fit_slip_model = fit_once  # type: ignore[assignment]
    try:
        yield
    finally:
        slipfit.fit_slip_model = original  # type: ignore[assignment]


def demo_builder(truth: str) -> Callable[[Path], Any]:
    """The builder of the lab's demo on ``truth`` (``odolab demo --truth TRUTH --out FOLDER``:
    ``run_lab`` with its defaults and the CLI's flags) for :func:`cached`: ``(LabResult, the progress steps it
    reported)``."""

    def build(folder: Path) -> Any:
        from odolab.app.demo import run_lab
        from odolab.cli.wording import flag

        steps: list[str] = []
        with slip_fits_once():  # the tests that rerun its `calibrate compare` reuse its fits
            result = run_lab(
                folder, truth=truth, progress=lambda s, d, t: steps.append(s), flag=flag
            )
        return result, steps

    return build
