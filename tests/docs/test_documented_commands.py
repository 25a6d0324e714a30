"""Every ``odolab ...`` command line documented in README.md and docs/*.md runs as written.

The command lines are taken from the fenced shell blocks of each document (continuation lines
joined) and run in order, one document per empty folder, with the installed ``odolab`` (and its
``python``) on the PATH, as the README's ``export PATH=...`` line leaves it. Shell variables the
document sets (``R=...``) carry over to its later lines.

What a document takes for granted (a log file of your own, a protocol file, a demo run folder)
is made by that document's fixture below, and a line that cannot run here (a real robot, a
server that runs until Ctrl-C, a usage synopsis) is in ``SKIP`` with the reason. A command that
exits with anything but 0 fails the test, with its output.

How a line runs: bash expands it (the document's variables, quotes, globs) into words, and
``odolab ...`` is then called in this test's process (``odolab.cli.main`` with those words, in the
document's folder, stdin as typed), which is what the ``odolab`` script does, without paying
Python's and the libraries' start-up again for each of the 90 lines (it was most of these tests'
4 minutes). A line with a pipe or a redirection, ``python -c``, and every line of the documents in
:data:`SUBPROCESS_DOCS` (the README's, which also checks the installed script, and the robot's,
which installs signal handlers) run in their own shell and process, as a user's would.
"""

from __future__ import annotations

import csv
import io
import os
import re
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from fixture_cache import cached, demo_builder
from shared_data import data_dir, require

#: `make test-fast` leaves these out (every documented command line, about 2 minutes); `make test` and CI run them
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
DATA = data_dir()

#: the documents checked (robot.md is driven in real time: its lines are in SKIP but for the
#: hand session on a background sim-server, about 30 s)
DOCS = [
    "README.md",
    "docs/analysis.md",
    "docs/notebook.md",
    "docs/real-logs.md",
    "docs/robot.md",
    "docs/sim.md",
    "docs/validation.md",
    "docs/models.md",
    "docs/ros2.md",
    "docs/serve.md",
    "docs/ground-truth.md",
    "docs/scale.md",
    "docs/imu.md",
]

