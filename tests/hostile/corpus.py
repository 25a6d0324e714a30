"""The hostile-input corpus: for every reader and importer, the cases a red-team round found
(issue 39): the zero quaternion, huge increments, constant or infinite time, an absent schema,
damaged pages, empty databases, a truth file with only its header, positions of 1e308.

Each case writes its file(s) with odolab's own writers where it can (then damages them), so the
corpus follows the formats; ``read`` reads them as the reader's users do. Every case must be
refused with one :class:`odolab.core.errors.OdolabError` whose sentence holds ``expect`` (what, where,
what was expected). ``tests/hostile/test_corpus.py`` runs them all; a case is named
``reader/what``.
"""

from __future__ import annotations

import json
import random
import shutil
import sqlite3
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["CASES", "Case", "damaged_notebook", "empty_database", "notebook_json"]


@dataclass(frozen=True)
class Case:
    """``make(folder)`` writes the input and returns the path to read; ``read(path)`` reads it
    and must raise an OdolabError whose text holds every string of ``expect``."""

    name: str
    make: Callable[[Path], Path]
    read: Callable[[Path], object]
    expect: tuple[str, ...]


# -- writers ------------------------------------------------------------------------------------

N = 30


def _encoder(suffix: str, t: np.ndarray) -> Callable[[Path], Path]:
    def make(d: Path) -> Path:
        from odolab.core.trials import EncoderLog
        from odolab.io import write_encoder_csv

        k = np.arange(t.size)
        return write_encoder_csv(d / f"enc{suffix}", EncoderLog(t, 7 * k, 9 * k, None))

    return make


def _text(name: str, text: str) -> Callable[[Path], Path]:
    def make(d: Path) -> Path:
        p = d / name
        p.write_text(text, encoding="utf-8")
        return p

    return make


def _tum(rows: list[tuple[float, ...]]) -> Callable[[Path], Path]:
    body = "# timestamp tx ty tz qx qy qz qw\n" + "".join(
        " ".join(repr(float(v)) for v in r) + "\n" for r in rows
    )
    return _text("gt.tum", body)


def _tum_rows(**change: object) -> list[tuple[float, ...]]:
    rows = []
    for k in range(N):
        t = 0.1 * k
        x = 0.01 * k
        q = (0.0, 0.0, 0.0, 1.0)
        if "t" in change:
            t = float(change["t"])  # type: ignore[arg-type]
        if "x" in change:
            x = float(change["x"])  # type: ignore[arg-type]
        if "q" in change and k == 3:
            q = change["q"]  # type: ignore[assignment]
        rows.append((t, x, 0.0, 0.0, *q))
    return rows


_OPTIODOM_META = (
    "type,diff,\nngear,43.7,\nencRes,64,\nLi,0.2,\nDi,0.084,0.084\nThi,,\nN,2,\nL,1.5,\n"
    "imarkers,4,3\n"
)


def _optiodom(t: np.ndarray, dticks: np.ndarray) -> Callable[[Path], Path]:
    def make(d: Path) -> Path:
        run_dir = d / "square" / "2312"
        run_dir.mkdir(parents=True)
        (run_dir / "2312_metadata.csv").write_text(_OPTIODOM_META)
        rows = [
            f"{float(ti)!r},{0.01 * k!r},0.0,0.0,{int(dticks[k])},{int(-dticks[k])}"
            for k, ti in enumerate(t)
        ]
        run = run_dir / "2312_run-01.csv"
        run.write_text("\n".join(rows) + "\n")
        return run

    return make


_HUGE = np.array([0] + [999_999_999 * (-1) ** k for k in range(1, N)], dtype=np.int64)
_SMALL = np.array([0] + [20] * (N - 1), dtype=np.int64)
_T = 0.05 * np.arange(N)


def _csv_run_with_gt(gt_text: str) -> Callable[[Path], Path]:
    def make(d: Path) -> Path:
        p = _encoder(".csv", _T)(d)
        target = d / "run.csv"
        p.rename(target)
        (d / "run_gt.csv").write_text(gt_text)
        return target

    return make


