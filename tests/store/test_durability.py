"""A SIGKILL in the middle of a large import, and two processes writing at once."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from odolab.core.trials import MotionKind
from odolab.store import Notebook, write_trials_csv

from .conftest import fingerprint, make_trials

SRC = str(Path(__file__).resolve().parents[2] / "src")
BATCH = 250


def _python(code: str, *args: str) -> subprocess.Popen[str]:
    env = {**os.environ, "PYTHONPATH": SRC}
    return subprocess.Popen(
        [sys.executable, "-c", textwrap.dedent(code), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )


@pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="needs SIGKILL")
def test_sigkill_mid_import_keeps_every_committed_batch(tmp_path: Path) -> None:
    trials = make_trials(12000, measured_every=3)
    csv_path = write_trials_csv(tmp_path / "big.csv", [(t, 1) for t in trials])
    db = tmp_path / "nb.db"
    with Notebook(db) as nb:  # something stored before the import must survive too
        nb.add_trials(make_trials(5, prefix="KEEP", with_logs=True))
    proc = _python(
        """
        import sys, time
        from odolab.store import Notebook
        def progress(done, total, what):
            print(done, flush=True)
            time.sleep(0.005)  # a slow disk: leaves the parent time to kill mid-way
        with Notebook(sys.argv[1]) as nb:
            nb.import_csv(sys.argv[2], create_campaigns=True, batch_size=int(sys.argv[3]),
                          progress=progress)
        print("finished", flush=True)
        """,
        str(db),
        str(csv_path),
        str(BATCH),
    )
    assert proc.stdout is not None
    committed = 0
    for line in proc.stdout:
        assert line.strip() != "finished", "the import ended before it could be killed"
        committed = int(line)
        if committed >= 4 * BATCH:
            proc.send_signal(signal.SIGKILL)
            break
    proc.wait(timeout=30)
    assert proc.returncode == -signal.SIGKILL
    assert committed >= 4 * BATCH

    conn = sqlite3.connect(db)  # opens, and SQLite finds it sound
    assert conn.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    conn.close()
    with Notebook(db) as nb:
        assert nb.integrity_check() == "ok"
        stored = nb.load_trials(campaign="rot-lab")
        keep = [t for t in stored if t.trial_id.startswith("KEEP")]
        imported = [t for t in stored if not t.trial_id.startswith("KEEP")]
        assert len(keep) == 5
        # every batch reported as committed is there, and only whole batches
        assert len(imported) >= committed
        assert len(imported) % BATCH == 0
        n = len(imported)
        assert [fingerprint(t) for t in imported] == [fingerprint(t) for t in trials[:n]]


def test_two_processes_write_at_once(tmp_path: Path) -> None:
    db = tmp_path / "nb.db"
    with Notebook(db) as nb:
        nb.add_campaign("fwd", "translation", "lab")
        nb.add_trials(make_trials(150, prefix="M", campaign="fwd", kind=MotionKind.TRANSLATION,
                                  measured_every=10**6))  # fmt: skip
    # a robot run saved one trial at a time (with encoder logs) ...
    robot = _python(
        """
        import sys
        sys.path.insert(0, sys.argv[2])
        from store.conftest import make_trials
        from odolab.store import Notebook
        trials = make_trials(150, prefix="RUN", with_logs=True)
        with Notebook(sys.argv[1], timeout=60) as nb:
            for t in trials:
                nb.add_trial(t)
        print("robot done", flush=True)
        """,
        str(db),
        str(Path(__file__).resolve().parents[1]),
    )
    # ... while someone enters the measurements of another campaign
    person = _python(
        """
        import sys
        from odolab.store import Notebook, translation_measurement
        with Notebook(sys.argv[1], timeout=60) as nb:
            for i in range(150):
                if i in (0, 3):
                    continue  # measured already / excluded
                nb.set_measurement(f"M{i:05d}", translation_measurement(1.0 + i / 1000, 0.01))
        print("person done", flush=True)
        """,
        str(db),
    )
    _, err_r = robot.communicate(timeout=120)
    _, err_p = person.communicate(timeout=120)
    assert robot.returncode == 0, err_r
    assert person.returncode == 0, err_p
    with Notebook(db) as nb:
        assert len(nb.load_trials(campaign="rot-lab")) == 150
        measured = nb.load_trials(campaign="fwd", status="measured")
        assert len(measured) == 149
        assert measured[-1].measured is not None and measured[-1].measured.x == 1.149
        assert nb.integrity_check() == "ok"


def test_a_writer_waits_for_another_processes_transaction(tmp_path: Path) -> None:
    db = tmp_path / "nb.db"
    with Notebook(db) as nb:
        nb.add_trials(make_trials(2, measured_every=10**6))
    holder = _python(
        """
        import sys, time
        from odolab.store import Notebook
        with Notebook(sys.argv[1]) as nb:
            with nb._write() as conn:
                conn.execute("UPDATE trials SET notes = 'held' WHERE trial_id = 'T00000'")
                print("locked", flush=True)
                time.sleep(1.0)
        """,
        str(db),
    )
    assert holder.stdout is not None
    assert holder.stdout.readline().strip() == "locked"
    from odolab.store import translation_measurement

    with Notebook(db, timeout=30) as nb:  # must wait for the lock, then succeed
        nb.set_measurement("T00001", translation_measurement(0.5, 0.0))
        assert nb.get_trial("T00000").notes == "held"
        assert nb.get_trial("T00001").measured is not None
    assert holder.wait(timeout=30) == 0
