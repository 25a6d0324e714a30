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

from rewrite_warmup import warm

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


@pytest.mark.usefixtures("writing")
def test_a_module_whose_rewriting_warns_is_left_for_the_worker(
    tmp_path: Path, pytestconfig: pytest.Config
) -> None:
    """pytest warns of an assert that is always true (a tuple) when it rewrites the module; a
    worker that finds the module cached would never say it, so the warm-up leaves it."""
    f = tmp_path / "test_tuple.py"
    f.write_text('def test_():\n    assert (1 == 2, "always true")\n', encoding="utf-8")
    assert warm(pytestconfig, [f], 1) == 0
    assert not _pyc(f).exists()


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


FOUND = """
import sys
from pathlib import Path
from _pytest.config import Config
from rewrite_warmup import modules_to_rewrite
root = Path(sys.argv[1])
config = Config.fromdictargs({}, ["-p", "no:cacheprovider", "--ignore", str(root / "skipped"), str(root)])
for f in modules_to_rewrite(config):
    print(f.relative_to(root))
"""


def test_only_the_folders_pytest_enters_are_searched(tmp_path: Path) -> None:
    """`pytest -n 4 .` in a checkout with its venv: the venv's own test files (numpy's, scipy's:
    thousands) are not rewritten, nor hidden, ``norecursedirs`` or ``--ignore``d folders."""
    for rel in (
        "tests/test_a.py", "tests/conftest.py", "tests/helper.py", "tests/sub/test_b.py",
        "env/lib/test_venv.py", ".hidden/test_h.py", "build/test_build.py",
        "node_modules/test_n.py", "skipped/test_s.py",
    ):  # fmt: skip
        f = tmp_path / rel
        f.parent.mkdir(parents=True, exist_ok=True)
        f.write_text("def test_():\n    assert True\n", encoding="utf-8")
    (tmp_path / "env" / "pyvenv.cfg").write_text("home = /usr/bin\n", encoding="utf-8")
    env = {**os.environ, "PYTHONPATH": str(TESTS)}
    proc = subprocess.run(
        [sys.executable, "-c", FOUND, str(tmp_path)],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["tests/conftest.py", "tests/sub/test_b.py", "tests/test_a.py"]


WORKER_CONFTEST = """
import os
from pathlib import Path
from _pytest.assertion.rewrite import PYC_TAIL


def pytest_configure(config):
    if hasattr(config, "workerinput"):  # a worker, before it collects: the cache is there
        here = Path(__file__).parent
        cached = (here / "__pycache__" / ("test_one" + PYC_TAIL)).exists()
        (here / f"seen-{config.workerinput['workerid']}").write_text(str(cached))
"""


def test_xdist_s_controller_fills_the_cache_before_its_workers_start(tmp_path: Path) -> None:
    """The wiring: under ``-n 2`` the controller (and only it) rewrites, before any worker."""
    (tmp_path / "conftest.py").write_text(WORKER_CONFTEST, encoding="utf-8")
    _modules(tmp_path, 1)
    (tmp_path / "test_m0.py").rename(tmp_path / "test_one.py")
    env = {**os.environ, "PYTHONPATH": str(TESTS), "PYTHONDONTWRITEBYTECODE": ""}
    cmd = [sys.executable, "-m", "pytest", "-n", "2", "-p", "rewrite_warmup", "-q"]
    cmd += [
        "-p",
        "no:cacheprovider",
        "-p",
        "no:randomly",
        "--rootdir",
        str(tmp_path),
        str(tmp_path),
    ]
    proc = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    seen = sorted(p.read_text() for p in tmp_path.glob("seen-*"))
    assert seen == ["True", "True"]
