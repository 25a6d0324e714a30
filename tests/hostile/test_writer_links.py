"""A symbolic link planted at an output path is replaced, never followed (odolab.core.writing).

Each test plants a link at the name a writer is about to write, pointing at a file outside the
output folder, and checks that the file outside is byte for byte unchanged afterwards while the
output folder holds the new file. On the code before odolab.core.writing, every writer opened its path
with ``write_text``/``open("w")``/``savefig(path)``, which follow the link and overwrite the file
outside.
"""

from __future__ import annotations

import json
import os
import stat
import sys
from pathlib import Path

import numpy as np
import pytest

from odolab.cli import main
from odolab.core.errors import OdolabError, StoreError
from odolab.core.writing import (
    OutputFileError,
    replacing_file,
    replacing_path,
    sub_folder,
    write_text_file,
)

SECRET = b"not odolab's to change\n"


def _plant(link: Path, outside: Path) -> None:
    outside.write_bytes(SECRET)
    link.parent.mkdir(parents=True, exist_ok=True)
    link.symlink_to(outside)


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


# -- the helper ------------------------------------------------------------------------------------


def test_a_link_at_the_path_is_replaced_and_its_target_kept(tmp_path: Path) -> None:
    out, outside = tmp_path / "out", tmp_path / "outside.txt"
    _plant(out / "a.txt", outside)
    write_text_file(out / "a.txt", "new", what="test file")
    assert outside.read_bytes() == SECRET
    assert not (out / "a.txt").is_symlink() and (out / "a.txt").read_text() == "new"
    assert sorted(p.name for p in out.iterdir()) == ["a.txt"]  # no temporary file left


def test_the_new_file_has_the_permissions_open_would_give(tmp_path: Path) -> None:
    path = write_text_file(tmp_path / "p.txt", "x", what="test file")
    assert stat.S_IMODE(path.stat().st_mode) == 0o666 & ~_umask()


def test_a_failed_write_keeps_the_old_file_and_leaves_no_temporary_file(tmp_path: Path) -> None:
    path = tmp_path / "keep.csv"
    path.write_text("old", encoding="utf-8")
    with pytest.raises(RuntimeError, match="half way"), replacing_file(path, what="t") as fh:
        fh.write("half")
        raise RuntimeError("half way")
    assert path.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["keep.csv"]


def test_the_temporary_path_keeps_the_suffix_and_the_folder(tmp_path: Path) -> None:
    with replacing_path(tmp_path / "table.parquet", what="t") as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".parquet" and tmp.name.startswith(".")
        tmp.write_bytes(b"x")
    assert (tmp_path / "table.parquet").read_bytes() == b"x"


def test_a_folder_in_the_place_of_the_file_is_one_sentence(tmp_path: Path) -> None:
    (tmp_path / "r.html").mkdir()
    with pytest.raises(StoreError, match=r"r\.html: is a folder; expected a file name for the x"):
        write_text_file(tmp_path / "r.html", "", what="x", error=StoreError)


def test_a_linked_sub_folder_is_refused(tmp_path: Path) -> None:
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "figures").symlink_to(tmp_path / "elsewhere")
    with pytest.raises(OutputFileError, match=r"figures: is a symbolic link; expected the"):
        sub_folder(tmp_path / "out", "figures", what="report figures")
    assert sub_folder(tmp_path / "out", "new", what="x").is_dir()


# -- the writers -----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def small_analysis() -> object:
    sys.path.insert(0, str(Path(__file__).parents[1] / "analysis"))
    from synth_trials import rotation_trials, translation_trials

    from odolab.analysis import analyze_trials

    rng = np.random.default_rng(2)
    return analyze_trials(rotation_trials(rng, repeats_at_20pi=3) + translation_trials(rng))


def test_the_report_replaces_links_at_every_output(
    tmp_path: Path, small_analysis: object, monkeypatch: pytest.MonkeyPatch
) -> None:
    import odolab.report.html as html
    from odolab.report import write_report

    plan = html._figure_plan
    monkeypatch.setattr(html, "_figure_plan", lambda *a: plan(*a)[:2])  # two figures: faster
    out = tmp_path / "rep"
    names = [f"{p.name}.png" for p in plan(small_analysis, {}, None, None, None)[:2]]
    targets = {}
    for i, rel in enumerate(["report.html", "results.json", *(f"figures/{n}" for n in names)]):
        targets[rel] = tmp_path / f"outside-{i}"
        _plant(out / rel, targets[rel])
    page = write_report(out, small_analysis)  # type: ignore[arg-type]
    assert page == out / "report.html"
    for rel, outside in targets.items():
        assert outside.read_bytes() == SECRET, rel
        assert not (out / rel).is_symlink() and (out / rel).stat().st_size > 0, rel
    assert json.loads((out / "results.json").read_text())["figures"]
    assert "<html" in page.read_text(encoding="utf-8")


def test_the_report_refuses_a_linked_figures_folder(tmp_path: Path, small_analysis: object) -> None:
    from odolab.report import write_report

    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "rep").mkdir()
    (tmp_path / "rep" / "figures").symlink_to(tmp_path / "elsewhere")
    with pytest.raises(OdolabError, match="figures: is a symbolic link"):
        write_report(tmp_path / "rep", small_analysis)  # type: ignore[arg-type]
    assert list((tmp_path / "elsewhere").iterdir()) == []


@pytest.mark.parametrize("suffix", [".csv", ".json"])
def test_trials_export_replaces_a_link(
    tmp_path: Path, suffix: str, capsys: pytest.CaptureFixture[str]
) -> None:
    from tests.store.conftest import make_trials

    from odolab.store import Notebook

    db = tmp_path / "lab.db"
    with Notebook(db) as nb:
        nb.add_campaign("rot-lab", "rotation", "lab")
        nb.add_trials(make_trials(3, seed=4))
    out, outside = tmp_path / "out" / f"trials{suffix}", tmp_path / "outside"
    _plant(out, outside)
    assert main(["trials", "export", str(out), "--db", str(db)]) == 0, capsys.readouterr().err
    assert outside.read_bytes() == SECRET
    assert not out.is_symlink() and "T0" in out.read_text(encoding="utf-8")


def test_the_fleet_table_replaces_a_link(tmp_path: Path) -> None:
    from odolab.fleet.table import COLUMNS, read_fleet_table, write_fleet_table

    row = {c: [1.0] for c in COLUMNS} | {"samples": [3], "run": ["r"], "source": ["s"]}
    row |= {"robot": ["jag"], "date": ["2024-05-01"], "error": [None]}
    out, outside = tmp_path / "fleet.csv", tmp_path / "outside"
    _plant(out, outside)
    write_fleet_table(row, out)
    assert outside.read_bytes() == SECRET
    assert read_fleet_table(out)["robot"] == ["jag"]


def test_a_replaced_file_keeps_its_permissions(tmp_path: Path) -> None:
    path = tmp_path / "params.toml"
    path.write_text("old", encoding="utf-8")
    path.chmod(0o600)
    write_text_file(path, "new", what="test file")
    assert path.read_text() == "new" and stat.S_IMODE(path.stat().st_mode) == 0o600