def _bag(
    *, t: np.ndarray | None = None, x: float | None = None, q: tuple[float, ...] | None = None
) -> Callable[[Path], Path]:
    """A rosbag2 (sqlite3) folder written by rosbags: joint states at ``t`` (default 20 Hz),
    ground truth at 10 Hz with ``x`` as every position's x and ``q`` as every orientation."""

    def make(d: Path) -> Path:
        import sys

        sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "io"))
        from bag_fixtures import write_bag  # tests/io: rosbags' own writers

        from odolab.core.trajectory import Trajectory

        tt = 100.0 + 0.05 * np.arange(N) if t is None else t
        k = np.arange(N)
        g = 100.0 + 0.1 * np.arange(N // 2)
        gx = 0.01 * np.arange(g.size) if x is None else np.full(g.size, x)
        gt = Trajectory.from_xytheta(g, gx, np.zeros(g.size), np.zeros(g.size))
        return write_bag(d / "run_ros2", tt, 0.2 * k, 0.25 * k, gt, gt_quaternion=q)  # type: ignore[arg-type]

    return make


def _sensorlog(t: np.ndarray) -> Callable[[Path], Path]:
    def make(d: Path) -> Path:
        from odolab.io.sensorlog import write_sensorlog

        ref = d / "ref.csv"
        write_sensorlog(ref, 100.0 + 0.02 * np.arange(t.size), 0.4 * np.arange(t.size),
                        np.full(t.size, 0.4), compass_every=3)  # fmt: skip
        lines = ref.read_text().splitlines()
        header = lines[0].split(",")
        col = next(i for i, h in enumerate(header) if h.startswith("motionTimestamp_sinceReboot"))
        out = [lines[0]]
        for k, line in enumerate(lines[1:]):
            cells = line.split(",")
            cells[col] = repr(float(t[k]))
            out.append(",".join(cells))
        p = d / "imu.csv"
        p.write_text("\n".join(out) + "\n")
        return p

    return make


#: Where :func:`notebook_json` writes a number of 5000 digits.
HUGE = "<a number of 5000 digits>"


def notebook_json(d: Path, change: Callable[[dict[str, object]], None]) -> Path:
    """A real notebook's JSON export (two trials with encoder logs), changed by ``change``."""
    from odolab.store import Notebook
    from store.conftest import make_trials  # (tests/ is on the path)

    src = d / "src.db"
    with Notebook(src) as nb:
        nb.add_campaign("rot-lab", "rotation", "lab")
        nb.add_trials(make_trials(2, seed=3, with_logs=True))
        nb.export_json(d / "nb.json")
    p = d / "nb.json"
    doc = json.loads(p.read_text(encoding="utf-8"))
    change(doc)
    # (json cannot write an integer of 5000 digits: a placeholder, replaced in the text)
    p.write_text(json.dumps(doc).replace(f'"{HUGE}"', "9" * 5000), encoding="utf-8")
    return p


def damaged_notebook(d: Path, *, zeroed: int = 512, seed: int = 39) -> Path:
    """A checkpointed notebook of 60 trials with encoder logs, with ``zeroed`` bytes zeroed in
    the middle of one page of the trials table (a damaged disk sector)."""
    from odolab.store import Notebook
    from store.conftest import make_trials  # (tests/ is on the path)

    db = d / "lab.db"
    with Notebook(db) as nb:
        nb.add_campaign("rot-lab", "rotation", "lab")
        nb.add_trials(make_trials(60, seed=1, with_logs=True))
    conn = sqlite3.connect(db)
    conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    page_size = int(conn.execute("PRAGMA page_size").fetchone()[0])
    leaves = sorted(
        int(r[0])
        for r in conn.execute(
            "SELECT pageno FROM dbstat WHERE name = 'trials' AND pagetype = 'leaf'"
        )
    )
    conn.close()
    page = random.Random(seed).choice(leaves)
    data = bytearray(db.read_bytes())
    at = page * page_size - zeroed  # the end of the page: the records' cells
    data[at : at + zeroed] = bytes(zeroed)
    db.write_bytes(bytes(data))
    return db


def empty_database(d: Path) -> Path:
    """A SQLite database with nothing in it (no schema version, no tables): one page."""
    db = d / "empty.db"
    conn = sqlite3.connect(db)
    conn.execute("VACUUM")  # writes the header: a 1-page database file
    conn.close()
    assert db.stat().st_size > 0
    return db


# -- readers ------------------------------------------------------------------------------------


def _read_encoder(p: Path) -> object:
    from odolab.io import read_encoder_csv

    return read_encoder_csv(p)


def _read_chunks(p: Path) -> object:
    from odolab.io.chunked import iter_encoder_chunks

    return list(iter_encoder_chunks(p, chunk_rows=7))


def _read_traj(p: Path) -> object:
    from odolab.io import read_trajectory

    return read_trajectory(p)


def _read_run(fmt: str) -> Callable[[Path], object]:
    def read(p: Path) -> object:
        from odolab.io import read_run

        return read_run(p, fmt)

    return read


def _read_sensorlog(p: Path) -> object:
    from odolab.io.sensorlog import read_sensorlog

    return read_sensorlog(p)


def _read_json(p: Path) -> object:
    from odolab.store.jsonio import read_notebook_json

    return read_notebook_json(p)


def _import_json(p: Path) -> object:
    from odolab.store import Notebook

    with Notebook(p.with_name("into.db")) as nb:
        return nb.import_json(p)


def _open_notebook(p: Path) -> object:
    from odolab.store import Notebook

    with Notebook(p) as nb:
        return nb.load_trials()


def _drop(key: str) -> Callable[[dict[str, object]], None]:
    def change(doc: dict[str, object]) -> None:
        del doc[key]

    return change


def _set(key: str, value: object) -> Callable[[dict[str, object]], None]:
    def change(doc: dict[str, object]) -> None:
        doc[key] = value

    return change


def _first_trial(key: str, value: object) -> Callable[[dict[str, object]], None]:
    def change(doc: dict[str, object]) -> None:
        doc["trials"][0][key] = value  # type: ignore[index]

    return change


_CONST = np.full(N, 5.0)
_BIG = np.full(N, 1e308)
_INF = np.where(np.arange(N) == 4, np.inf, _T)
_NO_ADVANCE = "expected times that advance"
_TIME_RANGE = "expected seconds from -1e+10 to 1e+10"

#: Every case, by name.
CASES: dict[str, Case] = {
    c.name: c
    for c in (
        # encoder logs: CSV, Parquet, read whole or in chunks
        Case(
            "encoder-csv/constant-time",
            _encoder(".csv", _CONST),
            _read_encoder,
            ("enc.csv: the time is 5 s at every line from 2 to 31", _NO_ADVANCE),
        ),
        Case(
            "encoder-csv/time-1e308",
            _encoder(".csv", _BIG),
            _read_encoder,
            ("enc.csv: time at line 2 is 1e+308 s", _TIME_RANGE),
        ),
        Case(
            "encoder-csv/time-inf",
            _text("enc.csv", "t,left_ticks,right_ticks\n0,0,0\ninf,1,1\n"),
            _read_encoder,
            ("enc.csv: line 3, column 't' is 'inf', expected a number",),
        ),
        Case(
            "encoder-parquet/constant-time",
            _encoder(".parquet", _CONST),
            _read_encoder,
            ("enc.parquet: the time is 5 s at every row", _NO_ADVANCE),
        ),
        Case(
            "encoder-parquet/time-1e308",
            _encoder(".parquet", _BIG),
            _read_encoder,
            ("time at row 1 is 1e+308 s", _TIME_RANGE),
        ),
        Case(
            "encoder-chunks/constant-time",
            _encoder(".csv", _CONST),
            _read_chunks,
            ("enc.csv: the time is 5 s at every line", _NO_ADVANCE),
        ),
        Case(
            "encoder-chunks/time-1e308",
            _encoder(".csv", _BIG),
            _read_chunks,
            ("time at line 2 is 1e+308 s", _TIME_RANGE),
        ),
        # trajectories: CSV and TUM
        Case(
            "trajectory-csv/header-only",
            _text("gt.csv", "t,x,y,theta,heading\n"),
            _read_traj,
            ("gt.csv: no poses after the header", "expected at least one row"),
        ),
        Case(
            "trajectory-csv/position-1e308",
            _text("gt.csv", "t,x,y,theta\n0,0,0,0\n1,1e308,0,0\n"),
            _read_traj,
            ("gt.csv: line 3, position x is 1e+308 m", "expected a number of metres"),
        ),
        Case(
            "trajectory-csv/constant-time",
            _text("gt.csv", "t,x,y,theta\n2,0,0,0\n2,1,0,0\n"),
            _read_traj,
            ("the time is 2 s at every line from 2 to 3", _NO_ADVANCE),
        ),
        Case(
            "tum/zero-quaternion",
            _tum(_tum_rows(q=(0.0, 0.0, 0.0, 0.0))),
            _read_traj,
            (
                "gt.tum: line 5, the quaternion qx qy qz qw = 0 0 0 0 has length 0",
                "expected a unit quaternion",
            ),
        ),
        Case(
            "tum/huge-quaternion",
            _tum(_tum_rows(q=(0.0, 0.0, 1e200, 1e200))),
            _read_traj,
            ("line 5, the quaternion", "expected a unit quaternion"),
        ),
        Case(
            "tum/position-1e308",
            _tum(_tum_rows(x=1e308)),
            _read_traj,
            ("gt.tum: line 2, position x is 1e+308 m", "expected a number of metres"),
        ),
        Case(
            "tum/constant-time",
            _tum(_tum_rows(t=7.0)),
            _read_traj,
            ("gt.tum: the time is 7 s at every line from 2 to 31", _NO_ADVANCE),
        ),
        Case(
            "tum/time-1e308",
            _tum(_tum_rows(t=1e308)),
            _read_traj,
            ("gt.tum: time at line 2 is 1e+308 s", _TIME_RANGE),
        ),
        # runs: the CSV run with its truth beside it, OptiOdom
        Case(
            "csv-run/truth-header-only",
            _csv_run_with_gt("t,x,y,theta,heading\n"),
            _read_run("csv"),
            ("run_gt.csv: no poses after the header",),
        ),
        Case(
            "optiodom/huge-increments",
            _optiodom(_T, _HUGE),
            _read_run("optiodom"),
            (
                "2312_run-01.csv: sample 2, the left increment of 999999999 counts",
                "expected at most 20 m/s",
            ),
        ),
        Case(
            "optiodom/constant-time",
            _optiodom(_CONST, _SMALL),
            _read_run("optiodom"),
            ("the time is 5 s at every line from 1 to 30", _NO_ADVANCE),
        ),
        Case(
            "optiodom/time-1e308",
            _optiodom(_BIG, _SMALL),
            _read_run("optiodom"),
            ("time at line 1 is 1e+308 s", _TIME_RANGE),
        ),
        Case(
            "optiodom/position-1e308",
            lambda d: _optiodom_far(d),
            _read_run("optiodom"),
            ("2312_run-01.csv: line 3, position x is 1e+308 m",),
        ),
        # a rosbag2 folder: its joint states and its ground-truth topic
        Case(
            "bag/zero-quaternion",
            _bag(q=(0.0, 0.0, 0.0, 0.0)),
            _read_run("bag"),
            (
                "topic '/ground_truth': message 1, the quaternion qx qy qz qw = 0 0 0 0 has "
                "length 0",
                "expected a unit quaternion",
            ),
        ),
        Case(
            "bag/position-1e308",
            _bag(x=1e308),
            _read_run("bag"),
            ("topic '/ground_truth': message 1, position x is 1e+308 m",),
        ),
        Case(
            "bag/constant-time",
            _bag(t=np.full(N, 100.0)),
            _read_run("bag"),
            ("topic '/joint_states': the time is 100 s at every message from 1 to 30", _NO_ADVANCE),
        ),
        # the phone's log
        Case(
            "sensorlog/constant-time",
            _sensorlog(_CONST),
            _read_sensorlog,
            ("imu.csv: 1 heading sample(s); at least 2 are needed",),
        ),
        Case(
            "sensorlog/time-1e308",
            _sensorlog(_BIG),
            _read_sensorlog,
            ("imu.csv: line 2, column 'motionTimestamp_sinceReboot(s)' is 1e+308 s", _TIME_RANGE),
        ),
        # the notebook: its JSON export, its SQLite file
        Case(
            "notebook-json/schema-absent",
            lambda d: notebook_json(d, _drop("schema")),
            _read_json,
            ("nb.json: no key 'schema'", "expected the schema number"),
        ),
        Case(
            "notebook-json/schema-null",
            lambda d: notebook_json(d, _set("schema", None)),
            _read_json,
            ("nb.json: schema is null", "expected the schema number"),
        ),
        Case(
            "notebook-json/number-of-5000-digits",
            lambda d: notebook_json(d, _set("campaigns", HUGE)),
            _read_json,
            ("nb.json: a number in it has more digits than can be read",),
        ),
        Case(
            "notebook-json/integer-past-a-float",
            lambda d: notebook_json(d, _first_trial("predicted_x", 10**400)),
            _read_json,
            ("nb.json: trials[0], key 'predicted_x': ", "expected a finite number"),
        ),
        Case(
            "notebook-json-import/schema-absent",
            lambda d: notebook_json(d, _drop("schema")),
            _import_json,
            ("nb.json: no key 'schema'",),
        ),
        Case(
            "notebook-sqlite/damaged-page",
            damaged_notebook,
            _open_notebook,
            (
                "lab.db: the notebook is damaged (SQLite: ",
                "integrity check: ",
                "odolab notebook rescue NEW.db",
            ),
        ),
        Case(
            "notebook-sqlite/empty-database",
            empty_database,
            _open_notebook,
            ("empty.db: is an empty SQLite database, not an odolab notebook",),
        ),
    )
}


def _optiodom_far(d: Path) -> Path:
    run = _optiodom(_T, _SMALL)(d)
    lines = run.read_text().splitlines()
    cells = lines[2].split(",")
    cells[1] = "1e308"
    lines[2] = ",".join(cells)
    run.write_text("\n".join(lines) + "\n")
    return run


def prepare(case: Case, root: Path) -> Path:
    """The case's input in a fresh folder under ``root``; the path to read."""
    folder = root / case.name.replace("/", "--")
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    return case.make(folder)
