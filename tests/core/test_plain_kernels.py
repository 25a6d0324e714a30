"""Without numba (the core without the fast extra) the kernels run as plain Python, with the
compiled kernels' results, and odolab says so once (issue 42)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from tests.core.kernel_cases import compute

from odolab.core import _jit
from odolab.core.extras import NO_NUMBA_NOTE

CASES = Path(__file__).with_name("kernel_cases.py")
ROOT = Path(__file__).resolve().parents[2]


def test_the_plain_kernels_give_the_compiled_results(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    assert _jit.HAVE_NUMBA  # make test installs the fast extra
    compiled = compute()
    assert NO_NUMBA_NOTE not in capfd.readouterr().err  # numba is here: nothing to say
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), str(ROOT)])}
    proc = subprocess.run(
        [sys.executable, str(CASES), str(tmp_path / "plain.npz")],
        capture_output=True, text=True, env=env, timeout=120,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert proc.stderr == NO_NUMBA_NOTE + "\n"  # once, though eleven kernels ran
    plain = np.load(tmp_path / "plain.npz")
    assert set(plain.files) == set(compiled)
    for name, want in compiled.items():
        got = plain[name]
        assert got.dtype == want.dtype and got.shape == want.shape, name
        if name.endswith("_cov"):
            # measured: at most 1.3e-14 apart (1.1e-11 relative, on terms up to 26 m^2): numba
            # contracts a * b + c into one rounding (fastmath={"contract"}), Python does not
            scale = float(np.max(np.abs(want)))
            np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12 * scale, err_msg=name)
        elif name.endswith("_pose"):
            # the headings: the same operations in the same order. The positions: numba fuses
            # the turn's polynomials (TURN in _odometry_kernels); measured at most 1.9e-15 m
            # apart on positions up to 11.5 m (1.7e-16 of the largest), bound 1e-14 of it
            np.testing.assert_array_equal(got[2], want[2], err_msg=name)
            scale = float(np.max(np.abs(want[:2])))
            np.testing.assert_allclose(got[:2], want[:2], rtol=0, atol=1e-14 * scale, err_msg=name)
        else:  # the RPE pairs: the same operations in the same order
            np.testing.assert_array_equal(got, want, err_msg=name)
    assert len(compiled["pairs_angle"]) > 100 and len(compiled["by_path"]) > 100


def test_the_plain_njit_keeps_the_function_and_numba_s_options(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(_jit, "_noted", True)  # (this process has numba: no note here)

    def step(x: float) -> float:
        return x + 1.0

    assert _jit._plain_njit(cache=True, inline="always")(step) is step  # no wrapper in loops
    kernel = _jit._plain_njit(cache=True, parallel=True)(step)
    bare = _jit._plain_njit(step)
    assert kernel(1.0) == bare(1.0) == 2.0
    assert kernel.py_func is step and kernel.__name__ == "step"
