"""The report's kinematic-model and covariance (NEES) sections: shown when there is data for
them, numbers checked by hand and against the chi-square table, text escaped."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from odolab.analysis import LabAnalysis
from odolab.calibration import ratios_from_analysis
from odolab.calibration.compare import Estimate, ModelComparison, ModelScore, compare_models
from odolab.core import numfmt
from odolab.core.params import PRESETS
from odolab.core.trajectory import Trajectory
from odolab.io.run import OdometryRun
from odolab.metrics.consistency import RunNees
from odolab.report import write_report
from odolab.report.models_section import ModelEvidence, consistency_view, models_view
from odolab.sim.drives import drive, random_legs
from odolab.sim.presets import TRUTH_PRESETS

NOMINAL = PRESETS["jaguar-lite"]


def _nees(name: str, values: list[float]) -> RunNees:
    k = len(values)
    return RunNees(name, 10.0, 0.0, np.array(values), np.zeros((k, 3)), np.ones(k))


#: 5 pieces: mean 24 / 5 = 4.8; 1, 2, 3, 6 inside chi2(3)'s 95 % band [0.2158, 9.348], 12 above
RUNS = (_nees("run-a", [1.0, 2.0, 3.0]), _nees("<b>run-b</b>", [6.0, 12.0]))


def test_consistency_numbers_match_the_chi_square_table() -> None:
    ev = ModelEvidence(nees=RUNS, about_nees="hand-made pieces")
    d = ev.consistency_dict()
    assert d is not None
    s = d["summary"]
    assert s["n"] == 5 and s["mean_nees"] == pytest.approx(4.8, abs=1e-12)
    # chi-square table, 3 dof: 0.216 and 9.348; 15 dof: 6.262 and 27.488 (mean of 5 = sum / 5)
    assert s["single_bounds95"] == pytest.approx([0.2158, 9.3484], abs=1e-4)
    assert s["mean_bounds95"] == pytest.approx([6.262 / 5, 27.488 / 5], abs=1e-3)
    assert s["fraction_inside"] == pytest.approx(0.8) and s["fraction_above"] == pytest.approx(0.2)
    assert s["verdict"].startswith("honest")
    view = consistency_view(d)
    cells = {c.label: c.text for c in view["rows"][0]}
    assert cells["pieces"] == "5" and cells["mean NEES"] == "4.80"
    assert cells["inside one piece's bounds"] == "80 %" and cells["above"] == "20 %"
    assert view["single"] == "[0.216, 9.35]"
    assert view["per_run"] == "run-a 2.00 (3); <b>run-b</b> 9.00 (2)"
    assert "95 % bounds of the mean (χ², 15 dof)" in cells  # 5 pieces of 3


def test_fitted_yaw_offsets_take_their_degrees_of_freedom_in_the_labels() -> None:
    """With a fitted yaw offset per run, the mean's bounds say how many degrees of freedom are
    left (not "3 dof" a piece), and the figure's expected mean is below 3."""
    from dataclasses import replace

    import matplotlib.pyplot as plt

    from odolab.report.models_section import plot_nees

    runs = tuple(replace(r, dof_removed=1) for r in RUNS)
    d = ModelEvidence(nees=runs, about_nees="offsets fitted").consistency_dict()
    assert d is not None
    cells = {c.label: c.text for c in consistency_view(d)["rows"][0]}
    assert "95 % bounds of the mean (χ², 13 dof)" in cells
    ax = plot_nees(runs)
    labels = ax.get_legend_handles_labels()[1]
    assert "expected mean (2.6: 2 fitted yaw offsets)" in labels
    plt.close(ax.figure)


def _score(model: str, k: int, err: float, lo: float, hi: float, ratio: Estimate) -> ModelScore:
    return ModelScore(
        model,
        k,
        None,
        held_out={
            "endpoint_error": Estimate(err, lo, hi),
            "rpe_rmse": Estimate(0.05, math.nan, math.nan),
            "drift_pct": Estimate(1.25, 1.0, 1.5),
            "drift_deg_per_m": Estimate(0.5, 0.4, 0.6),
        },
        delta_bic=Estimate(-1e-13 if model == "extended" else 0.0, -2e-11, 3e-11),
        ratio_to_best=ratio,
    )


