"""Seeded byte-mutation fuzzing of every reader: valid files, mutated, read; only an
:class:`odolab.core.errors.OdolabError` or success is allowed.

Used by ``tests/hostile/test_fuzz_readers.py`` (a fixed, small budget in CI) and by
``benchmarks/bench_fuzz.py`` (minutes). Each target writes valid seed files with odolab's (or
rosbags') own writers, then reads mutations of one of them: bits flipped, bytes set to 0x00 or
0xff, the file cut short, bytes inserted, deleted or repeated, a number replaced by a huge one
(400 or 5000 digits, 1e999), a 4- or 8-byte field overwritten by a huge length. Everything is
drawn from ``random.Random`` seeded by the target's name and the case number, so a failure is
reproduced by its (target, case) pair.
"""

from __future__ import annotations

import math
import random
import re
import shutil
import struct
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from odolab.core.errors import OdolabError

__all__ = ["TARGETS", "Target", "foreign", "mutate", "prepare", "run_case", "try_case"]

_TOKENS = (
    b'"',
    b",",
    b";",
    b"\n",
    b"\r",
    b"\r\n",
    b" ",
    b"\t",
    b"#",
    b"nan",
    b"inf",
    b"-",
    b"1e999",
    b"-1e-999",
    b"9" * 400,
    b"9" * 5000,
    b"0x1f",
    b"\xef\xbb\xbf",
    b"\xff\xfe",
    b"\x00",
    b"[robot]",
    b"=",
    b"'",
    b"\\",
    b"1_0",
)
_HUGE_FIELDS = (
    struct.pack("<I", 0xFFFFFFFF),
    struct.pack("<I", 0x7FFFFFFF),
    struct.pack("<I", 0x10000000),
    struct.pack("<Q", 0xFFFFFFFFFFFFFFFF),
    struct.pack("<Q", 0x7FFFFFFFFFFFFFFF),
    struct.pack("<Q", 1 << 40),
    struct.pack("<Q", 1 << 31),
)
_NUMBER = re.compile(rb"\d+(?:\.\d+)?")


def mutate(data: bytes, rng: random.Random) -> bytes:
    """One to four random edits of ``data`` (see the module's docstring)."""
    b = bytearray(data)
    for _ in range(rng.randint(1, 4)):
        op = rng.randrange(10)
        n = len(b)
        pos = rng.randrange(n + 1)
        if op == 0 and n:  # flip a bit
            i = min(pos, n - 1)
            b[i] ^= 1 << rng.randrange(8)
        elif op == 1 and n:  # a byte set to an edge value
            b[min(pos, n - 1)] = rng.choice((0x00, 0xFF, 0x7F, 0x80, 0x0A, 0x22, 0x2C))
        elif op == 2:  # cut short
            del b[pos:]
        elif op == 3:  # random bytes inserted
            b[pos:pos] = bytes(rng.randrange(256) for _ in range(rng.randint(1, 16)))
        elif op == 4:  # a token inserted
            b[pos:pos] = rng.choice(_TOKENS)
        elif op == 5 and n:  # a range deleted
            del b[pos : pos + rng.randint(1, 64)]
        elif op == 6 and n:  # a range repeated
            end = min(n, pos + rng.randint(1, 256))
            b[pos:pos] = b[pos:end]
        elif op == 7 and n >= 8:  # a length field made huge
            field = rng.choice(_HUGE_FIELDS)
            i = min(pos, n - len(field))
            b[i : i + len(field)] = field
        elif op == 8:  # a number made huge
            numbers = list(_NUMBER.finditer(b))
            if numbers:
                m = rng.choice(numbers)
                b[m.start() : m.end()] = rng.choice(
                    (b"9" * 400, b"9" * 5000, b"1e999", b"-0", b"nan", b"1" + b"0" * 30)
                )
        elif op == 9 and n:  # a line (or a stretch of bytes) duplicated many times
            end = min(n, pos + rng.randint(1, 80))
            b[pos:pos] = b[pos:end] * rng.randint(2, 50)
    return bytes(b)


@dataclass(frozen=True)
class Target:
    """A reader under test: ``make(folder)`` writes valid seed files into an empty folder and
    returns the file to mutate and the path to read; ``read(path)`` reads it."""

    name: str
    make: Callable[[Path], tuple[Path, Path]]
    read: Callable[[Path], object]


