"""The report's readable sections: validation table, after-calibration table, additional results,
and the proportional fit (Table I's ratio) beside the line with an intercept."""

from __future__ import annotations

import html
import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.container import ErrorbarContainer
from matplotlib.figure import Figure

from odolab.analysis import LabAnalysis
from odolab.calibration import ratios_from_analysis
from odolab.core import numfmt
from odolab.report import figures as F
from odolab.report import write_report
from odolab.report.html import _extra_view, _fmt, _validation_view
from odolab.validation import plot_validation, rotation_scenario, simulate_phone_log, validate

EXTRA: dict[str, Any] = {
    "seed": 4314,
    "truth": "jaguar-lab",
    "true_params": {
        "left_radius_forward": 0.07618545030205576,
        "track_width": 0.583936385548691,
        "terrain_radius_scale": [["concrete", 1.0159302335380749], ["grass", 0.998227]],
        "name": "jaguar-lab",
    },
    "after_calibration": {
        "method": "ratios",
        "ratios": {"rotation_tile": 1.0022475866970841, "y_forward_tile": 1.03},
        "note": "the campaign re-run with the calibrated parameters",
    },
    "live_runs": {"runs": 11, "cycles": 15915, "rate_hz": 20.0},
    "notebook": "/tmp/lab/odolab.db",
    "something_new": {"a": [1, 2]},
}


@pytest.fixture(scope="module")
def check():  # type: ignore[no-untyped-def]
    sc = rotation_scenario(seed=2)
    phone = simulate_phone_log(sc.true_t, sc.true_heading, clock_offset=5.5, bias=0.002, seed=7)
    return validate(sc.encoder_log, phone, sc.old, sc.new)


@pytest.fixture(scope="module")
def full(tmp_path_factory: pytest.TempPathFactory, analysis: LabAnalysis, check) -> Path:  # type: ignore[no-untyped-def]
    out = tmp_path_factory.mktemp("full")
    return write_report(
        out,
        analysis,
        {"ratios": ratios_from_analysis(analysis)},
        check.to_dict(series=False),
        validation_figure=lambda ax: plot_validation(check, ax=ax, kind="heading"),
        extra=EXTRA,
    )


def _table(text: str, table_id: str) -> str:
    m = re.search(rf'<table id="{table_id}"[^>]*>(.*?)</table>', text, re.S)
    assert m is not None, table_id
    return html.unescape(m.group(1))


def _cells(row_html: str) -> list[str]:
    return [
        re.sub(r"<[^>]+>", "", c).strip()
        for c in re.findall(r"<t[dh][^>]*>(.*?)</t[dh]>", row_html, re.S)
    ]


def _row(table: str, label: str) -> list[str]:
    for tr in re.findall(r"<tr>(.*?)</tr>", table, re.S):
        cells = _cells(tr)
        if cells and cells[0] == label:
            return cells
    raise AssertionError(f"no row {label!r}")


def test_validation_is_a_table_with_the_json_numbers(full: Path) -> None:
    text = full.read_text()
    v = json.loads((full.parent / "results.json").read_text())["validation"]
    assert v["old"]["rms_error_rad"] > 1.0 > v["new"]["rms_error_rad"]  # the scenario's point
    sets = _table(text, "validation-sets")
    for label, key in (
        ("RMS heading error (rad)", "rms_error_rad"),
        ("final heading error (rad)", "final_error_rad"),
        ("max |heading error| (rad)", "max_abs_error_rad"),
        ("predicted rotation (rad)", "predicted_rotation_rad"),
        ("actual/predicted rotation (IMU)", "ratio_actual_over_predicted"),
    ):
        assert _row(sets, label)[1:] == [_fmt(v["old"][key]), _fmt(v["new"][key])]
    assert _row(sets, "parameter set")[1:] == [
        v["old"]["params"]["name"],
        v["new"]["params"]["name"],
    ]
    assert _row(sets, "track width (m)")[1:] == [
        _fmt(v["old"]["params"]["track_width"], 6),
        _fmt(v["new"]["params"]["track_width"], 6),
    ]
    summary = _table(text, "validation-summary")
    offset = _row(summary, "clock offset found")[1]
    assert offset.startswith(f"{_fmt(v['clock_offset_s'])} s") and "5.5" in offset
    assert _row(summary, "yaw-rate correlation at that offset")[1] == _fmt(
        v["offset_correlation"], 3
    )
    a, b = v["overlap_s"]
    assert _row(summary, "overlap of the two logs")[1].startswith(f"{_fmt(b - a)} s")
    assert _row(summary, "rotation measured by the IMU")[1] == f"{_fmt(v['imu_rotation_rad'])} rad"
    # no raw JSON dump of the dict any more, the figure sits in the section
    assert '"rms_error_rad"' not in html.unescape(text)
    section = text.split("<h2>Validation</h2>", 1)[1]
    assert 'id="validation"' in section.split("<h2>", 1)[0]


def test_validation_warnings_are_a_note_and_unknown_keys_are_kept() -> None:
    v = {
        "clock_offset_s": 1.25,
        "offset_correlation": None,
        "warnings": ["the yaw rates correlate only 0.72"],
        "extra_number": 0.5,
    }
    view = _validation_view(v)
    assert view["warnings"] == ["the yaw rates correlate only 0.72"]
    assert ("clock offset found", "1.25 s") in view["summary"]
    assert view["other"] == {"extra_number": "0.5"}
    assert view["sets"] is None


