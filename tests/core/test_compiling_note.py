"""A fresh install's first use of a kernel compiles it for 10-20 s: odolab says so once, where a
person waits at a terminal, and nowhere else (odolab.core._jit.note_compiling)."""

from __future__ import annotations

import io
import os
import pty
import subprocess
import sys
from pathlib import Path

import pytest

from odolab.core import _jit
from odolab.core.extras import COMPILING_NOTE

ROOT = Path(__file__).resolve().parents[2]


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_the_note_is_said_once_and_only_to_a_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(_jit, "_compiling_noted", False)
    piped = io.StringIO()
    _jit.note_compiling(piped)
    assert piped.getvalue() == ""  # a pipe, a log file, a test's capture: nothing
    term = _Terminal()
    _jit.note_compiling(term)
    _jit.note_compiling(term)
    assert term.getvalue() == COMPILING_NOTE + "\n"


def _first_use(cache: Path) -> str:
    """What a process whose stderr is a terminal says when it first runs a kernel."""
    main, child = pty.openpty()
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(ROOT / "src")}
    code = "from odolab.core._kinematics_jit import chord; chord(0.1, True)"
    proc = subprocess.run(
        [sys.executable, "-c", code], stderr=child, stdout=subprocess.DEVNULL, env=env, timeout=120
    )
    os.close(child)
    said = b""
    while True:
        try:
            chunk = os.read(main, 4096)
        except OSError:  # the terminal's other end is closed: all is read
            break
        if not chunk:
            break
        said += chunk
    os.close(main)
    assert proc.returncode == 0, said
    return said.decode().replace("\r\n", "\n")


def test_a_cold_cache_is_said_at_a_terminal_and_a_warm_one_is_not(tmp_path: Path) -> None:
    assert _first_use(tmp_path) == COMPILING_NOTE + "\n"  # compiled: said once
    assert _first_use(tmp_path) == ""  # loaded from numba's cache: nothing to wait for
