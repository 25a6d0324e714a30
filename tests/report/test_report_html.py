"""The report: files written, numbers consistent between HTML and results.json, figures labelled."""

from __future__ import annotations

import html
import json
import re
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from odolab.analysis import LabAnalysis, table1
from odolab.calibration import ratios_from_analysis, umbmark
from odolab.cli import main
from odolab.core import numfmt
from odolab.report import figures as F
from odolab.report import table1_rich, write_report


def _calibrations(analysis: LabAnalysis) -> dict[str, object]:
    return {
        "ratios": ratios_from_analysis(analysis),
        "umbmark": umbmark(
            [[-0.11, -0.12], [-0.1, -0.1]], [[-0.05, 0.05]], 4.0, analysis.params
        ).with_after([[0.01, 0.0], [-0.01, 0.0]], [[0.0, 0.005]]),
    }


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory, analysis: LabAnalysis) -> Path:
    out = tmp_path_factory.mktemp("report")

    def imu(ax):
        ax.plot([0, 1], [0, 1], label="IMU")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("heading (rad)")
        ax.legend()
        return ax

    return write_report(
        out, analysis, _calibrations(analysis), {"rmse_heading_old": 0.5},
        validation_figure=imu, extra={"k": 1},
    )  # fmt: skip


def test_files_and_results_json(report: Path) -> None:
    res = json.loads((report.parent / "results.json").read_text())
    assert {"table1", "analysis", "calibration", "validation", "summary", "figures"} <= set(res)
    for row in res["table1"]:
        assert {"motion", "terrain", "ratio", "ratio_ci95"} <= set(row)
        assert row["ratio_ci95"][0] < row["ratio"] < row["ratio_ci95"][1]
        if "sigma" in row:
            assert "sigma_at" in row
    assert {r["motion"] for r in res["table1"]} >= {"rotation", "x", "y_forward", "y_reverse"}
    assert set(res["calibration"]) == {"ratios", "umbmark"}
    assert res["calibration"]["umbmark"]["e_max_syst_after"] == pytest.approx(0.005)
    assert "track_width" in res["calibration"]["ratios"]["params"]
    for rel in res["figures"].values():
        png = report.parent / rel
        assert png.stat().st_size > 5000
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "validation" in res["figures"]
    assert res["validation"] == {"rmse_heading_old": 0.5}


def test_html_is_self_contained_and_matches_the_json(report: Path) -> None:
    text = report.read_text()
    srcs = re.findall(r'src="([^"]*)"', text)
    assert srcs and all(s.startswith("data:image/png;base64,") for s in srcs)
    assert "<link" not in text and "<script" not in text
    res = json.loads((report.parent / "results.json").read_text())
    plain = html.unescape(text)
    for sentence in res["summary"]:
        assert sentence in plain
    # one number rule: a ratio carries the digits its 95 % interval supports, everywhere
    for row in res["table1"]:
        assert numfmt.with_ci(row["ratio"], *row["ratio_ci95"]) in plain
    new = res["calibration"]["ratios"]["params"]["track_width"]
    assert f"track width {numfmt.plain(new, 5, strip=True)} m" in plain
    assert '<meta name="viewport"' in text


def test_long_provenance_cells_are_collapsed(report: Path) -> None:
    """Issue 38, item 13: provenance cells that were walls of trial ids (the report 42,000 px
    tall on a phone) show their start; the whole text is a tap away, escaped."""
    text = report.read_text()
    cells = re.findall(r'<td class="l" data-label="value">(.*?)</td>', text, re.S)
    visible = [re.sub(r"<details.*?</details>", "", c, flags=re.S) for c in cells]
    assert max(len(c) for c in visible) <= 240
    folded = [c for c in cells if c.startswith('<details class="long"><summary>')]
    assert folded and all("characters: show all)</summary>" in c for c in folded)
    assert any("k_left" in c and len(c) > 1000 for c in folded)  # the noise fit's trial lists


