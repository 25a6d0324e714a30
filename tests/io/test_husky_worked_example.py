"""The numbers of docs/real-logs.md's worked example (the DRIVE Husky, fitted on even command
steps, held out on odd ones): nominal -> fitted models -> compare -> NEES.

The page's own command lines run here as written (bash expands them, odolab.cli.main runs them
in this process, as tests/docs/test_documented_commands.py does), and their outputs are checked
against the numbers the page states; that test leaves these lines to this one (its SKIP), so the
Husky's fits run once in the suite, not twice. One end-to-end run over the whole table (about
45 s on two cores): the doc's numbers are the Husky's, not a subset's."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from tests.docs.test_documented_commands import _env, _in_process, _words, documented_lines
from tests.shared_data import require

from odolab.core.params import PRESETS
from odolab.io import find_runs, read_run
from odolab.io.run import ReadOptions
from odolab.metrics.runs import RUN_OPTIONS, evaluate_run

pytestmark = pytest.mark.slow

DOC = "docs/real-logs.md"
#: the page's Husky lines, in its order (the ones test_documented_commands leaves to this test)
HUSKY_LINES = (
    "odolab calibrate compare $H#even",
    "odolab calibrate lsq $H#even",
    "odolab evaluate $H#odd",
)

HUSKY = PRESETS["jaguar-lite"].with_(
    name="husky",
    left_wheel_radius=0.165,
    right_wheel_radius=0.165,
    track_width=0.55,
    encoder_modulus=None,
)


def _run_the_page(folder: Path) -> str:
    """The page's Husky block in ``folder`` (with ``data`` linked to the shared data): what
    the lines printed."""
    (folder / "data").symlink_to(require("drive-husky").parent)
    lines = documented_lines(DOC)
    start = next(i for i, line in enumerate(lines) if line.startswith("H=data/drive-husky"))
    assignments = [lines[start]]
    block = lines[start + 1 : start + 1 + 1 + len(HUSKY_LINES)]
    assert block[0].startswith("python -c ") and [
        any(line.startswith(h) for line in block[1:]) for h in HUSKY_LINES
    ] == [True] * len(HUSKY_LINES), block
    import subprocess

    subprocess.run(
        ["bash", "-c", block[0]], cwd=folder, env=_env(), check=True, capture_output=True
    )
    printed = []
    for line in block[1:]:
        words = _words(folder, assignments, line)
        assert words is not None, line
        code, out = _in_process(folder, words[1:], None)
        assert code == 0, f"{line}\n{out[-4000:]}"
        printed.append(out)
    return "\n".join(printed)


def test_husky_even_steps_fitted_odd_steps_held_out(tmp_path: Path) -> None:
    table = require("drive-husky") / "husky_windows.csv"
    ro = ReadOptions(params=HUSKY)
    held = [read_run(p, "drive", ro) for p in find_runs([f"{table}#odd"], "drive")]
    train = find_runs([f"{table}#even"], "drive")
    assert (len(train), len(held)) == (289, 314)
    updates = np.array([r.meta["truth_updates"] for r in held], dtype=float)
    assert np.median(updates) == 20  # of 40 rows: the lidar's ~10 Hz, the rest held values
    nominal = np.mean(
        [evaluate_run(r, HUSKY, RUN_OPTIONS).evaluation.drift.endpoint_error for r in held]
    )
    assert round(float(nominal), 3) == 0.462

    printed = _run_the_page(tmp_path)
    doc = json.loads((tmp_path / "husky-compare.json").read_text(encoding="utf-8"))
    models = {m["model"]: m for m in doc["models"]}
    end = {k: m["held_out"]["endpoint_error"]["value"] for k, m in models.items()}
    assert {k: round(v, 3) for k, v in end.items()} == {
        "diff": 0.227,
        "extended": 0.227,
        "icr": 0.208,
        "slip": 0.181,
    }
    assert round(end["slip"] / min(end["diff"], end["extended"], end["icr"]), 2) == 0.87
    assert doc["segments"] == 154 and doc["recommended"] == "slip"
    icr = models["icr"]["ratio_to_best"]
    assert (round(icr["value"], 3), *(round(b, 3) for b in icr["ci95"])) == (1.147, 1.088, 1.216)
    # the risk per run, against the best kinematic model on the decision's segments (diff)
    assert models["slip"]["runs_worse_than_best_kinematic"] == {"runs": 55, "of": 153}
    assert models["extended"]["runs_worse_than_best_kinematic"] == {"runs": 0, "of": 153}
    assert "slip is worse than diff (the best kinematic model) on 55 of 153" in doc["reason"]
    assert round(models["slip"]["segment_error"]["value"], 3) == 0.218
    # the Husky turns less than its wheels say
    assert round(models["diff"]["values"]["track_width"], 1) == 1.1
    assert round(models["icr"]["values"]["y_icr_left"], 1) == 0.6
    assert round(-models["icr"]["values"]["y_icr_right"], 1) == 0.7

    # where odolab chose to compute the 603 windows, said by each command (none started a
    # local Dask cluster: a window takes about a millisecond)
    flat = " ".join(printed.split())
    for said in (
        "note: the runs read in this process (603 runs: the first 8 took ",
        "note: the fitted runs read in this process (289 runs: the first 8 took ",
        "note: computed in this process (314 runs: the first 8 took ",
    ):
        assert said in flat, said

    # calibrate lsq wrote the slip model the page evaluates, allowing for the lidar's noise
    # as estimated from its updates (the page's note)
    assert (tmp_path / "husky-slip.toml").is_file()
    assert (
        "ground truth taken as noisy: 13.8 mm in position, 0.0038 rad in heading, estimated "
        "from 5066 of its updates" in " ".join(printed.split())
    )
    # evaluate --nees over 1 s pieces
    m = re.search(
        r"mean NEES ([\d.]+) over (\d+) pieces; 95 % bounds \[([\d.]+), ([\d.]+)\]", printed
    )
    assert m is not None, printed[-3000:]
    assert (m[1], m[2], m[3], m[4]) == ("3.7", "314", "2.74", "3.28")
    # with the lidar's noise at each piece's two ends in its covariance (3.78 without)
    assert (
        "ground truth taken as noisy: 13.3 mm in position, 0.00363 rad in heading, estimated "
        "from 5559 of its updates" in " ".join(printed.split())
    )