def test_validation_warning_box_in_the_page(tmp_path: Path, analysis: LabAnalysis) -> None:
    path = write_report(
        tmp_path, analysis, None, {"clock_offset_s": 2.0, "warnings": ["low correlation"]},
        figures=False,  # the box is the page's text
    )  # fmt: skip
    text = path.read_text()
    note = text.split("<h2>Validation</h2>", 1)[1]
    assert re.search(r'<div class="note"><b>Warnings:</b><ul>\s*<li>low correlation</li>', note)


def test_after_calibration_table_and_place(full: Path) -> None:
    text = full.read_text()
    after = _table(text, "after-calibration")
    assert _row(after, "rotation")[1:] == ["tile", _fmt(1.0022475866970841, 5), "yes"]
    assert _row(after, "y_forward")[1:] == ["tile", "1.03", "no"]
    # right after the calibrated parameters, before the validation
    i_cal = text.index("<h2>Calibrated parameters")
    i_after = text.index("<h2>After calibration</h2>")
    i_val = text.index("<h2>Validation</h2>")
    assert i_cal < i_after < i_val
    assert "The campaign re-run with the calibrated parameters." in text


def test_additional_results_tables_and_json_fallback(full: Path) -> None:
    text = full.read_text()
    res = json.loads((full.parent / "results.json").read_text())
    assert res["extra"] == json.loads(json.dumps(EXTRA))  # every number kept
    run = _table(text, "extra-run")
    assert _row(run, "random seed")[1] == "4314"
    assert _row(run, "lab notebook")[1] == "/tmp/lab/odolab.db"
    live = _table(text, "extra-live")
    assert _row(live, "control cycles")[1] == "15915"
    truth = _table(text, "extra-true-params")
    assert _row(truth, "track width")[1] == "0.583936"
    assert _row(truth, "terrain radius scale")[1] == "concrete 1.01593; grass 0.998227"
    extra_part = html.unescape(text.split("<h2>Additional results</h2>", 1)[1])
    # an unknown key is a readable row, not raw JSON
    assert _row(_table(text, "extra-other"), "something_new › a")[1] == "1, 2"
    assert "<pre" not in extra_part and "{" not in extra_part
    assert '"after_calibration"' not in extra_part  # shown as a table, not dumped


def test_extra_view_without_known_keys_is_readable_rows() -> None:
    view = _extra_view({"k": 1, "nested": {"a": 0.1 + 0.2}})
    assert view["other"] == [("k", "1"), ("nested › a", "0.3")]
    assert view["after"] is None and view["run"] == []


def test_fit_figure_draws_the_proportional_fit(analysis: LabAnalysis) -> None:
    m = analysis.get("rotation")
    assert m.ratio_fit is not None
    ax = F.plot_fit(m, Figure().add_subplot())
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    lo, hi = m.ratio_fit.slope_ci95
    want = f"ratio (through origin) {m.ratio:.3f} [{lo:.3f}, {hi:.3f}]"
    assert want in texts
    assert any(t.startswith("fit with intercept: slope") for t in texts)
    line = next(ln for ln in ax.get_lines() if ln.get_label() == want)
    x, y = (np.asarray(a, dtype=float) for a in line.get_data())
    np.testing.assert_allclose(y, m.ratio_fit.slope * x)  # through the origin
    assert line.get_linestyle() == "--"
    # y rows have no proportional fit: no such line
    ym = analysis.get("y_forward")
    ax = F.plot_fit(ym, Figure().add_subplot())
    assert not any("through origin" in t.get_text() for t in ax.get_legend().get_texts())


def test_terrain_slopes_show_slope_and_ratio(analysis: LabAnalysis) -> None:
    ax = F.plot_terrain_slopes(analysis, "x", Figure().add_subplot())
    bars = [c for c in ax.containers if isinstance(c, ErrorbarContainer)]
    assert [b.get_label() for b in bars] == [
        "slope with intercept (F-test), 95% CI",
        "ratio (through origin), 95% CI",
    ]
    ms = [m for m in analysis.motions if m.motion == "x"]
    np.testing.assert_allclose(bars[0].lines[0].get_xdata(), [m.fit.slope for m in ms])
    np.testing.assert_allclose(bars[1].lines[0].get_xdata(), [m.ratio for m in ms])


def test_fits_table_has_the_ratio_beside_the_slope(full: Path, analysis: LabAnalysis) -> None:
    text = html.unescape(full.read_text())
    fits = _table(text, "fits")
    assert "ratio through the origin [95 % CI]" in fits
    for m in analysis.motions:
        cells = _row(fits, f"{m.motion} ({m.terrain})")
        assert cells[1] == numfmt.with_ci(m.fit.slope, *m.fit.slope_ci95)
        if m.ratio_fit is not None:
            assert cells[4] == numfmt.with_ci(m.ratio_fit.slope, *m.ratio_fit.slope_ci95)
            # e.g. "0.8683 [0.8571, 0.8795]": decimals from the interval's half-width
            lo, hi = m.ratio_fit.slope_ci95
            assert len(cells[4].split(" ")[0].split(".")[1]) == numfmt.decimals_for((hi - lo) / 2)
        else:
            assert cells[4] == "-"
    note = text.split("<h2>Systematic error: fits</h2>", 1)[0].rsplit("</table>", 1)[1]
    assert "proportional fit" in note and "through the origin" in note
    assert "slope of the line with an intercept" in note and "per metre travelled" in note