def test_the_umbmark_verdict_says_what_before_is(analysis: LabAnalysis) -> None:
    """Issue 38, item 13: "UMBmark E_max,syst 1.58 -> 1.32 m" took the ratios version as
    "before" without saying so."""
    from odolab.report.view import verdict

    umb = umbmark([[-0.11, -0.12]], [[-0.05, 0.05]], 4.0, analysis.params).with_after(
        [[0.01, 0.0]], [[0.0, 0.005]]
    )
    start = "the ratios calibration of the same trials on tile (UMBmark iterated ...), itself from"
    v = verdict(analysis, {"umbmark": umb}, [], None, {"umbmark_from": start})
    labels = [row[0] for row in v.improvements]
    assert labels == [
        "UMBmark E_max,syst, same squares (umbmark; before: with the ratios calibration of the "
        "same trials on tile) (m)"
    ]
    v = verdict(analysis, {"umbmark": umb}, [], None, None)
    assert "before: with the parameters UMBmark started from" in v.improvements[0][0]


def test_summary_numbers_come_from_the_analysis(report: Path, analysis: LabAnalysis) -> None:
    res = json.loads((report.parent / "results.json").read_text())
    rot = analysis.get("rotation")
    lo, hi = rot.ratio_ci95
    assert any(f"{numfmt.with_ci(rot.ratio, lo, hi)} rad/rad" in s for s in res["summary"])
    # the reader's words, never the internal motion names ("X:", "Y_forward:", "y_reverse on")
    import re

    internal = re.compile(r"\b(X|Y_forward|Y_reverse|y_forward|y_reverse)\b")
    assert not [s for s in res["summary"] if internal.search(s)]
    assert any(s.startswith("Distance (x): slopes on ") for s in res["summary"])


@pytest.mark.parametrize(
    "draw",
    [
        lambda a, ax: F.plot_fit(a.get("rotation"), ax),
        lambda a, ax: F.plot_residuals(a.get("y_forward"), ax),
        lambda a, ax: F.plot_histogram(a.get("rotation").groups[0], "rad", ax),
        lambda a, ax: F.plot_growth(a.get("y_reverse"), ax),
        lambda a, ax: F.plot_terrains(a, "x", ax),
        lambda a, ax: F.plot_terrain_slopes(a, "x", ax),
        lambda a, ax: F.plot_error_ellipses(a, "tile", ax),
        lambda a, ax: F.plot_calibration_effect(
            a, a.params, {"ratios": ratios_from_analysis(a).params}, "rotation", ax
        ),
        lambda a, ax: F.plot_umbmark(
            np.array([[0.1, 0.1]]), np.array([[0.1, -0.1]]), ax, after=(np.zeros((1, 2)),) * 2
        ),
    ],
)
def test_figures_draw_on_the_given_axes_with_labels(analysis: LabAnalysis, draw) -> None:
    ax = Figure().add_subplot()
    assert draw(analysis, ax) is ax
    assert "(" in ax.get_xlabel() and ax.get_ylabel()  # a unit in brackets
    assert ax.get_legend() is not None
    assert ax.get_title()


def test_calibration_effect_puts_new_predictions_on_the_ideal_line(analysis) -> None:
    ax = Figure().add_subplot()
    F.plot_calibration_effect(
        analysis, analysis.params, {"r": ratios_from_analysis(analysis).params}, "rotation", ax
    )
    label = [t.get_text() for t in ax.get_legend().get_texts() if t.get_text().startswith("new")]
    slope = float(label[0].rsplit("ratio ", 1)[1])
    assert slope == pytest.approx(1.0, abs=0.01)


def test_table1_rich_renders_every_row(analysis: LabAnalysis) -> None:
    from rich.console import Console

    con = Console(record=True, width=200)
    con.print(table1_rich(table1(analysis)))
    text = con.export_text()
    for row in table1(analysis):
        assert row["terrain"] in text
    assert "y_reverse" in text


def _fake_store(monkeypatch: pytest.MonkeyPatch, trials) -> None:
    import odolab.store as store

    class Notebook:
        def __init__(self, path: Path) -> None:
            self.path = path

        def __enter__(self):
            return self

        def __exit__(self, *exc: object) -> None:
            return None

        def load_trials(self, **_: object):
            return trials

        def campaigns(self) -> list[object]:
            return []

        def find_params_version(self, params: object) -> int:
            return 1  # (the report says which version its calibrations start from)

    monkeypatch.setattr(store, "Notebook", Notebook, raising=False)


