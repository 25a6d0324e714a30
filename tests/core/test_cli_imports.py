"""What each command imports: no heavy library a command does not use (plotting, Dask, OpenCV,
rosbags, pandas), and no compiled kernel where the command needs none, so start-up cannot
creep back. One fresh interpreter imports the command line, then forks once per command (each
child runs one command and reports its modules), so the test costs one start-up."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

#: Libraries no command below may import (the commands that use them are elsewhere).
NEVER = ("matplotlib", "dask", "distributed", "cv2", "rosbags", "pandas", "jinja2", "mcap",
         "sqlite3", "statsmodels", "sklearn", "uvicorn", "starlette")  # fmt: skip
#: numba's CPU target (its kernels' loader, which imports scipy.linalg: ~0.5 s).
KERNELS = ("numba.np.arraymath", "scipy.linalg")

_CHILD = textwrap.dedent(
    """
    import json, os, sys
    from odolab.cli import main
    commands = json.loads(sys.argv[1])
    found = {}
    for name, args in commands.items():
        r, w = os.pipe()
        pid = os.fork()
        if pid == 0:
            os.close(r)
            sys.stdout = open(os.devnull, "w")
            try:
                code = main(args)
            except SystemExit as e:
                code = e.code
            with os.fdopen(w, "w") as out:
                json.dump({"code": code, "modules": sorted(sys.modules)}, out)
            os._exit(0)
        os.close(w)
        with os.fdopen(r) as inp:
            found[name] = json.load(inp)
        os.waitpid(pid, 0)
    print(json.dumps(found))
    """
)


@pytest.fixture(scope="module")
def imported(tmp_path_factory: pytest.TempPathFactory) -> dict[str, set[str]]:
    from odolab.core.trajectory import Trajectory
    from odolab.core.trials import EncoderLog
    from odolab.io import write_encoder_csv, write_tum

    d = tmp_path_factory.mktemp("imports")
    t = np.arange(50) * 0.1
    traj = Trajectory.from_xytheta(t, np.cos(t), np.sin(t), t)
    gt = write_tum(d / "gt.tum", traj)
    est = write_tum(d / "est.tum", Trajectory.from_xytheta(t, np.cos(t) + 0.01, np.sin(t), t))
    log = EncoderLog(np.array([0.0, 0.05, 0.1]), np.array([0, 10, 20]), np.array([0, 11, 22]), None)
    csv = write_encoder_csv(d / "tiny.csv", log)
    parquet = write_encoder_csv(d / "tiny.parquet", log)
    commands = {
        "--help": ["--help"],
        "params list": ["params", "list"],
        "evaluate TUM": ["evaluate", str(gt), str(est)],
        "odometry CSV": ["odometry", str(csv), "-p", "jaguar-lite", "-o", str(d / "o.csv")],
        "odometry Parquet": ["odometry", str(parquet), "-o", str(d / "o.parquet")],
    }
    proc = subprocess.run(
        [sys.executable, "-c", _CHILD, json.dumps(commands)],
        capture_output=True, text=True, check=True, timeout=300,
    )  # fmt: skip
    found = json.loads(proc.stdout.splitlines()[-1])
    for name, got in found.items():
        assert got["code"] in (0, None), (name, got["code"])
    assert Path(d / "o.parquet").is_file()
    return {name: set(got["modules"]) for name, got in found.items()}


def _loaded(modules: set[str], names: tuple[str, ...]) -> list[str]:
    return [n for n in names if n in modules]


@pytest.mark.parametrize("command", ["--help", "params list"])
def test_help_and_params_load_no_numerics(imported: dict[str, set[str]], command: str) -> None:
    heavy = (*NEVER, "numpy", "numba", "polars", "pyarrow", "scipy")
    assert _loaded(imported[command], heavy) == []


def test_evaluate_loads_no_kernel(imported: dict[str, set[str]]) -> None:
    assert _loaded(imported["evaluate TUM"], (*NEVER, *KERNELS, "pyarrow")) == []
    assert "polars" in imported["evaluate TUM"]  # the readers' fast path


@pytest.mark.parametrize("command", ["odometry CSV", "odometry Parquet"])
def test_odometry_loads_only_its_libraries(imported: dict[str, set[str]], command: str) -> None:
    assert _loaded(imported[command], NEVER) == []  # pyarrow's to_numpy imported pandas
    assert ("pyarrow" in imported[command]) == command.endswith("Parquet")
    # a 3-row log is integrated in numpy: numba (0.35 s to import, its kernels 0.5 s) not loaded
    assert _loaded(imported[command], ("numba", *KERNELS)) == []


def test_evaluate_loads_no_numba(imported: dict[str, set[str]]) -> None:
    """The pair choosers' kernels are loaded on first use (odolab.metrics._pairs_jit): the
    default evaluation chooses its pairs in numpy, so numba (0.15-0.35 s) is not imported."""
    assert _loaded(imported["evaluate TUM"], ("numba", "odolab.core._kinematics_jit")) == []
