"""CPU of a whole ``odolab robot drive`` process against the virtual Jaguar (``sim-server``), with
its baseline in the same rounds: the same drive in a process that loads numba and the compiled
pose step first, as every drive did before the streaming odometry ran the step's plain source
(``odolab.core._step_kernels``, 2026-11-29).

Each drive is a fresh process (``--no-realtime``, 0.3 m); the rounds alternate the two, and the
median CPU (user + system, the child's own) of each and their ratio are printed. A first drive
of each fills numba's cache, as an installed odolab has it.

Usage: PYTHONPATH=src python benchmarks/bench_drive_process.py [--rounds 7] [--port 10491]
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _timing import alternated, print_ratio

#: The baseline's start: numba and the compiled step loaded (and called) before the CLI runs.
BEFORE = (
    "from odolab.core._kinematics_jit import body_motion, step_pose; "
    "step_pose(0.0, 0.0, 0.0, *body_motion(1.0, 1.0, 0.5, 0.5, 0.6, 0.0, 0.01, 0.01), True); "
    "import sys; from odolab.cli import main; sys.exit(main(sys.argv[1:]))"
)
NOW = "import sys; from odolab.cli import main; sys.exit(main(sys.argv[1:]))"


def _drive(code: str, port: int, out: Path) -> float:
    """The CPU seconds of one drive process (its own, from the kernel's accounting)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(
        [sys.executable, "-c", code, "robot", "drive", "--distance", "0.3", "--robot",
         f"udp://127.0.0.1:{port}", "--no-realtime", "--quiet", "--out", str(out)],
        check=True, capture_output=True, env=os.environ.copy(),
    )  # fmt: skip
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--port", type=int, default=10491)
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="bench-drive-"))
    server = subprocess.Popen(
        [sys.executable, "-m", "odolab.cli", "robot", "sim-server", "--port", str(args.port),
         "--idle-exit", "120"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=tmp,
    )  # fmt: skip
    try:
        time.sleep(3.0)  # the server's start
        runs = {"drive now": NOW, "drive with numba's step (before)": BEFORE}
        cpu = alternated(
            list(runs),
            lambda name, tag: _drive(runs[name], args.port, tmp / f"{tag}-{len(name)}"),
            args.rounds,
        )
    finally:
        server.terminate()
        server.wait(timeout=10)
    print_ratio(cpu, "drive now", "drive with numba's step (before)", width=34)


if __name__ == "__main__":
    main()