def foreign(err: BaseException) -> str:
    """A short signature of an exception that is not an OdolabError: its type and the
    innermost frame in odolab (else the innermost frame)."""
    frames = traceback.extract_tb(err.__traceback__)
    ours = [f for f in frames if "/odolab/" in f.filename]
    frame = (ours or frames or [None])[-1]
    where = "?" if frame is None else f"{Path(frame.filename).name}:{frame.lineno}"
    return f"{type(err).__name__} at {where}"


def run_case(target: Target, seed: bytes, mutable: Path, read_path: Path, case: int) -> str | None:
    """Write mutation ``case`` of ``seed`` over ``mutable`` and read ``read_path``; None when
    the reader succeeded or raised an OdolabError, else the exception's signature."""
    outcome = try_case(target, seed, mutable, read_path, case)
    return None if outcome in ("read", "refused") else outcome


def try_case(target: Target, seed: bytes, mutable: Path, read_path: Path, case: int) -> str:
    """As :func:`run_case`: ``"read"``, ``"refused"`` (an OdolabError) or the signature of
    anything else (a MemoryError turned into a sentence counts as anything else: the reader
    tried to allocate what a length field said)."""
    rng = random.Random(f"{target.name}-{case}")
    mutable.write_bytes(mutate(seed, rng))
    try:
        target.read(read_path)
    except OdolabError as err:
        cause = err.__cause__
        while cause is not None:  # a sentence, but the reader tried to allocate first
            if isinstance(cause, MemoryError):
                return foreign(cause).replace("MemoryError", "MemoryError (as a sentence)")
            cause = cause.__cause__ or cause.__context__
        return "refused"
    except (KeyboardInterrupt, SystemExit):
        raise
    except BaseException as err:  # the point: anything else is a finding
        return foreign(err)
    return "read"


# ---------------------------------------------------------------------------------------------
# seed files


def _drive(n: int = 40) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = 0.05 * np.arange(n)
    left = np.cumsum(np.full(n, 7)) - 7
    right = np.cumsum(np.full(n, 9)) - 9
    return t, left, right


def _trajectory(n: int = 40):  # type: ignore[no-untyped-def]
    from odolab.core.trajectory import Trajectory

    t = 0.1 * np.arange(n)
    return Trajectory.from_xytheta(t, np.cos(t), np.sin(t), 0.3 * t)


def _encoder(suffix: str) -> Callable[[Path], tuple[Path, Path]]:
    def make(d: Path) -> tuple[Path, Path]:
        from odolab.core.trials import EncoderLog
        from odolab.io import write_encoder_csv

        t, left, right = _drive()
        p = write_encoder_csv(d / f"enc{suffix}", EncoderLog(t, left, right, None))
        return p, p

    return make


def _traj(suffix: str) -> Callable[[Path], tuple[Path, Path]]:
    def make(d: Path) -> tuple[Path, Path]:
        from odolab.io import write_trajectory_csv, write_tum

        if suffix == ".tum":
            p = write_tum(d / "gt.tum", _trajectory())
            text = p.read_text()
            p.write_text("# timestamp tx ty tz qx qy qz qw\n" + text)
            return p, p
        p = write_trajectory_csv(d / f"traj{suffix}", _trajectory())
        return p, p

    return make


def _csv_run(d: Path) -> tuple[Path, Path]:
    from odolab.core.trials import EncoderLog
    from odolab.io import write_encoder_csv, write_tum

    t, left, right = _drive()
    p = write_encoder_csv(d / "run.csv", EncoderLog(t, left, right, None))
    write_tum(d / "run_gt.tum", _trajectory())
    return p, p


def _csv_run_gt(d: Path) -> tuple[Path, Path]:
    p, _ = _csv_run(d)
    return d / "run_gt.tum", p


def _sensorlog(d: Path) -> tuple[Path, Path]:
    from odolab.io.sensorlog import write_sensorlog

    t = 100.0 + 0.02 * np.arange(30)
    p = write_sensorlog(d / "imu.csv", t, 0.4 * t, np.full(30, 0.4), compass_every=3)
    return p, p


_OPTIODOM_META = (
    "type,diff,\nngear,43.7,\nencRes,64,\nLi,0.2,\nDi,0.084,0.084\nThi,,\nN,2,\nL,1.5,\n"
    "imarkers,4,3\n"
)


