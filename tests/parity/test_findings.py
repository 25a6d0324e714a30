"""Issue 25's findings 1-3, each on the faces as a user meets it (each fails on the code before
the application layer).

1. The web's /calibrate applied Table I's ratios to the robot's LATEST parameter version (an
   earlier calibration of the same trials) instead of the version the trials were driven with.
2. The web's Table I and its report counted the validation campaign that the CLI leaves out.
3. ``odolab odometry LOG -o OUT`` without ``-p`` integrated with jaguar-lite without a word.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from odolab.cli import main
from odolab.core.params import PRESETS, load_params
from odolab.store import Notebook

from .faces import cli, client, csrf_of, geometry, page_calibration, table_of
from .notebooks import VALIDATION, make_notebook


def test_1_the_web_calibrates_from_the_driven_version_not_the_latest(tmp_path: Path) -> None:
    gen = make_notebook(tmp_path, 1, two_robots=False)
    robot = gen.robots[0]
    with Notebook(gen.db) as nb:
        latest = nb.latest_params_version(robot)
    assert latest is not None and latest > gen.driven_version[robot]  # the trap is set
    out = tmp_path / "cli.toml"
    cli("calibrate", "ratios", "--db", gen.db, "-p", "jaguar-lite", "-o", out)
    want = geometry(load_params(out).to_dict())
    c = client(gen.db)
    token = csrf_of(c.get("/calibrate").text)
    for _ in range(2):  # again, after its own version was recorded: the same numbers
        r = c.post("/calibrate", data={"csrf": token, "method": "ratios", "robot": robot})
        assert r.status_code == 200, r.text
        with Notebook(gen.db) as nb:  # the version it recorded
            assert geometry(nb.latest_params(robot).to_dict()) == want
        assert page_calibration(r.text) == want
        started = f"{robot} parameters version {gen.driven_version[robot]}, the one "
        assert started in r.text and "driven with" in r.text


def test_2_the_web_leaves_the_validation_campaign_out_as_the_cli(tmp_path: Path) -> None:
    gen = make_notebook(tmp_path, 1, two_robots=False)
    c = client(gen.db)
    rows = table_of(c.get("/api/table1").json()["rows"])
    with Notebook(gen.db) as nb:
        counted = [
            t
            for t in nb.load_trials(status="measured", kind="rotation", with_logs=False)
            if t.campaign != VALIDATION
        ]
        in_validation = nb.load_trials(campaign=VALIDATION, status="measured", with_logs=False)
    assert in_validation  # the validation rotations are there, measured
    assert rows[("rotation", "tile")][0] == len(counted)
    page = c.get("/table1").text
    assert f"left out: {VALIDATION} (validation campaign" in page.replace("&#39;", "'")
    # the report the page offers "as odolab report writes it" says so too
    report = c.get("/report.html")
    assert report.status_code == 200
    assert f"left out: {VALIDATION} (validation campaign" in report.text.replace("&#39;", "'")


def _log(path: Path, params: object) -> Path:
    """A short curved run's encoder log (raw counters)."""
    from odolab.core.trials import EncoderLog
    from odolab.io import write_encoder_csv

    t = np.linspace(0.0, 5.0, 101)
    left = np.round(400.0 * t).astype(np.int64)
    right = np.round(480.0 * t).astype(np.int64)
    return write_encoder_csv(path, EncoderLog(t, left, right, modulus=32768))


def test_3_odometry_says_which_parameters_and_takes_the_logs_own(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from odolab.core.odometry import integrate

    log = _log(tmp_path / "log.csv", None)
    assert main(["odometry", str(log), "-o", str(tmp_path / "a.csv")]) == 0
    out = capsys.readouterr().out
    assert "parameters jaguar-lite" in out and "from preset jaguar-lite" in out
    assert "the default: neither --params nor the log named any" in out
    # a robot run folder names its parameters (run.json): they are the ones used, and said
    run = tmp_path / "run-001"
    run.mkdir()
    mine = PRESETS["jaguar-lite"].with_(name="my-rover", left_wheel_radius=0.1, track_width=0.7)
    enc = _log(run / "encoders.csv", mine)
    (run / "run.json").write_text(json.dumps({"params": mine.to_dict()}), encoding="utf-8")
    assert main(["odometry", str(enc), "-o", str(tmp_path / "b.csv")]) == 0
    out = capsys.readouterr().out
    assert "parameters my-rover" in out and str(run / "run.json") in out
    assert "the log's" in out
    from odolab.io import read_encoder_csv, read_trajectory_csv

    e = read_encoder_csv(enc, modulus=32768)
    want = integrate(e.t, e.left_ticks, e.right_ticks, mine).final
    got = read_trajectory_csv(tmp_path / "b.csv").final
    assert math.isclose(got.x, want.x, abs_tol=1e-9) and math.isclose(got.y, want.y, abs_tol=1e-9)
    # the user's --params win over the log's, and the file is named
    toml = tmp_path / "p.toml"
    from odolab.core.params import save_params

    save_params(toml, PRESETS["jaguar-lite"], provenance={"notebook_version": 3, "method": "x"})
    assert main(["odometry", str(enc), "-p", str(toml), "-o", str(tmp_path / "c.csv")]) == 0
    out = capsys.readouterr().out
    assert f"from {toml}, notebook version 3" in out and "my-rover" not in out