#: (document, start of the command line) -> why it is not run here
SKIP: dict[tuple[str, str], str] = {
    ("README.md", "odolab notebook init --db lab.db"): "the hand session: test_readme_session",
    ("README.md", "odolab sim run rotation --db lab.db"): "the hand session: test_readme_session",
    ("README.md", "odolab sim run translation --db lab.db"): "the hand session",
    ("README.md", "odolab robot rotate --turns 2"): "the hand session",
    ("README.md", "odolab trials measure --db lab.db"): "the hand session",
    ("README.md", "odolab analyze --db lab.db"): "the hand session",
    ("README.md", "odolab calibrate ratios -p jaguar-lite --db lab.db"): "the hand session",
    ("README.md", "odolab report --db lab.db"): "the hand session",
    ("docs/robot.md", "odolab robot rotate --turns 10"): (
        "drives the virtual Jaguar in real time for two minutes; tests/robot drive the same "
        "stack in simulated time"
    ),
    ("docs/robot.md", "odolab robot drive --distance -2.5"): "real time (tests/robot cover it)",
    ("docs/robot.md", "odolab robot square"): "real time, about a minute (tests/robot cover it)",
    ("docs/robot.md", "odolab robot pivot"): "real time (tests/robot cover it)",
    ("docs/robot.md", "odolab robot drive --distance 1 --robot udp://192.168.0.60"): (
        "needs the real Jaguar at 192.168.0.60"
    ),
    ("docs/robot.md", "odolab robot sim-server --host 127.0.0.1 --port 10001"): (
        "a server that runs until Ctrl-C (the hand session's runs in the background and exits "
        "when idle)"
    ),
    (
        "docs/robot.md",
        "odolab robot sim-server --link jaguar2014",
    ): "a server that runs until Ctrl-C",
    ("docs/robot.md", "odolab robot drive --distance 1 --robot tcp://192.168.0.60"): (
        "needs the real Jaguar 4x4 at 192.168.0.60"
    ),
    ("docs/robot.md", "odolab robot rotate --turns 1 --robot 'tcp://192.168.0.60"): (
        "needs the real tracked Jaguar at 192.168.0.60"
    ),
    ("docs/robot.md", "odolab robot square --side 1 --robot tcp://127.0.0.1:10001"): (
        "needs the 2014 sim-server of the line before it running; tests/robot/test_safety_2014.py "
        "drives the same commands against it"
    ),
    ("docs/robot.md", "odolab robot rotate --turns 1 --robot udp://127.0.0.1:10001"): (
        "needs the sim-server of the line before it running"
    ),
    ("docs/real-logs.md", "odolab evaluate bags/"): (
        "needs a folder of bags with wheel joints wheel_l/wheel_r and a /mocap topic; the bag "
        "reader is tested on generated bags in tests/io"
    ),
    **{
        ("docs/real-logs.md", start): (
            "the Husky's fits (about 45 s): tests/io/test_husky_worked_example.py runs these lines "
            "as written and checks the numbers the page states"
        )
        for start in (
            "odolab calibrate compare $H#even",
            "odolab calibrate lsq $H#even",
            "odolab evaluate $H#odd",
        )
    },
    ("docs/validation.md", "odolab validate ENCODER_LOG.csv IMU.csv"): "a usage synopsis",
    ("docs/models.md", "odolab calibrate compare RUN..."): "a usage synopsis",
    ("docs/models.md", "odolab calibrate lsq RUN..."): "a usage synopsis",
    ("docs/models.md", "odolab sim questions stops"): (
        "the built-in stops experiment with 50 repeats, a minute here; "
        "tests/analysis run the experiments"
    ),
    ("docs/ros2.md", "odolab export mcap odolab-out/latest/runs/robot-rotation-..."): (
        "the run folder's name holds its time; tests/export/test_mcap.py exports a robot run folder"
    ),
    ("docs/ros2.md", "odolab robot drive --distance 1 --params jaguar-calibrated.toml"): (
        "drives in real time and serves until the run ends; tests/export/test_foxglove.py runs "
        "it in simulated time"
    ),
    ("docs/serve.md", "odolab serve --db lab.db"): "a server that runs until Ctrl-C",
    ("docs/ground-truth.md", "odolab camera calibrate board.mp4"): (
        "needs your film of the printed board; tests/groundtruth/test_tracking.py calibrates "
        "from a rendered board video"
    ),
    ("docs/ground-truth.md", "odolab track run.mp4"): (
        "needs your film; the same command runs on the simulated video above"
    ),
    ("docs/ground-truth.md", "odolab calibrate sensor run.csv laser_poses.tum"): (
        "your logs; tests/groundtruth/test_sensor_calibration.py runs it on simulated ones"
    ),
    ("docs/ground-truth.md", "odolab calibrate sensor drive.bag drive.bag"): (
        "your bag; tests/groundtruth/test_sensor_calibration.py runs it on a generated ROS 2 bag"
    ),
    ("docs/scale.md", "odolab evaluate logs/ --format csv -p jaguar-lite --scheduler"): (
        "needs the dask scheduler and workers of the lines before it; "
        "tests/scale/test_fleet.py starts them with the dask CLI"
    ),
    ("docs/scale.md", 'odolab odometry "logs/**/*.csv" -p jaguar-lite -o trajectories/'): (
        "needs the dask cluster above; tests/scale/test_cli_fleet.py runs odometry over many logs"
    ),
    ("docs/scale.md", "odolab calibrate lsq runs/ -f optiodom -o calibrated.toml --scheduler"): (
        "needs the dask cluster above and your runs; tests/calibration run calibrate lsq"
    ),
}

#: documents whose lines run in their own shell and process (see the module's docstring)
SUBPROCESS_DOCS = {"README.md", "docs/robot.md"}

#: (document, start of the command line) -> what is typed at its questions
STDIN: dict[tuple[str, str], str] = {
    ("docs/notebook.md", "odolab trials measure R01"): "200\n290\n8\n",
}


def _blocks(text: str) -> list[list[str]]:
    out: list[list[str]] = []
    inside, shell, cur = False, False, []
    for line in text.splitlines():
        if line.strip().startswith("```"):
            if inside:
                if shell:
                    out.append(cur)
                cur, inside = [], False
            else:
                inside = True
                shell = line.strip()[3:].strip() in ("", "bash", "sh", "shell", "console")
            continue
        if inside:
            cur.append(line)
    return out


def documented_lines(doc: str) -> list[str]:
    """The shell lines of ``doc`` that run odolab (or set a variable, or run python -c)."""
    lines: list[str] = []
    for block in _blocks((ROOT / doc).read_text(encoding="utf-8")):
        buf = ""
        for raw in block:
            if raw.rstrip().endswith("\\"):
                buf += raw.rstrip()[:-1].rstrip() + " "
                continue
            line = (buf + raw.strip()).strip()
            buf = ""
            if re.match(r"^(odolab |python -c |[A-Z]+=\S+$)", line):
                lines.append(re.sub(r"\s+#\s.*$", "", line))
    return lines


def _skip_reason(doc: str, line: str) -> str | None:
    for (d, start), why in SKIP.items():
        if d == doc and line.startswith(start):
            return why
    return None


# -- what each document takes for granted -------------------------------------------------------

JAGUAR_TOML = """[robot]
name = "my-robot"
left_wheel_radius = 0.0835
right_wheel_radius = 0.0835
track_width = 0.56
ticks_per_rev = 380
encoder_modulus = 32768
"""


