"""CPU of a whole ``odolab robot sim-server`` process serving one drive, with its baseline in the
same rounds: the same server in a process that steps its robot with numba's physics (as every
``sim-server`` did before its board ran the step's plain source, ``odolab.sim._physics_kernels``,
2026-11-29).

Each round starts a fresh server (``--idle-exit 1``: it exits a second after the drive), drives
it 0.3 m from another process (``--no-realtime``), and takes the server's own CPU (user +
system); the rounds alternate the two servers, and the median of each and their ratio are
printed. A first round of each fills numba's cache, as an installed odolab has it.

Usage: PYTHONPATH=src python benchmarks/bench_sim_server_process.py [--rounds 7] [--port 10493]
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

NOW = "import sys; from odolab.cli import main; sys.exit(main(sys.argv[1:]))"
#: The baseline: the board's robot made with the compiled physics, as before.
BEFORE = (
    "import sys; import odolab.sim.plants as plants; real = plants.make_plant; "
    "plants.make_plant = lambda *a, **k: real(*a, **{**k, 'compiled': True}); "
    "from odolab.cli import main; sys.exit(main(sys.argv[1:]))"
)


def _serve_one_drive(code: str, port: int, out: Path) -> float:
    """The CPU seconds of one server process that serves one drive, then exits."""
    server = subprocess.Popen(
        [sys.executable, "-c", code, "robot", "sim-server", "--port", str(port), "--idle-exit", "1"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=os.environ.copy(),
    )  # fmt: skip
    deadline = time.monotonic() + 30
    while True:  # drive as soon as it answers
        proc = subprocess.run(
            [sys.executable, "-m", "odolab.cli", "robot", "drive", "--distance", "0.3",
             "--robot", f"udp://127.0.0.1:{port}", "--no-realtime", "--quiet", "--out", str(out)],
            capture_output=True, env=os.environ.copy(),
        )  # fmt: skip
        if proc.returncode == 0 or time.monotonic() > deadline:
            break
        time.sleep(0.2)
    mid = resource.getrusage(resource.RUSAGE_CHILDREN)  # the drives reaped: counted above
    server.wait(timeout=60)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - mid.ru_utime) + (after.ru_stime - mid.ru_stime)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--port", type=int, default=10493)
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="bench-sim-server-"))
    runs = {"sim-server now": NOW, "sim-server with numba's physics (before)": BEFORE}
    cpu = alternated(
        list(runs),
        lambda name, tag: _serve_one_drive(runs[name], args.port, tmp / f"{tag}-{len(name)}"),
        args.rounds,
    )
    print_ratio(cpu, "sim-server now", "sim-server with numba's physics (before)")


if __name__ == "__main__":
    main()
