"""The CLI and two HTTP clients writing the same notebook at once lose nothing."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import httpx

from odolab.serve import ServeSettings, run_in_thread
from odolab.store import Notebook

N = 12  # writes per writer and per kind


def _add_awaiting(db: Path) -> None:
    with Notebook(db) as nb:
        template = nb.get_trial("F2")  # translation of 1 m, awaiting
        ids = [f"{w}{i:02d}" for w in ("A", "B", "C") for i in range(N)] + ["S"]
        nb.add_trials([dataclasses.replace(template, trial_id=i) for i in ids])


CLI_WRITER = textwrap.dedent(
    """
    import sys
    from odolab.cli import main
    db, n = sys.argv[1], int(sys.argv[2])
    main(["trials", "show", "F1", "--db", db])  # imports done before the start
    print("ready", flush=True)
    sys.stdin.readline()  # start together with the HTTP clients
    codes = []
    for i in range(n):
        codes.append(main(["trials", "measure", f"C{i:02d}", "--x", f"{0.9 + i / 1000}",
                           "--y", "0.01", "--db", db]))
        codes.append(main(["trials", "measure", "S", "--x", f"{1.2 + i / 1000}", "--y", "0",
                           "--replace", "--db", db]))
    print("codes", *codes, flush=True)
    """
)


def test_cli_and_two_http_clients(lab_db: Path) -> None:
    _add_awaiting(lab_db)
    proc = subprocess.Popen(
        [sys.executable, "-c", CLI_WRITER, str(lab_db), str(N)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None and proc.stdin is not None
    try:
        while (line := proc.stdout.readline().strip()) != "ready":
            assert line, "the CLI writer stopped before it was ready"
        statuses: dict[str, list[int]] = {"A": [], "B": []}
        with run_in_thread(ServeSettings(db=lab_db)) as info:
            start = threading.Barrier(2)

            def writer(name: str, x0: float) -> None:
                with httpx.Client(base_url=info.base_url, timeout=60) as c:
                    start.wait()
                    for i in range(N):
                        r = c.post(
                            f"/api/trials/{name}{i:02d}/measurement",
                            json={"x": x0 + i / 1000, "y": 0.02},
                        )
                        statuses[name].append(r.status_code)
                        r = c.post(
                            "/api/trials/S/measurement",
                            json={"x": x0 + 0.2 + i / 1000, "y": 0, "replace": True},
                        )
                        statuses[name].append(r.status_code)

            threads = [
                threading.Thread(target=writer, args=("A", 0.95)),
                threading.Thread(target=writer, args=("B", 1.05)),
            ]
            proc.stdin.write("go\n")
            proc.stdin.flush()
            for t in threads:
                t.start()
            for t in threads:
                t.join(timeout=120)
        out, _ = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert statuses["A"] == [200] * (2 * N) and statuses["B"] == [200] * (2 * N)
    assert out.splitlines()[-1].split() == ["codes"] + ["0"] * (2 * N)
    with Notebook(lab_db) as nb:
        for name, x0, y in (("A", 0.95, 0.02), ("B", 1.05, 0.02), ("C", 0.9, 0.01)):
            for i in range(N):
                m = nb.get_trial(f"{name}{i:02d}").measured
                assert m is not None and (m.x, m.y) == (round(x0 + i / 1000, 12), y), name
        # every write of the shared trial is either its measurement or in its history
        current = nb.get_trial("S").measured
        history = nb.measurement_history("S")
        assert current is not None and len(history) == 3 * N - 1
        written = {round(x0 + 0.2 + i / 1000, 9) for x0 in (0.95, 1.05) for i in range(N)}
        written |= {round(1.2 + i / 1000, 9) for i in range(N)}
        kept = {round(m.x, 9) for _, m in history if m.x is not None} | {round(current.x or 0, 9)}
        assert kept == written