def _encoder_log(path: Path, n: int = 600) -> None:
    t = np.arange(n) * 0.05
    left = np.round(np.cumsum(np.full(n, 3.0))).astype(int)
    right = np.round(np.cumsum(np.full(n, 3.2))).astype(int)
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t", "left_ticks", "right_ticks"])
        for row in zip(t, left, right, strict=True):
            w.writerow([repr(float(row[0])), int(row[1]), int(row[2])])


def _odolab(folder: Path, *args: str) -> None:
    code, out = _in_process(folder, list(args), None)
    assert code == 0, out


def _readme(folder: Path) -> None:
    require("optiodom")
    (folder.parent / "shared").mkdir(exist_ok=True)
    if not (folder.parent / "shared" / "data").exists():
        (folder.parent / "shared" / "data").symlink_to(DATA)
    _encoder_log(folder / "log.csv")
    (folder / "my-robot.toml").write_text(JAGUAR_TOML, encoding="utf-8")


def _analysis(folder: Path) -> None:
    _odolab(folder, "sim", "run", "lab-report", "--db", "lab.sqlite", "-o", "campaign.csv")
    _odolab(folder, "sim", "run", "umbmark", "--db", "lab.sqlite", "-o", "umbmark.csv")
    (folder / "squares.csv").write_text(
        "direction,x,y\ncw,-0.112,-0.112\nccw,-0.048,0.048\n", encoding="utf-8"
    )


def _notebook(folder: Path) -> None:
    (folder / "sheet.csv").write_text(
        "trial_id,campaign,terrain,kind,distance_m,predicted_x_m,predicted_y_m,"
        "predicted_heading_rad,robot,params_version,measured_x_m,measured_y_m\n"
        "S01,my-sheet,tile,translation,1.0,1.0,0.0,0.0,jaguar-lite,1,0.905,-0.02\n",
        encoding="utf-8",
    )


def _real_logs(folder: Path) -> None:
    require("optiodom")
    (folder / "data").symlink_to(DATA)
    t = [0.1 * i for i in range(100)]
    with (folder / "gt.tum").open("w") as fh:
        for ti in t:
            fh.write(f"{ti!r} {0.3 * ti!r} 0 0 0 0 0 1\n")
    with (folder / "odometry.csv").open("w") as fh:
        fh.write("t,x,y,theta\n")
        for ti in t:
            fh.write(f"{ti!r},{0.29 * ti!r},{0.001 * ti!r},0.0\n")
    (folder / "robot.toml").write_text(JAGUAR_TOML, encoding="utf-8")
    for name in ("run1", "run2"):
        _encoder_log(folder / f"{name}.csv")
        with (folder / f"{name}_gt.csv").open("w") as fh:
            fh.write("t,x,y,theta\n")
            for i in range(600):
                fh.write(f"{i * 0.05!r},{0.004 * i!r},0.0,{0.0001 * i!r}\n")


def _sim(folder: Path) -> None:
    (folder / "my_protocol.toml").write_text(
        '[protocol]\ncampaign = "mine"\nterrain = "tile"\n\n'
        '[[trials]]\nmotion = "rotation"\nangle_pi = [2, 4, 6]\nrepeats = 2\n',
        encoding="utf-8",
    )


def _ros2(folder: Path) -> None:
    _real_logs(folder)
    (folder / "jaguar-calibrated.toml").write_text(
        JAGUAR_TOML.replace("0.0835", "0.0756", 1), encoding="utf-8"
    )
    with (folder / "gt.tum").open("w") as fh:
        for i in range(100):
            fh.write(f"{0.1 * i!r} {0.03 * i!r} 0 0 0 0 0 1\n")
    with (folder / "estimate.csv").open("w") as fh:
        fh.write("t,x,y,theta\n")
        for i in range(100):
            fh.write(f"{0.1 * i!r},{0.029 * i!r},{0.0001 * i!r},0.0\n")


def _validation(folder: Path) -> None:
    """``odolab demo --out odolab-out`` (20 s): the suite's default demo, built once for every
    test process (tests/fixture_cache.py; the same run_lab call with the same defaults), copied
    there with its ``latest`` link."""
    cached("default-demo", demo_builder("jaguar-lab"), folder / "odolab-out")


def _scale(folder: Path) -> None:
    """Encoder logs (CSV, Parquet), a ground truth (Parquet) and an estimate (CSV) over the
    same 30 s."""
    from odolab.core.trajectory import Trajectory
    from odolab.io import write_encoder_csv, write_trajectory_csv
    from odolab.io.encoder_csv import read_encoder_csv

    _encoder_log(folder / "log.csv")
    write_encoder_csv(folder / "log.parquet", read_encoder_csv(folder / "log.csv"))
    t = np.arange(600) * 0.05
    h = 0.02 * t
    gt = Trajectory.from_xyh(t, 0.2 * t, 0.01 * t * t, h)
    write_trajectory_csv(folder / "gt.parquet", gt)
    est = Trajectory.from_xyh(t, 0.19 * t, 0.012 * t * t, 1.05 * h)
    write_trajectory_csv(folder / "traj.csv", est)


