"""The suite's own rules (tests/suite_plugin.py), checked on a throwaway test file: a skip fails a
CI run, and the bound measurements (seed shift, assertion log) do what tests/bounds.py needs."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

TESTS = Path(__file__).resolve().parents[1]

SAMPLE = """
import numpy as np
import pytest


def test_skips():
    pytest.skip("no reason in CI")


def test_draws():
    value = float(np.random.default_rng(7).random())
    assert value < 2.0
    print("DRAW", value)
"""


def _pytest(folder: Path, env: dict[str, str], *args: str) -> subprocess.CompletedProcess[str]:
    (folder / "test_sample.py").write_text(SAMPLE, encoding="utf-8")
    drop = ("CI", "ODOLAB_ASSERT_LOG", "PYTEST_XDIST_WORKER", "ODOLAB_TEST_SEED_SHIFT")
    full = {k: v for k, v in os.environ.items() if k not in drop}
    full.update({"PYTHONPATH": str(TESTS), "PYTHONDONTWRITEBYTECODE": "1", **env})
    cmd = [sys.executable, "-m", "pytest", "-p", "suite_plugin", "-p", "no:randomly", "-q", "-s"]
    cmd += ["-p", "no:cacheprovider", "--rootdir", str(folder), *args, str(folder)]
    return subprocess.run(cmd, cwd=folder, env=full, capture_output=True, text=True, timeout=120)


def test_a_skip_fails_a_ci_run_and_names_the_test(tmp_path: Path) -> None:
    proc = _pytest(tmp_path, {"CI": "true"})
    assert proc.returncode == 1, proc.stdout
    assert "skipped in CI (not allowed)" in proc.stdout
    assert "test_sample.py::test_skips: Skipped: no reason in CI" in proc.stdout


def test_a_skip_is_a_skip_on_a_developer_machine(tmp_path: Path) -> None:
    proc = _pytest(tmp_path, {})
    assert proc.returncode == 0, proc.stdout
    assert "1 passed, 1 skipped" in proc.stdout


@pytest.mark.parametrize("shift", ["0", "3"])
def test_the_seed_shift_and_the_assertion_log(tmp_path: Path, shift: str) -> None:
    import numpy as np

    log = tmp_path / "log"
    proc = _pytest(
        tmp_path,
        {"ODOLAB_TEST_SEED_SHIFT": shift, "ODOLAB_ASSERT_LOG": str(log)},
        "-o",
        "enable_assertion_pass_hook=true",
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    drawn = float(proc.stdout.split("DRAW ")[1].split()[0])
    assert drawn == float(np.random.default_rng(7 + int(shift)).random())
    (record,) = [json.loads(line) for line in log.with_suffix(".main").read_text().splitlines()]
    assert record["orig"] == "value < 2.0" and record["shift"] == int(shift)
    assert record["expl"].startswith(f"{drawn!r} < 2.0") or record["expl"].startswith(
        f"{drawn} < 2.0"
    )
