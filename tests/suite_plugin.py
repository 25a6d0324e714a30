"""The suite's own rules, as a pytest plugin (loaded by tests/conftest.py).

- **No silent skips in CI.** With ``CI`` set, a skipped test fails the run, naming the test and its
  reason; CI has the real data (a missing data folder already fails there, tests/shared_data.py),
  Debian's chromium and every extra, so nothing it runs has a reason to skip. A skip that is right
  even in CI goes into :data:`SKIP_ALLOWED_IN_CI` with why.
- **Measuring the bounds** (opt-in, for the audit in docs/testing.md):
  ``ODOLAB_ASSERT_LOG=FILE`` with ``-o enable_assertion_pass_hook=true`` appends every passing
  assertion's location and values to ``FILE.<worker>`` (JSON lines), and
  ``ODOLAB_TEST_SEED_SHIFT=K`` adds ``K`` to every integer seed given to
  ``numpy.random.default_rng`` (in the tests and in odolab), so the same suite can be run on
  other seeds it could reasonably have used. Both are off in ``make test``; ``tests/bounds.py``
  drives them.
- **Ctrl-C is Ctrl-C.** A shell that starts the suite in the background (``make test &`` in a
  script, some CI runners) hands every process an *ignored* SIGINT, and Python then installs no
  KeyboardInterrupt handler: the tests of odolab's Ctrl-C handling (and the odolab processes they
  start) would see nothing. The suite puts Python's own handler back, in itself and so in what
  it starts (an exec resets a handled signal to its default; an ignored one stays ignored).
"""

from __future__ import annotations

import json
import os
import signal
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest

#: test id (as pytest reports it, without parameters) -> why its skip is right even in CI
SKIP_ALLOWED_IN_CI: dict[str, str] = {}

_SHIFT = int(os.environ.get("ODOLAB_TEST_SEED_SHIFT", "0") or 0)
_LOG = os.environ.get("ODOLAB_ASSERT_LOG", "")


def _shift_seeds() -> None:
    """``numpy.random.default_rng(seed)`` with ``seed + K`` (measurement runs only)."""
    original = np.random.default_rng

    def shifted(seed: Any = None, *args: Any, **kwargs: Any) -> np.random.Generator:
        if isinstance(seed, int | np.integer) and not isinstance(seed, bool):
            seed = int(seed) + _SHIFT
        elif isinstance(seed, Sequence) and not isinstance(seed, str | bytes):
            seed = [*seed, _SHIFT]
        return original(seed, *args, **kwargs)

    np.random.default_rng = shifted  # type: ignore[assignment]


if _SHIFT:
    _shift_seeds()

if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


#: the phase of the running test ("setup": an assert in a fixture, logged against whichever test
#: first asked for it, which the order decides)
_PHASE = ["call"]


@pytest.hookimpl(wrapper=True)
def pytest_runtest_setup(item: pytest.Item) -> Any:
    _PHASE[0] = "setup"
    try:
        return (yield)
    finally:
        _PHASE[0] = "call"


def _asserting_file(lineno: int) -> Path | None:
    """The file of the frame whose assert passed (the frame under pytest's hook caller), when it
    is not a library's: pytest also rewrites the asserts of plugins."""
    frame = sys._getframe(2)
    for _ in range(12):
        if frame is None:
            return None
        name = frame.f_code.co_filename
        if frame.f_lineno == lineno and "site-packages" not in name and "pluggy" not in name:
            return Path(name).resolve()
        frame = frame.f_back
    return None


def pytest_assertion_pass(item: pytest.Item, lineno: int, orig: str, expl: str) -> None:
    if not _LOG:
        return
    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
    path = _asserting_file(lineno)
    if path is None:  # an assert of a plugin pytest rewrote (hypothesis'), not a test's
        return
    root = Path(__file__).resolve().parents[1]
    record = {
        "test": item.nodeid,
        "phase": _PHASE[0],
        "file": str(path.relative_to(root)) if path.is_relative_to(root) else str(path),
        "line": lineno,
        "orig": orig,
        "expl": expl[:2000],
        "shift": _SHIFT,
        # hypothesis' examples depend on the modules loaded before (it draws constants from them)
        "hypothesis": bool(getattr(getattr(item, "obj", None), "is_hypothesis_test", False)),
    }
    with Path(f"{_LOG}.{worker}").open("a", encoding="utf-8") as fh:
        fh.write(json.dumps(record) + "\n")


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    """A failed assertion's values too (measurement runs only): a seed shift can move a number
    across its bound, and that number is what the audit wants."""
    if not _LOG or not report.failed or report.when != "call" or hasattr(report, "node"):
        return  # (a report with .node is a worker's, seen again on xdist's controller)
    crash = getattr(report.longrepr, "reprcrash", None)
    if crash is None:
        return
    lines = [ln for ln in str(crash.message).splitlines() if ln.strip().startswith("assert ")]
    if not lines:
        return
    try:
        file = str(Path(crash.path).resolve().relative_to(Path(__file__).resolve().parents[1]))
    except ValueError:
        return
    record = {
        "test": report.nodeid,
        "file": file,
        "line": crash.lineno,
        "orig": lines[0],
        "expl": lines[0],
        "shift": _SHIFT,
        "failed": True,
    }
    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
    with Path(f"{_LOG}.{worker}").open("a", encoding="utf-8") as fh:
        fh.write(json.dumps(record) + "\n")


class _SkipGuard:
    """Counts skips on the controller (xdist hands every report to it)."""

    def __init__(self) -> None:
        self.skipped: list[tuple[str, str]] = []

    @pytest.hookimpl
    def pytest_runtest_logreport(self, report: pytest.TestReport) -> None:
        if not report.skipped or hasattr(report, "wasxfail"):
            return
        base = report.nodeid.split("[", 1)[0]
        if base in SKIP_ALLOWED_IN_CI:
            return
        reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else str(report.longrepr)
        self.skipped.append((report.nodeid, str(reason)))

    @pytest.hookimpl(trylast=True)
    def pytest_sessionfinish(self, session: pytest.Session, exitstatus: int) -> None:
        if self.skipped and exitstatus == 0:
            session.exitstatus = pytest.ExitCode.TESTS_FAILED

    @pytest.hookimpl
    def pytest_terminal_summary(self, terminalreporter: Any) -> None:
        if not self.skipped:
            return
        terminalreporter.section("skipped in CI (not allowed)", red=True)
        for nodeid, reason in self.skipped:
            terminalreporter.write_line(f"{nodeid}: {reason}")
        terminalreporter.write_line(
            f"{len(self.skipped)} test(s) skipped with CI set: CI has the real data, chromium "
            "and every extra, so a skip there hides an untested behaviour "
            "(tests/suite_plugin.py: SKIP_ALLOWED_IN_CI lists the skips that are right in CI)"
        )


def pytest_configure(config: pytest.Config) -> None:
    if os.environ.get("CI") and not hasattr(config, "workerinput"):
        config.pluginmanager.register(_SkipGuard(), "odolab-skip-guard")
