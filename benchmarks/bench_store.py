"""Notebook speed: CSV import, add_trials, encoder-log storage, against bare sqlite in the same run.

Run:  PYTHONPATH=src python benchmarks/bench_store.py [N]
Baseline: the same rows written with a bare ``sqlite3`` executemany (no parsing, no checks).
"""

from __future__ import annotations

import sqlite3
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from odolab.store import Notebook, encode_log, write_trials_csv
from odolab.store.records import TRIAL_COLUMNS, record_from_trial
from store.conftest import make_trials


def main(n: int = 20000) -> None:
    d = Path(tempfile.mkdtemp())
    trials = make_trials(n)
    write_trials_csv(d / "t.csv", [(t, 1) for t in trials])

    rows = [tuple(record_from_trial(t, 1).values()) for t in trials]
    conn = sqlite3.connect(d / "bare.db", isolation_level=None)
    conn.execute("PRAGMA journal_mode = WAL")
    conn.execute(f"CREATE TABLE trials ({', '.join(TRIAL_COLUMNS)})")
    t0 = time.perf_counter()
    conn.execute("BEGIN")
    conn.executemany(f"INSERT INTO trials VALUES ({','.join('?' * len(TRIAL_COLUMNS))})", rows)
    conn.execute("COMMIT")
    bare = n / (time.perf_counter() - t0)

    with Notebook(d / "a.db") as nb:
        t0 = time.perf_counter()
        nb.import_csv(d / "t.csv", create_campaigns=True, batch_size=1000)
        imp = n / (time.perf_counter() - t0)
    with Notebook(d / "b.db") as nb:
        t0 = time.perf_counter()
        nb.add_trials(trials)
        add = n / (time.perf_counter() - t0)
        t0 = time.perf_counter()
        nb.trials_frame()
        frame = n / (time.perf_counter() - t0)
        t0 = time.perf_counter()
        nb.export_csv(d / "o.csv")
        exp = n / (time.perf_counter() - t0)
    logged = make_trials(500, with_logs=True, prefix="L")
    raw = sum(24 * len(t.encoder_log) for t in logged if t.encoder_log is not None)
    packed = 0
    for t in logged:
        assert t.encoder_log is not None
        e = encode_log(t.encoder_log)
        packed += len(e.t) + len(e.left_ticks) + len(e.right_ticks)

    print(f"{n} trials")
    print(f"bare sqlite executemany      {bare:10.0f} trials/s   (baseline)")
    print(f"import_csv (parse+check+write) {imp:8.0f} trials/s   ratio {imp / bare:.3f}")
    print(f"add_trials (check+write)     {add:10.0f} trials/s   ratio {add / bare:.3f}")
    print(f"export_csv                   {exp:10.0f} trials/s   ratio {exp / bare:.3f}")
    print(f"trials_frame                 {frame:10.0f} trials/s   ratio {frame / bare:.3f}")
    print(f"encoder logs: {packed / raw:.3f} of the raw int64/float64 size")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 20000)
