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
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

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
        for name, code in runs.items():  # numba's cache filled, the bytecode written
            _drive(code, args.port, tmp / f"warm-{len(name)}")
        cpu: dict[str, list[float]] = {name: [] for name in runs}
        for k in range(args.rounds):
            for name, code in runs.items():
                cpu[name].append(_drive(code, args.port, tmp / f"{k}-{len(name)}"))
    finally:
        server.terminate()
        server.wait(timeout=10)
    for name, values in cpu.items():
        print(f"{name:34s} {statistics.median(values):.3f} s CPU (median of {args.rounds})")
    ratios = [
        b / a
        for a, b in zip(cpu["drive now"], cpu["drive with numba's step (before)"], strict=True)
    ]
    print(
        f"ratio before / now: {statistics.median(ratios):.2f}x (rounds {min(ratios):.2f}-{max(ratios):.2f})"
    )


if __name__ == "__main__":
    main()