def test_cli_analyze_and_report(tmp_path: Path, lab, monkeypatch, capsys) -> None:
    _fake_store(monkeypatch, lab)
    db = tmp_path / "lab.db"
    db.write_bytes(b"")
    assert main(["analyze", "--db", str(db), "--json", str(tmp_path / "a.json")]) == 0
    out = capsys.readouterr().out
    assert "Table I" in out and "rotation" in out
    assert json.loads((tmp_path / "a.json").read_text())["n_measured"] == len(lab)
    _fake_store(monkeypatch, lab[:38])  # the rotation campaign: fewer figures, faster
    assert main(["report", "--db", str(db), "--out", str(tmp_path / "rep")]) == 0
    assert (tmp_path / "rep" / "report.html").exists()
    assert "report:" in capsys.readouterr().out


def test_cli_too_few_trials_is_one_line(tmp_path: Path, lab, monkeypatch, capsys) -> None:
    _fake_store(monkeypatch, lab[:2])
    db = tmp_path / "lab.db"
    db.write_bytes(b"")
    assert main(["analyze", "--db", str(db)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "at least 3" in err and "nan" not in err.lower()


def test_report_from_square_runs_only(tmp_path: Path) -> None:
    """A notebook with only UMBmark squares: no fits, but the UMBmark section and figure."""
    import sys

    sys.path.insert(0, str(Path(__file__).parents[1] / "calibration"))
    from test_umbmark import NOM, _square_trials

    from odolab.analysis import analyze_trials
    from odolab.calibration import umbmark_errors_from_trials

    trials = _square_trials(NOM.with_(track_width=0.57), np.random.default_rng(0))
    analysis = analyze_trials(trials)
    assert table1(analysis) == []
    cw, ccw, side = umbmark_errors_from_trials(analysis.square_trials)
    path = write_report(tmp_path, analysis, {"umbmark": umbmark(cw, ccw, side, NOM)})
    res = json.loads((tmp_path / "results.json").read_text())
    assert list(res["figures"]) == ["umbmark_umbmark"]
    assert res["calibration"]["umbmark"]["e_b"] > 1.0
    assert "UMBmark" in path.read_text()


def test_a_report_without_figures_has_every_number(
    tmp_path: Path, analysis: LabAnalysis, report: Path
) -> None:
    """``figures=False`` (``odolab report --no-figures``) draws nothing: no figures folder, no
    image, a note at the page's top; the tables and results.json are the full report's (the
    module's, from the same inputs)."""
    bare = write_report(tmp_path / "bare", analysis, _calibrations(analysis),
                        {"rmse_heading_old": 0.5}, extra={"k": 1}, figures=False)  # fmt: skip
    whole = report
    assert not (bare.parent / "figures").exists() and (whole.parent / "figures").is_dir()
    page = bare.read_text()
    assert "<img" not in page and 'id="figures-left-out"' in page
    assert 'id="figures-left-out"' not in whole.read_text()

    def numbers(path: Path) -> dict[str, object]:
        doc = json.loads((path.parent / "results.json").read_text())
        doc.pop("generated")
        for c in doc["calibration"].values():
            c["provenance"].pop("created")
        return doc

    a, b = numbers(bare), numbers(whole)
    assert a.pop("figures") == {} and b.pop("figures")
    assert a == b

    def tables(text: str) -> list[str]:  # the calibrations' "made" times masked
        found = re.findall(r"<table.*?</table>", text, flags=re.S)
        return [re.sub(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ", "T", t) for t in found]

    assert tables(page) == tables(whole.read_text())


def test_cli_report_no_figures_says_so(tmp_path: Path, lab, monkeypatch, capsys) -> None:
    _fake_store(monkeypatch, lab[:38])
    db = tmp_path / "lab.db"
    db.write_bytes(b"")
    assert main(["report", "--db", str(db), "--out", str(tmp_path / "rep"), "--no-figures"]) == 0
    assert "results.json beside it; figures left out" in capsys.readouterr().out
    assert not (tmp_path / "rep" / "figures").exists()


def test_a_report_without_figures_has_no_empty_figure_list(
    tmp_path: Path, analysis: LabAnalysis
) -> None:
    page = write_report(tmp_path, analysis, figures=False).read_text()
    assert "(0 figures)" not in page and "<figure" not in page