def test_models_view_rows_recommendation_and_problems() -> None:
    cmp = ModelComparison(
        scores=[
            _score("diff", 3, 0.1234, 0.1, 0.15, Estimate(1.0000000003, 0.9999999998, 1.0000004)),
            _score("extended", 3, 0.1234, 0.1, 0.15, Estimate(1.0, 1.0, 1.0)),
            ModelScore("icr", 5, None, problem="x_icr is not identifiable <without turns>"),
        ],
        recommended="diff",
        reason="diff is simpler",
        train=["a", "b", "c"],
        held_out=["d"],
        cross_validated=False,
    )
    ev = ModelEvidence(cmp, about_models="three runs")
    view = models_view(json.loads(json.dumps(ev.models_dict())))  # as read from results.json
    assert view["recommended"] == "diff" and view["about"] == "three runs"
    assert view["runs"] == "fitted on 3 runs, scored on 1 held-out run"
    assert [r[0].text for r in view["rows"]] == ["diff", "extended"]
    diff = {c.label: c.text for c in view["rows"][0]}
    assert diff["held-out end-point error (m)"] == "0.123 [0.100, 0.150]"
    assert diff["RPE over 1 m (m)"] == "0.05"  # no interval (one held-out run)
    assert diff["error / best"] == "1"  # an interval of 1e-6 is not printed
    ext = {c.label: c.text for c in view["rows"][1]}
    assert ext["ΔBIC vs diff"] == "0"  # rounding noise of 1e-13 is 0
    assert view["problems"] == [("icr", "x_icr is not identifiable <without turns>")]


def _runs(n: int) -> list[OdometryRun]:
    truth = TRUTH_PRESETS["jaguar-lab-tracked"].with_(
        turn_slip=0.0, speed_slip=0.0, stop_slide=0.0, k_scrub=1e-5, align_sigma=0.0
    )
    out = []
    for s in range(n):
        d = drive(truth, NOMINAL, random_legs(np.random.default_rng(s), 12), seed=s)
        gt = Trajectory.from_xyh(d.t, d.x, d.y, d.heading)
        name = f"<i>run {s}</i>"
        out.append(OdometryRun(name, name, d.t, d.dticks_left, d.dticks_right, ground_truth=gt))
    return out


@pytest.fixture(scope="module")
def evidence() -> ModelEvidence:
    from odolab.core.params import NoiseParams
    from odolab.metrics.consistency import run_nees

    runs = _runs(4)
    cmp = compare_models(runs[:3], runs[3:], NOMINAL, models=("diff", "icr"), n_boot=200)
    noisy = NOMINAL.with_(noise=NoiseParams(2e-5, 2e-5, 1e-5))
    nees = tuple(run_nees(r, noisy, segment_s=5.0) for r in runs)
    return ModelEvidence(cmp, nees, "four <runs>", "noise & more", ("a <note>",))


def test_report_shows_both_sections_escaped(
    tmp_path: Path, analysis: LabAnalysis, evidence: ModelEvidence
) -> None:
    html_path = write_report(
        tmp_path, analysis, {"ratios": ratios_from_analysis(analysis)}, evidence=evidence
    )
    page = html_path.read_text()
    assert 'id="kinematic-model"' in page and 'id="consistency"' in page
    assert evidence.comparison is not None
    assert f"<b>Recommended: {evidence.comparison.recommended}</b>" in page
    assert "four &lt;runs&gt;" in page and "noise &amp; more" in page and "a &lt;note&gt;" in page
    assert "&lt;i&gt;run 0&lt;/i&gt;" in page and "<i>run 0</i>" not in page
    assert 'id="models"' in page and 'id="nees"' in page  # the two tables
    assert '<figure id="model_comparison">' in page and '<figure id="nees_pieces">' in page
    assert (tmp_path / "figures" / "model_comparison.png").stat().st_size > 1000
    assert (tmp_path / "figures" / "nees_pieces.png").stat().st_size > 1000
    ids = re.findall(r'\bid="([^"]+)"', page)
    assert len(ids) == len(set(ids))  # no id twice
    res = json.loads((tmp_path / "results.json").read_text())
    assert res["models"]["recommended"] == evidence.comparison.recommended
    assert res["consistency"]["summary"]["n"] == sum(r.nees.size for r in evidence.nees)
    assert res["evidence_missing"] == ["a <note>"]
    s = res["consistency"]["summary"]
    assert res["summary"][-2].startswith(f"Kinematic model: {res['models']['recommended']} (")
    assert res["summary"][-1].startswith(
        f"Propagated covariance: mean NEES {numfmt.plain(s['mean_nees'], 3)} over {s['n']} pieces"
    )


def test_report_without_evidence_has_neither_section(tmp_path: Path, analysis: LabAnalysis) -> None:
    page = write_report(tmp_path, analysis, figures=False).read_text()  # the sections' text
    assert 'id="kinematic-model"' not in page and 'id="consistency"' not in page
    res = json.loads((tmp_path / "results.json").read_text())
    assert res["models"] is None and res["consistency"] is None
