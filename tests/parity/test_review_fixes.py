"""What a cross-face review found saying different things (each test names the old behaviour):
the report's UMBmark iterations table, its model-comparison footnote, the first-order note on
NEES, the trials a ratios calibration records, the repeat sigma's distance on the web, and the
terrain a ratios calibration picks."""

from __future__ import annotations

import html
import json
import re
from pathlib import Path

import numpy as np
import pytest

from odolab.analysis import analyze_trials
from odolab.store import Notebook

from .faces import cli, client
from .notebooks import VALIDATION, make_notebook


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A generated notebook with squares and their logs (seed 4), and its report folder."""
    folder = tmp_path_factory.mktemp("rev")
    gen = make_notebook(folder, 4, two_robots=False)
    cli("report", "--db", gen.db, "--out", folder / "rep")
    return gen.db, folder / "rep"


def test_the_umbmark_iterations_table_has_every_iterate_in_its_columns(
    report: tuple[Path, Path],
) -> None:
    """Its summary said 12 iterations for 11, numbered 1-12 against the file's 0-11, and the
    last row (the result: no step from it) sat four columns to the left."""
    _, rep = report
    doc = json.loads((rep / "results.json").read_text())
    its = doc["calibration"]["umbmark"]["provenance"]["iterations"]
    steps = doc["calibration"]["umbmark"]["provenance"]["n_iterations"]
    assert len(its) == steps + 1
    page = (rep / "report.html").read_text()
    assert f"<summary>{steps} iterations ({steps + 1} iterates:" in page
    table = re.search(r'<table id="iterations-umbmark".*?</table>', page, re.S)
    assert table
    head = re.findall(r"<th>([^<]*)</th>", table.group(0))
    rows = re.findall(r"<tr>(<td.*?)</tr>", table.group(0), re.S)
    assert head[0] == "iterate" and len(rows) == steps + 1
    cells = [re.findall(r'<td data-label="([^"]*)">([^<]*)</td>', r) for r in rows]
    assert all(len(c) == len(head) for c in cells)
    assert [c[0][1] for c in cells] == [str(i) for i in range(steps + 1)]
    last = dict(cells[-1])
    assert last["alpha"] == "–" and last["e max syst"] != "–"  # E_max under its own column
    emax = float(last["e max syst"])
    assert emax == pytest.approx(its[-1]["e_max_syst"], rel=1e-4)


def test_the_report_says_what_error_over_best_is() -> None:
    """The footnote said end-point error; the column (and the recommendation) is the paired
    segment error."""
    import odolab.report

    text = (Path(odolab.report.__file__).parent / "templates" / "report.html.j2").read_text()
    assert "error / best: the mean held-out segment error over the best model's" in text
    assert "error / best: mean end-point error" not in text


def test_the_reports_nees_says_when_pieces_pass_first_order() -> None:
    """`evaluate --nees` said it, the report did not: one function, first_order_note."""
    from odolab.metrics.consistency import RunNees
    from odolab.report.models_section import ModelEvidence, consistency_view

    run = RunNees("r", 10.0, 0.0, np.array([3.0, 90.0]), np.zeros((2, 3)), np.ones(2),
                  second_order=np.array([0.01, 0.9]))  # fmt: skip
    cons = ModelEvidence(nees=(run,)).consistency_dict()
    assert cons is not None and cons["summary"]["pieces_past_first_order"] == 1
    note = consistency_view(cons)["first_order_note"]
    assert note.startswith("1 of 2 pieces go past the first-order covariance's range")
    clean = RunNees("r", 1.0, 0.0, np.array([3.0]), np.zeros((1, 3)), np.ones(1),
                    second_order=np.array([0.01]))  # fmt: skip
    cons = ModelEvidence(nees=(clean,)).consistency_dict()
    assert cons is not None and consistency_view(cons)["first_order_note"] == ""


def test_a_ratios_version_records_the_trials_of_its_fits(report: tuple[Path, Path]) -> None:
    """It recorded every trial of the selection (the squares too), while its notes counted the
    fits' trials."""
    db, _ = report
    c = client(db)
    res = c.post("/api/calibrate", json={"method": "ratios", "robot": "jaguar-lite"})
    assert res.status_code == 200, res.text
    terrain = res.json()["terrain"]
    with Notebook(db) as nb:
        version = nb.params_versions("jaguar-lite")[-1]
        trials = nb.load_trials(status="measured", with_logs=False)
    analysis = analyze_trials([t for t in trials if t.campaign != VALIDATION])
    fits = set()
    for motion in ("x", "rotation"):
        m = analysis.get(motion, terrain)
        assert m is not None
        fits.update(m.fit.trial_ids)
    kinds = {t.trial_id: t.command.kind.value for t in trials}
    assert fits <= set(version.source_trials)
    assert not any(kinds.get(t) == "square" for t in version.source_trials)


def test_the_web_table1_says_where_each_sigma_was_measured(
    report: tuple[Path, Path], tmp_path: Path
) -> None:
    """It showed one sigma and its count without its distance; the CLI and the report list
    every repeated distance with its own."""
    import shutil

    db = shutil.copy(report[0], tmp_path / "lab.db")
    for k, x in enumerate((1.93, 1.95, 1.90, 0.97, 0.96, 0.98)):
        d = "2.0" if k < 3 else "1.0"
        cli("trials", "add", "--id", f"S{k}", "--campaign", "repeats", "--terrain", "tile",
            "--create-campaign",
            "--kind", "translation",
            "--distance", d, "--predicted-x", d, "--x", str(x), "--y", "0.0", "--db", db)  # fmt: skip
    page = client(db).get("/table1", params={"campaign": "repeats"}).text
    cells = re.findall(r'<td class="sigma"[^>]*>(.*?)</td>', page, re.S)
    shown = [html.unescape(c) for c in cells if c != "–"]
    assert shown, cells
    assert any(" @ 1 (n 3)" in c and " @ 2 (n 3)" in c for c in shown), shown


def test_calibrate_ratios_says_which_terrain_it_chose(
    report: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from odolab.cli import main

    db, _ = report
    assert main(["calibrate", "ratios", "--db", str(db), "-o", str(tmp_path / "r.toml")]) == 0
    out = capsys.readouterr().out
    assert "(not given, so chosen: the first, alphabetically, with both a rotation and an x" in out
    assert main(["calibrate", "ratios", "--db", str(db), "--terrain", "tile", "-o",
                 str(tmp_path / "t.toml")]) == 0  # fmt: skip
    assert "not given, so chosen" not in capsys.readouterr().out
