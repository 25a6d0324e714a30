"""The core installs alone (issue 42): its dependency closure fits in 650 MB of site-packages,
the core's commands run with every extra's packages unimportable, and each extra's command
says the one install line that brings it, exit 1, nothing written.

No network: the closure is computed from the installed distributions' metadata (Requires-Dist
without extras' markers) and their RECORD files' sizes; "not installed" is a meta-path finder in
the child process that refuses the extras' modules (tests/core/extras_blocked.py)."""

from __future__ import annotations

import importlib.metadata as md
import json
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from packaging.requirements import Requirement

from odolab.core.extras import (
    COMMAND_EXTRAS,
    COMMAND_PREFERS,
    EXTRAS,
    NO_NUMBA_NOTE,
    MissingExtraError,
    command_extra,
    extra_of_missing,
)

ROOT = Path(__file__).resolve().parents[2]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
BLOCKED_RUN = Path(__file__).with_name("extras_blocked.py")
#: The modules the extras bring, and what only they pull in (pandas and statsmodels: the
#: core's line fits are odolab.core.regression's).
EXTRA_MODULES = sorted({m for ms in EXTRAS.values() for m in ms} | {"statsmodels", "PIL"})
GOAL_BYTES = 650e6


def _key(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def _dists() -> dict[str, md.Distribution]:
    return {_key(d.metadata["Name"]): d for d in md.distributions()}


def _closure(reqs: list[str], dists: dict[str, md.Distribution]) -> set[str]:
    """Every distribution that installing ``reqs`` installs (the extras they name included,
    markers evaluated for this interpreter)."""
    seen: set[str] = set()
    expanded: set[tuple[str, str]] = set()
    todo = [(Requirement(r), "") for r in reqs]
    while todo:
        req, extra = todo.pop()
        if req.marker is not None and not req.marker.evaluate({"extra": extra}):
            continue
        name = _key(req.name)
        if name == "odolab":  # [all] names the other extras
            for e in req.extras:
                todo += [(Requirement(r), "") for r in PYPROJECT["optional-dependencies"][e]]
            continue
        assert name in dists, f"{req.name} is not installed (make installs .[all,dev])"
        seen.add(name)
        for e in ("", *sorted(req.extras)):
            if (name, e) not in expanded:
                expanded.add((name, e))
                todo += [(Requirement(r), e) for r in dists[name].requires or []]
    return seen


def _size(dist: md.Distribution) -> int:
    total = 0
    for f in dist.files or []:
        p = Path(str(dist.locate_file(f)))
        if p.is_file():
            total += p.stat().st_size
    return total


def test_the_core_fits_in_650_mb_and_brings_no_extra() -> None:
    dists = _dists()
    core = _closure(PYPROJECT["dependencies"], dists)
    size = sum(_size(dists[n]) for n in core)
    print(f"core closure: {len(core)} distributions, {size / 1e6:.1f} MB")
    # measured 2026-11-28: 638.1 MB with numba (0.68) and llvmlite in the core, 425.2 MB since they
    # are the fast extra (numpy 2.4, scipy 1.17, polars 2.1, typer 0.29 with pydantic); every
    # dependency before the split: 1,386 MB (docs/architecture.md)
    assert size <= GOAL_BYTES
    for heavy in ("pandas", "statsmodels", "matplotlib", "pyarrow", "opencv-python-headless",
                  "dask", "distributed", "foxglove-sdk", "rosbags", "jinja2", "starlette", "numba",
                  "llvmlite"):  # fmt: skip
        assert heavy not in core, heavy


def test_each_extra_brings_the_modules_odolab_asks_it_for() -> None:
    dists = _dists()
    extras = PYPROJECT["optional-dependencies"]
    assert set(EXTRAS) | {"all", "dev"} == set(extras)
    assert set(_closure(extras["all"], dists)) >= {
        n for e in EXTRAS for n in _closure(extras[e], dists)
    }
    tops = {n: {f.parts[0].partition(".")[0] for f in d.files or []} for n, d in dists.items()}
    for extra, modules in EXTRAS.items():
        brought = _closure(extras[extra], dists)
        for m in modules:  # a package's folder, or a top-level (extension) module's file
            assert any(m in tops[n] for n in brought), (extra, m)


def test_a_command_names_the_extra_it_cannot_start_without() -> None:
    assert command_extra(["track", "video.mp4"]) == "video"
    assert command_extra(["sim", "video", "-o", "v"]) == "video"
    assert command_extra(["sim", "run", "rotation"]) is None
    assert command_extra(["odometry", "log.parquet"]) is None  # only its input needs parquet
    assert all(e in EXTRAS for e in [*COMMAND_EXTRAS.values(), *COMMAND_PREFERS.values()])
    bag = ModuleNotFoundError("No module named 'rosbags'", name="rosbags")
    assert extra_of_missing(bag) == "ros"
    assert extra_of_missing(bag, command_extra(["calibrate", "sensor"], COMMAND_PREFERS)) == "laser"
    assert extra_of_missing(ModuleNotFoundError("x", name="no_such_module")) is None
    err = MissingExtraError("video", "odolab track")
    assert str(err) == "odolab track needs the video extra: pip install 'odolab[video]'"


def test_the_missing_extra_check_knows_every_command_group() -> None:
    """main() finds a command's words (group, then command) before the app is loaded, from the
    list of groups: a group missing from it would skip the missing-extra check of its commands."""
    from odolab.cli import _GROUPS, _words_of, load_commands

    app = load_commands()  # every command module: every group registered
    groups = {g.name for g in app.registered_groups}
    assert groups == _GROUPS
    for words in [*COMMAND_EXTRAS, *COMMAND_PREFERS]:  # each two-word entry is reachable
        assert tuple(_words_of([*words, "--help"])) == words, words


def _run_blocked(tmp_path: Path, commands: list[list[str]]) -> list[dict[str, object]]:
    path = os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])
    env = {**os.environ, "ODOLAB_BLOCKED": ",".join(EXTRA_MODULES), "PYTHONPATH": path}
    proc = subprocess.run(
        [sys.executable, str(BLOCKED_RUN), json.dumps(commands)],
        capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    return list(json.loads(proc.stdout.splitlines()[-1]))


@pytest.mark.slow  # one child process drives a virtual robot and runs eleven commands (~15 s)
def test_the_core_commands_run_without_any_extra(tmp_path: Path) -> None:
    results = _run_blocked(
        tmp_path,
        [
            ["--import-all"],
            ["sim", "run", "rotation", "--db", "lab.db", "-o", "rotation.csv"],
            ["sim", "run", "translation", "--db", "lab.db", "-o", "translation.csv"],
            ["robot", "sim-server", "--port", "0"],  # (in its own child process)
            [
                "robot",
                "drive",
                "--distance",
                "0.2",
                "-q",
                "--no-realtime",
                "-o",
                "run",
                "--db",
                "lab.db",
            ],
            ["trials", "list", "--db", "lab.db"],
            ["analyze", "--db", "lab.db"],
            ["calibrate", "ratios", "-p", "jaguar-lite", "--db", "lab.db", "-o", "cal.toml"],
            ["odometry", "run/encoders.csv", "-p", "cal.toml", "-o", "traj.csv"],
            ["evaluate", "run/predicted.csv", "traj.csv", "--json", "eval.json"],
        ],
    )
    for r in results:
        assert r["code"] == 0, r
    assert results[0]["err"] == ""  # every core module imports without an extra
    # no numba: the kernels ran as plain Python, said once in the process (by the first sim run)
    notes = [str(r["err"]).count(NO_NUMBA_NOTE) for r in results]
    assert sum(notes) == 1 and notes[1] == 1, notes
    table = next(r for r in results if r["args"][0] == "analyze")
    assert "Table I" in str(table["out"]) and "rotation" in str(table["out"])
    assert "written to cal.toml" in str(results[7]["out"])
    for name in ("rotation.csv", "run/encoders.csv", "cal.toml", "traj.csv"):
        assert (tmp_path / name).stat().st_size > 0, name
    assert json.loads((tmp_path / "eval.json").read_text())["ape"]


REFUSED = [
    (["report", "--db", "lab.db", "--out", "rep"], "odolab report", "report", "rep"),
    (["demo", "--out", "demo"], "odolab demo", "report", "demo"),
    (["serve", "--db", "lab.db"], "odolab serve", "web", None),
    (["track", "v.mp4", "-o", "gt.csv"], "odolab track", "video", "gt.csv"),
    (["markers", "-o", "m"], "odolab markers", "video", "m"),
    (["scans", "x.bag", "-o", "s.csv"], "odolab scans", "laser", "s.csv"),
    (["export", "mcap", "traj.csv", "-o", "r.mcap"], "odolab export mcap", "ros", "r.mcap"),
    (["robot", "drive", "--foxglove", "-q", "-o", "run"], "--foxglove", "ros", "run"),
    (["odometry", "log.parquet", "-o", "t.csv"], "odolab odometry", "parquet", "t.csv"),
    (
        ["odometry", "logs/a.csv", "-o", "t.parquet", "--chunk-rows", "1"],
        "odolab odometry",
        "parquet",
        "t.parquet",
    ),
    (["fleet", "report", "f.parquet", "-o", "fl"], "odolab fleet report", "report", "fl"),
    (  # a few runs are evaluated in this process; two workers asked for need Dask
        ["evaluate", "logs", "-f", "csv", "--workers", "2", "--results", "f.csv"],
        "odolab evaluate",
        "fleet",
        "f.csv",
    ),
]


@pytest.mark.slow  # one child process, eleven refusals (~3 s: odolab's imports)
def test_each_extra_is_refused_in_one_sentence_with_its_install_line(tmp_path: Path) -> None:
    (tmp_path / "traj.csv").write_text("t,x,y,theta\n0,0,0,0\n0.1,0.1,0,0\n")
    (tmp_path / "log.parquet").write_bytes(b"PAR1" + bytes(64) + b"PAR1")
    (tmp_path / "logs").mkdir()
    for name in ("a.csv", "b.csv"):
        (tmp_path / "logs" / name).write_text("t,left_ticks,right_ticks\n0,0,0\n0.1,10,12\n")
    results = _run_blocked(tmp_path, [args for args, *_ in REFUSED] + [["--pandas"]])
    assert len(results) == len(REFUSED) + 1
    for (args, what, extra, output), r in zip(REFUSED, results, strict=False):
        want = f"odolab: error: {what} needs the {extra} extra: pip install 'odolab[{extra}]'\n"
        # (the odometry to Parquet integrates its first chunk before its writer is refused)
        err = str(r["err"]).replace(NO_NUMBA_NOTE + "\n", "")
        assert (r["code"], err) == (1, want), args
        if output is not None:
            assert not (tmp_path / output).exists(), args
    assert results[-1]["err"] == (
        "Notebook.trials_frame needs the pandas extra: pip install 'odolab[pandas]'"
    )
    # pandas: a method's refusal; fast: no refusal, a note (test_the_core_commands_run_without_any_extra)
    assert {extra for _, _, extra, _ in REFUSED} | {"pandas", "fast"} == set(EXTRAS)