def _optiodom(which: str) -> Callable[[Path], tuple[Path, Path]]:
    def make(d: Path) -> tuple[Path, Path]:
        run_dir = d / "square" / "2312"
        run_dir.mkdir(parents=True)
        meta = run_dir / "2312_metadata.csv"
        meta.write_text(_OPTIODOM_META)
        t = 0.05 * np.arange(30)
        rows = [
            f"{float(ti)!r},{0.01 * k!r},{0.002 * k!r},{0.003 * k!r},{19 + k % 3},{23 - k % 2}"
            for k, ti in enumerate(t)
        ]
        run = run_dir / "2312_run-01.csv"
        run.write_text("\n".join(rows) + "\n")
        return (meta if which == "meta" else run), run

    return make


def _params(d: Path) -> tuple[Path, Path]:
    from odolab.core.params import PRESETS, NoiseParams, save_params

    p = save_params(
        d / "robot.toml",
        PRESETS["jaguar-lite"].with_(noise=NoiseParams(1e-4, 2e-4, 0.01)),
        provenance={"method": "umbmark", "runs": 4},
    )
    return p, p


def _bag_drive(n: int = 30) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = 100.0 + 0.05 * np.arange(n)
    left = 0.2 * np.arange(n)
    right = 0.25 * np.arange(n)
    return t, left, right


def _bag(kind: str) -> Callable[[Path], tuple[Path, Path]]:
    def make(d: Path) -> tuple[Path, Path]:
        import sys

        sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "io"))
        from bag_fixtures import write_bag  # tests/io: rosbags' own writers

        t, left, right = _bag_drive()
        gt = _trajectory(15)
        gt = type(gt).from_xytheta(gt.t + 100.0, gt.x, gt.y, gt.theta)
        if kind == "ros1":
            p = write_bag(d / "run.bag", t, left, right, gt, ros1=True)
            return p, p
        folder = write_bag(d / "run_ros2", t, left, right, gt, storage=kind)
        if kind == "metadata":
            return folder / "metadata.yaml", folder
        storage = next(q for q in folder.iterdir() if q.suffix in (".db3", ".mcap"))
        return storage, folder

    return make


def _scan_mcap(d: Path) -> tuple[Path, Path]:
    from odolab.io.scans import LaserScans, write_scan_mcap

    n, beams = 6, 24
    ranges = 2.0 + 0.1 * np.sin(np.arange(n * beams).reshape(n, beams))
    scans = LaserScans(
        t=1.0 + 0.1 * np.arange(n),
        ranges=ranges,
        angle_min=-math.pi / 2,
        angle_increment=math.pi / (beams - 1),
        range_min=0.05,
        range_max=10.0,
    )
    p = d / "scans.mcap"
    write_scan_mcap(p, scans, joint_t=np.arange(5) * 0.1 + 1.0, wheel_angles=np.zeros((5, 2)))
    return p, p


def _notebook_json(d: Path) -> tuple[Path, Path]:
    """A real notebook's JSON export: three trials (encoder logs included), two campaigns, a
    parameter version; an empty notebook beside it for the import target."""
    from odolab.store import Notebook
    from store.conftest import make_trials  # (tests/ is on the path)

    with Notebook(d / "src.db") as nb:
        nb.add_campaign("rot-lab", "rotation", "lab", operator="me", notes="n")
        nb.add_trials(make_trials(3, seed=5, with_logs=True))
        nb.export_json(d / "nb.json")
    _fixed_times(d / "nb.json")
    with Notebook(d / "into.db"):
        pass
    return d / "nb.json", d / "nb.json"


def _fixed_times(p: Path) -> None:
    """The export's times of writing made fixed, so that a (target, case) pair is the same
    file on every run."""
    import json

    def fix(node: object) -> None:
        if isinstance(node, dict):
            for key, value in node.items():
                if key in ("created", "updated", "replaced", "date") and isinstance(value, str):
                    node[key] = "2026-01-02" if key == "date" else "2026-01-02T03:04:05+00:00"
                else:
                    fix(value)
        elif isinstance(node, list):
            for item in node:
                fix(item)

    doc = json.loads(p.read_text(encoding="utf-8"))
    fix(doc)
    p.write_text(json.dumps(doc, indent=1), encoding="utf-8")


def _notebook_csv(d: Path) -> tuple[Path, Path]:
    from odolab.store import Notebook
    from store.conftest import make_trials

    with Notebook(d / "src.db") as nb:
        nb.add_campaign("rot-lab", "rotation", "lab")
        nb.add_trials(make_trials(3, seed=5))
        nb.export_csv(d / "nb.csv")
    with Notebook(d / "into.db"):
        pass
    return d / "nb.csv", d / "nb.csv"


