"""The core's old module names keep working for a release (issue 41's move into odolab/core/).

``import odolab.kinematics`` (and ``odolab.models.slip``, ``odolab.lab``, ...) gives the very same
module object as the new name, and warns with a DeprecationWarning that names the new place.
A child process: the aliases are found only on a module's first import.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parents[2] / "src"

_PROBE = """
import warnings
warnings.simplefilter("error", DeprecationWarning)
import odolab
import odolab.core.kinematics, odolab.core.models.slip, odolab.app.demo
for old, new in [("odolab.kinematics", odolab.core.kinematics),
                 ("odolab.models.slip", odolab.core.models.slip),
                 ("odolab.lab", odolab.app.demo)]:
    try:
        __import__(old)
    except DeprecationWarning as w:
        print(old, "warned:", w)
    else:
        raise SystemExit(old + " did not warn")
warnings.simplefilter("ignore", DeprecationWarning)
import importlib, sys
for old, new in [("odolab.kinematics", odolab.core.kinematics),
                 ("odolab.models.slip", odolab.core.models.slip),
                 ("odolab.lab", odolab.app.demo)]:
    assert importlib.import_module(old) is new, old
from odolab.models import SlipModel
from odolab.core.models import SlipModel as S2
assert SlipModel is S2
from odolab.lab import run_lab
assert run_lab is odolab.app.demo.run_lab
print("same objects")
"""


def test_old_core_names_are_the_same_modules_and_warn() -> None:
    out = subprocess.run(
        [sys.executable, "-c", _PROBE],
        env={"PYTHONPATH": str(SRC), "PATH": "/usr/bin:/bin"},
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert out.returncode == 0, out.stdout + out.stderr
    assert (
        "odolab.kinematics warned: odolab.kinematics moved to odolab.core.kinematics" in out.stdout
    )
    assert "odolab.lab warned: odolab.lab moved to odolab.app.demo" in out.stdout
    assert "same objects" in out.stdout
