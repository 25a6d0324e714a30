"""tests/rewrite_warmup.py: the controller's one rewrite of the test modules fills pytest's own
cache with what pytest itself would write, and leaves alone what it cannot do."""

from __future__ import annotations

import os
import subprocess
import sys
import types
from pathlib import Path

import pytest
from _pytest.assertion import rewrite

from rewrite_warmup import modules_to_rewrite, warm

TESTS = Path(__file__).resolve().parents[1]

MODULE = """
def test_adds():
    x = 1
    assert x + 1 == {value}, "a message"
"""


def _pyc(fn: Path) -> Path:
    return rewrite.get_cache_dir(fn) / (fn.name[:-3] + rewrite.PYC_TAIL)


def _modules(folder: Path, n: int) -> list[Path]:
    files = []
    for k in range(n):
        f = folder / f"test_m{k}.py"
        f.write_text(MODULE.format(value=k + 2), encoding="utf-8")
        files.append(f)
    return files


@pytest.fixture
def writing(monkeypatch: pytest.MonkeyPatch) -> None:
    """Byte-code writing on (the developer's environment may turn it off)."""
    monkeypatch.setattr(sys, "dont_write_bytecode", False)


@pytest.mark.usefixtures("writing")
def test_the_cache_holds_what_pytest_would_write(
    tmp_path: Path, pytestconfig: pytest.Config
) -> None:
    (f,) = _modules(tmp_path, 1)
    assert rewrite._read_pyc(f, _pyc(f)) is None
    assert warm(pytestconfig, [f], 1) == 1
    cached = rewrite._read_pyc(f, _pyc(f))
    assert cached is not None
    assert cached == rewrite._rewrite_test(f, pytestconfig)[1]  # the same code, asserts rewritten
    (test,) = [c for c in cached.co_consts if isinstance(c, types.CodeType)]
    assert any(name.startswith("@py_assert") for name in test.co_varnames)
    assert warm(pytestconfig, [f], 1) == 0  # a valid cache is left alone
    f.write_text(MODULE.format(value=9), encoding="utf-8")  # an edit makes it stale
    assert warm(pytestconfig, [f], 1) == 1
    assert rewrite._read_pyc(f, _pyc(f)) == rewrite._rewrite_test(f, pytestconfig)[1]


@pytest.mark.usefixtures("writing")
def test_a_module_that_does_not_parse_is_left_to_pytest(
    tmp_path: Path, pytestconfig: pytest.Config
) -> None:
    bad = tmp_path / "test_bad.py"
    bad.write_text("def test_(:\n", encoding="utf-8")
    (good,) = _modules(tmp_path, 1)
    assert warm(pytestconfig, [bad, good], 1) == 1
    assert not _pyc(bad).exists()
    assert rewrite._read_pyc(good, _pyc(good)) is not None


def test_no_byte_code_writing_writes_nothing(
    tmp_path: Path, pytestconfig: pytest.Config, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(sys, "dont_write_bytecode", True)
    (f,) = _modules(tmp_path, 1)
    assert warm(pytestconfig, [f], 1) == 0
    assert not _pyc(f).parent.exists()


def test_the_suite_s_modules_are_found(pytestconfig: pytest.Config) -> None:
    found = set(modules_to_rewrite(pytestconfig))
    assert Path(__file__).resolve() in found or not pytestconfig.args  # (run by node id)
    here = [p for p in found if p.parent == Path(__file__).resolve().parent]
    assert all(p.name.startswith("test_") or p.name == "conftest.py" for p in found), here


@pytest.mark.usefixtures("writing")
def test_with_other_threads_running_it_does_not_fork(
    tmp_path: Path, pytestconfig: pytest.Config, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A process with threads is not forked (a fork copies only the calling thread, and a lock
    another thread held would never be released in the child): it rewrites every module."""
    import threading

    files = _modules(tmp_path, 3)
    monkeypatch.setattr(threading, "active_count", lambda: 2)
    monkeypatch.setattr(os, "fork", lambda: pytest.fail("forked"))
    assert warm(pytestconfig, files, 3) == 3
    assert all(rewrite._read_pyc(f, _pyc(f)) is not None for f in files)


FORKED = """
import sys
import types
from pathlib import Path
from _pytest.config import Config
from rewrite_warmup import warm
folder = Path(sys.argv[1])
config = Config.fromdictargs({}, ["-p", "no:cacheprovider", str(folder)])
files = sorted(folder.glob("test_*.py"))
print("written", warm(config, files, 3))
"""


def test_the_processes_share_the_modules(tmp_path: Path) -> None:
    """Three processes (two forked children) write every module between them."""
    files = _modules(tmp_path, 5)
    env = {**os.environ, "PYTHONPATH": str(TESTS), "PYTHONDONTWRITEBYTECODE": ""}
    proc = subprocess.run(
        [sys.executable, "-c", FORKED, str(tmp_path)],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert "written 2" in proc.stdout  # this process's share: modules 0 and 3
    assert all(rewrite._read_pyc(f, _pyc(f)) is not None for f in files)
