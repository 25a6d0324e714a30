"""The import contract in pyproject.toml ([tool.importlinter]) bites.

Each test copies src/odolab to a temporary folder, adds one import against the layers (or a cycle),
and runs ``lint-imports`` on the copy with the project's own contract: it must fail and name the
offending import. The unchanged copy must pass, so a failure is the added import's doing.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
LINT_IMPORTS = Path(sys.executable).parent / "lint-imports"

pytestmark = pytest.mark.skipif(not LINT_IMPORTS.exists(), reason="import-linter not installed")


def _copy(tmp: Path) -> Path:
    shutil.copytree(
        ROOT / "src" / "odolab",
        tmp / "src" / "odolab",
        ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"),
    )
    shutil.copy(ROOT / "pyproject.toml", tmp / "pyproject.toml")
    return tmp


def _lint(tmp: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(tmp / "src")}
    return subprocess.run(
        [str(LINT_IMPORTS), "--config", str(tmp / "pyproject.toml"), "--no-cache"],
        cwd=tmp,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )


def _append(path: Path, line: str) -> None:
    path.write_text(path.read_text(encoding="utf-8") + f"\n{line}  # noqa\n", encoding="utf-8")


def test_the_project_keeps_its_contract(tmp_path: Path) -> None:
    out = _lint(_copy(tmp_path))
    assert out.returncode == 0, out.stdout + out.stderr
    assert "BROKEN" not in out.stdout and out.stdout.count("KEPT") >= 2


@pytest.mark.parametrize(
    ("module", "line", "expected"),
    [
        # core must not know the notebook
        (
            "core/trials.py",
            "import odolab.store.notebook",
            "odolab.core.trials -> odolab.store.notebook",
        ),
        # the notebook must not know the analysis above it
        (
            "store/records.py",
            "import odolab.analysis.core",
            "odolab.store.records -> odolab.analysis",
        ),
        # a reader must not know the calibration
        ("io/run.py", "import odolab.calibration.lsq", "odolab.io.run -> odolab.calibration.lsq"),
        # the live stack gets its plant through robot.plant, never from the simulator (issue 27)
        ("robot/loop.py", "import odolab.sim.physics", "odolab.robot.loop -> odolab.sim.physics"),
        # nor does the simulator know the robot stack, nor tracking either
        ("sim/physics.py", "import odolab.robot.plant", "odolab.sim.physics -> odolab.robot.plant"),
        ("tracking/__init__.py", "import odolab.robot", "odolab.tracking -> odolab.robot"),
        # a new top-level module must be placed in a layer
        ("unplaced.py", "import odolab.core.errors", "odolab.unplaced"),
    ],
)
def test_an_import_against_the_layers_fails_lint(
    tmp_path: Path, module: str, line: str, expected: str
) -> None:
    tmp = _copy(tmp_path)
    target = tmp / "src" / "odolab" / module
    if not target.exists():
        target.write_text('"""A module nobody placed in a layer."""\n', encoding="utf-8")
    _append(target, line)
    out = _lint(tmp)
    assert out.returncode != 0
    assert "BROKEN" in out.stdout
    assert expected in out.stdout, out.stdout


def test_a_cycle_between_readers_fails_lint(tmp_path: Path) -> None:
    tmp = _copy(tmp_path)
    _append(tmp / "src" / "odolab" / "io" / "encoder_csv.py", "import odolab.io.registry")
    out = _lint(tmp)
    assert out.returncode != 0
    assert "No cycles are allowed in odolab.io" in out.stdout, out.stdout