def _imu(folder: Path) -> None:
    """The DRIVE Husky windows (shared data) where the page's Husky lines read them."""
    (folder / "husky_windows.csv").symlink_to(require("drive-husky") / "husky_windows.csv")


FIXTURES: dict[str, Callable[[Path], None]] = {
    "docs/imu.md": _imu,
    "docs/scale.md": _scale,
    "README.md": _readme,
    "docs/analysis.md": _analysis,
    "docs/notebook.md": _notebook,
    "docs/real-logs.md": _real_logs,
    "docs/sim.md": _sim,
    "docs/validation.md": _validation,
    "docs/ros2.md": _ros2,
}


def _env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("COLUMNS", "ODOLAB_DB")}
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["MPLBACKEND"] = "Agg"
    return env


#: what makes a line a shell's job rather than one command's words
_SHELL = re.compile(r"[|<>;&`]|\$\(")


def _words(folder: Path, assignments: list[str], line: str) -> list[str] | None:
    """The words bash makes of ``line`` after the document's assignments; None for a line
    with a pipe, a redirection or a command substitution (it runs in a shell)."""
    if _SHELL.search(line.replace("->", "")):
        return None
    script = "; ".join([*assignments, f"printf '%s\\0' {line[len('odolab') :]}"])
    proc = subprocess.run(
        ["bash", "-c", script], cwd=folder, env=_env(), capture_output=True, check=True
    )
    words = proc.stdout.decode().split("\0")[:-1]
    return ["odolab", *words] if line.startswith("odolab ") else None


def _in_process(folder: Path, args: list[str], stdin: str | None) -> tuple[int, str]:
    """``odolab ARGS`` in this process, in ``folder``, as the script runs it: (exit code, what it
    printed)."""
    from odolab.cli import main

    saved = (Path.cwd(), sys.stdin, sys.stdout, sys.stderr, dict(os.environ))
    raw = io.BytesIO()
    out = io.TextIOWrapper(raw, encoding="utf-8", errors="replace", write_through=True)
    try:
        os.chdir(folder)
        os.environ.clear()
        os.environ.update(_env())
        sys.stdin = io.StringIO(stdin or "")
        sys.stdout = sys.stderr = out
        code = main(args)
    finally:
        os.chdir(saved[0])
        sys.stdin, sys.stdout, sys.stderr = saved[1:4]
        os.environ.clear()
        os.environ.update(saved[4])
    out.flush()
    return code, raw.getvalue().decode("utf-8", errors="replace")


def test_every_document_has_commands_and_every_skip_names_one() -> None:
    found = {doc: documented_lines(doc) for doc in DOCS}
    assert all(found[d] for d in DOCS if d != "docs/robot.md")
    for (doc, start), why in SKIP.items():
        assert why and any(line.startswith(start) for line in found[doc]), (doc, start)


@pytest.mark.parametrize("doc", DOCS)
def test_documented_commands_run_as_written(doc: str, tmp_path: Path) -> None:
    if doc in FIXTURES:
        FIXTURES[doc](tmp_path)
    assignments: list[str] = []
    ran = 0
    for line in documented_lines(doc):
        if re.match(r"^[A-Z]+=\S+$", line):
            assignments.append(line)
            continue
        if _skip_reason(doc, line):
            continue
        # a test sends traffic only to this machine: a documented robot address elsewhere (a
        # real board on the robot's network) must be in SKIP, never tried
        hosts = re.findall(r"(?:udp|tcp)://\[?([^\]:/?'\"\s]+)", line)
        assert all(h in ("localhost", "::1") or h.startswith("127.") for h in hosts), (
            f"{doc}: {line!r} names a robot off this machine; add it to SKIP"
        )
        stdin = next((s for (d, st), s in STDIN.items() if d == doc and line.startswith(st)), None)
        words = None if doc in SUBPROCESS_DOCS else _words(tmp_path, assignments, line)
        if words is not None and words[:1] == ["odolab"]:
            code, out = _in_process(tmp_path, words[1:], stdin)
            assert code == 0, f"{doc}: {line}\n{out[-6000:]}"
        else:
            proc = subprocess.run(
                ["bash", "-c", "; ".join([*assignments, line])],
                cwd=tmp_path,
                env=_env(),
                input=stdin,
                capture_output=True,
                text=True,
                timeout=300,
            )
            assert proc.returncode == 0, (
                f"{doc}: {line}\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
            )
        ran += 1
    if doc != "docs/robot.md":
        assert ran > 0