def _read_notebook_json(p: Path) -> object:
    from odolab.store.jsonio import read_notebook_json

    return read_notebook_json(p)


def _import_notebook(p: Path) -> object:
    """Import into the empty notebook beside the file; what was imported is taken out again
    (deleted notebook file), so that every case meets an empty notebook."""
    from odolab.store import Notebook

    db = p.with_name("into.db")
    template = p.with_name("into.template")
    if not template.exists():
        shutil.copyfile(db, template)
    shutil.copyfile(template, db)
    for extra in ("-wal", "-shm"):
        Path(f"{db}{extra}").unlink(missing_ok=True)
    with Notebook(db) as nb:
        if p.suffix == ".json":
            return nb.import_json(p)
        return nb.import_csv(p, create_campaigns=True)


def _read_optiodom(p: Path) -> object:
    from odolab.io.optiodom import read_optiodom_run

    return read_optiodom_run(p)


def _read_run(fmt: str) -> Callable[[Path], object]:
    def read(p: Path) -> object:
        from odolab.io import read_run

        return read_run(p, fmt)

    return read


def _read_traj(p: Path) -> object:
    from odolab.io import read_trajectory

    return read_trajectory(p)


def _read_encoder(p: Path) -> object:
    from odolab.io import read_encoder_csv

    return read_encoder_csv(p, modulus=32768)


def _read_chunks(p: Path) -> object:
    from odolab.io.chunked import iter_encoder_chunks

    return list(iter_encoder_chunks(p, chunk_rows=7, modulus=32768))


def _read_sensorlog(p: Path) -> object:
    from odolab.io.sensorlog import read_sensorlog

    return read_sensorlog(p)


def _read_params(p: Path) -> object:
    from odolab.core.params import load_params

    return load_params(p)


def _read_scans(p: Path) -> object:
    from odolab.io.scans import read_scans

    return read_scans(p)


def _read_bag_topics(p: Path) -> object:
    from odolab.io import bag_topics, read_bag_trajectory

    bag_topics(p)
    return read_bag_trajectory(p, "/ground_truth")


#: Every reader, by name.
TARGETS: dict[str, Target] = {
    t.name: t
    for t in (
        Target("encoder-csv", _encoder(".csv"), _read_encoder),
        Target("encoder-parquet", _encoder(".parquet"), _read_encoder),
        Target("encoder-arrow", _encoder(".arrow"), _read_encoder),
        Target("encoder-csv-chunks", _encoder(".csv"), _read_chunks),
        Target("encoder-parquet-chunks", _encoder(".parquet"), _read_chunks),
        Target("trajectory-csv", _traj(".csv"), _read_traj),
        Target("trajectory-parquet", _traj(".parquet"), _read_traj),
        Target("tum", _traj(".tum"), _read_traj),
        Target("registry-csv-run", _csv_run, _read_run("csv")),
        Target("registry-csv-run-gt", _csv_run_gt, _read_run("csv")),
        Target("sensorlog", _sensorlog, _read_sensorlog),
        Target("registry-optiodom-run", _optiodom("run"), _read_run("optiodom")),
        Target("registry-optiodom-metadata", _optiodom("meta"), _read_run("optiodom")),
        Target("params-toml", _params, _read_params),
        Target("registry-bag-ros1", _bag("ros1"), _read_run("bag")),
        Target("registry-bag-sqlite3", _bag("sqlite3"), _read_run("bag")),
        Target("registry-bag-mcap", _bag("mcap"), _read_run("bag")),
        Target("bag-metadata-yaml", _bag("metadata"), _read_run("bag")),
        Target("bag-trajectory-mcap", _bag("mcap"), _read_bag_topics),
        Target("scans-mcap", _scan_mcap, _read_scans),
        Target("optiodom-run", _optiodom("run"), _read_optiodom),
        Target("optiodom-metadata", _optiodom("meta"), _read_optiodom),
        Target("notebook-json", _notebook_json, _read_notebook_json),
        Target("notebook-json-import", _notebook_json, _import_notebook),
        Target("notebook-csv-import", _notebook_csv, _import_notebook),
    )
}


def prepare(target: Target, root: Path) -> tuple[bytes, Path, Path]:
    """Seed files of ``target`` in a fresh folder under ``root``: (seed bytes, file to mutate,
    path to read). The valid seed must read without error."""
    folder = root / target.name
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    mutable, read_path = target.make(folder)
    target.read(read_path)  # the seed itself is valid
    return mutable.read_bytes(), mutable, read_path
