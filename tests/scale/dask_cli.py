"""A Dask scheduler and workers started as separate processes with the dask CLI, on 127.0.0.1."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path


@dataclass
class DaskProcesses:
    address: str
    scheduler: subprocess.Popen[bytes]
    workers: list[subprocess.Popen[bytes]] = field(default_factory=list)


def _dask(*args: str, log: Path) -> subprocess.Popen[bytes]:
    env = dict(os.environ, DASK_DISTRIBUTED__WORKER__DAEMON="False")
    with log.open("ab") as fh:
        return subprocess.Popen(
            [sys.executable, "-m", "dask", *args],
            stdout=fh,
            stderr=subprocess.STDOUT,
            env=env,
            start_new_session=True,
        )


def _stop(proc: subprocess.Popen[bytes]) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=10)


@contextmanager
def dask_cluster(folder: Path, workers: int = 2, timeout: float = 60.0) -> Iterator[DaskProcesses]:
    """``dask scheduler`` and ``workers`` x ``dask worker`` (no nanny: killing one kills it)."""
    from distributed import Client

    folder.mkdir(parents=True, exist_ok=True)
    info = folder / "scheduler.json"
    log = folder / "dask.log"
    sched = _dask(
        "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
        "--scheduler-file", str(info), log=log,
    )  # fmt: skip
    procs = DaskProcesses("", sched)
    try:
        deadline = time.monotonic() + timeout
        while not info.is_file() or not info.read_text().strip():
            if sched.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"dask scheduler did not start: {log.read_text()[-2000:]}")
            time.sleep(0.1)
        time.sleep(0.2)
        procs.address = json.loads(info.read_text())["address"]
        args = ["worker", procs.address, "--nthreads", "1", "--no-nanny", "--no-dashboard"]
        args += ["--host", "127.0.0.1", "--death-timeout", "30"]
        for _ in range(workers):
            procs.workers.append(_dask(*args, log=log))
        with Client(procs.address, timeout=timeout) as client:
            client.wait_for_workers(workers, timeout=timeout)
        yield procs
    finally:
        for w in procs.workers:
            _stop(w)
        _stop(sched)
