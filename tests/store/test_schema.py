"""Schema v2 on a new file, the real v1 -> v2 migration, and refusals."""

from __future__ import annotations

import math
import shutil
import sqlite3
from pathlib import Path

import pytest

from odolab.core.errors import StoreError
from odolab.core.trials import TrialStatus
from odolab.store import SCHEMA_VERSION, Notebook

FIXTURES = Path(__file__).parent / "fixtures"


def test_new_notebook_has_wal_foreign_keys_and_version(tmp_path: Path) -> None:
    db = tmp_path / "n.db"
    with Notebook(db) as nb:
        assert nb.migrated_from == 0
        assert nb.integrity_check() == "ok"
    conn = sqlite3.connect(db)
    assert conn.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION == 3
    assert conn.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type='table'")}
    assert {"robots", "params_versions", "campaigns", "trials", "encoder_logs"} <= tables
    conn.close()
    with Notebook(db) as nb:  # reopening does not migrate again
        assert nb.migrated_from == 3
        assert nb._conn.execute("PRAGMA foreign_keys").fetchone()[0] == 1


def test_v1_fixture_migrates_with_everything_kept(tmp_path: Path) -> None:
    db = tmp_path / "old.db"
    shutil.copy(FIXTURES / "notebook_v1.db", db)
    with Notebook(db) as nb:
        assert nb.migrated_from == 1
        assert nb.integrity_check() == "ok"
        # params_sets ids 1, 3 (jaguar-lite) and 2 (other) became versions 1, 2 and 1
        versions = nb.params_versions("jaguar-lite")
        assert [(v.version, v.params.track_width) for v in versions] == [(1, 0.56), (2, 0.64)]
        assert versions[0].method == "unknown (from schema v1)"
        assert versions[1].created == "2019-03-05T10:00:00+00:00"
        assert nb.latest_params("other").ticks_per_rev == 1000
        assert nb.latest_params("other").encoder_modulus is None
        r01 = nb.get_trial("R01")
        assert nb.trial_params_version("R01") == ("jaguar-lite", 1)
        assert nb.trial_params_version("R02") == ("jaguar-lite", 2)
        assert r01.measured is not None
        assert r01.measured.rotation == pytest.approx(8 * 2 * math.pi + math.radians(316.9))
        assert r01.measured.raw["turns"] == 8.0
        assert r01.encoder_log is None
        r03 = nb.get_trial("R03")
        assert r03.status is TrialStatus.EXCLUDED
        assert r03.exclusion_reason == "excluded (no reason recorded in schema v1)"
        assert [c.name for c in nb.campaigns()] == ["rot-lab", "fwd-grass"]
        assert nb.get_campaign("rot-lab").operator == "A.B."
        assert len(nb.load_trials()) == 4
        # a migrated notebook takes new versions after the old ones
        p = nb.latest_params("jaguar-lite").with_(track_width=0.7)
        assert nb.add_params_version(p, method="ratios", source_trials=["R01"]) == 3


def test_newer_schema_is_refused_and_not_touched(tmp_path: Path) -> None:
    db = tmp_path / "future.db"
    conn = sqlite3.connect(db)
    conn.execute("PRAGMA user_version = 9")
    conn.close()
    with pytest.raises(StoreError, match="newer odolab"):
        Notebook(db)


def test_foreign_sqlite_file_is_refused(tmp_path: Path) -> None:
    db = tmp_path / "other.db"
    conn = sqlite3.connect(db)
    conn.execute("CREATE TABLE x (a)")
    conn.commit()
    conn.close()
    with pytest.raises(StoreError, match="not an odolab notebook"):
        Notebook(db)
    garbage = tmp_path / "garbage.db"
    garbage.write_bytes(b"hello, this is not sqlite at all" * 20)
    with pytest.raises(StoreError, match=r"is not an odolab notebook \(not a SQLite database"):
        Notebook(garbage)


def test_v2_fixture_opens_with_everything(tmp_path: Path) -> None:
    db = tmp_path / "v2.db"
    shutil.copy(FIXTURES / "notebook_v2.db", db)
    with Notebook(db) as nb:
        assert nb.migrated_from == 2
        assert nb.integrity_check() == "ok"
        assert [(v.version, v.method, v.source_trials, v.notes)
                for v in nb.params_versions("jaguar-lite")] == [
            (1, "preset", (), ""), (2, "ratios", ("R01",), "sec VIII")]  # fmt: skip
        r01 = nb.get_trial("R01")
        # 20 deg ccw replaced an earlier 30 deg reading, which is kept in the history
        assert r01.measured is not None
        assert r01.measured.rotation == pytest.approx(math.radians(340.0))
        (_, old), *_ = nb.measurement_history("R01")
        assert old.rotation == pytest.approx(math.radians(330.0))
        assert r01.encoder_log is not None and len(r01.encoder_log) == 41
        assert int(r01.encoder_log.left_ticks[-1]) == (32700 - 25 * 40) % 32768
        f01 = nb.get_trial("F01")
        assert (f01.status, f01.exclusion_reason, f01.notes) == (
            TrialStatus.EXCLUDED, "tape moved", "windy")  # fmt: skip
        assert nb.get_campaign("fwd-grass").kind == "translation"
        assert nb.trial_params_version("F01") == ("jaguar-lite", 1)
