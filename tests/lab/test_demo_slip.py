"""The demo on the tracked virtual Jaguar explores for a minute and sets the slip model beside the
kinematic ones (issue 29); on the default truth it explores nothing and says why. The report,
results.json and ``calibrate compare`` on the runs the lab wrote agree (one rule:
odolab.app.models). Structure and parity only: the slip fit's accuracy is another session's."""

from __future__ import annotations

import json
import math
import re
import shlex
from pathlib import Path
from typing import Any

import pytest

from fixture_cache import slip_fits_once
from odolab.app.demo import LabResult
from odolab.app.models import CURVE_SECONDS, SLIP_MODELS
from odolab.cli import main
from odolab.core import numfmt

#: `make test-fast` leaves these out (the tracked demo); `make test` and CI run them
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def tracked(tracked_demo: LabResult) -> tuple[LabResult, dict[str, Any]]:
    """The session's tracked demo (conftest.py; it built its own smaller one before)."""
    return tracked_demo, json.loads(tracked_demo.results.read_text())


def test_tracked_demo_compares_the_slip_model_with_a_learning_curve(
    tracked: tuple[LabResult, dict[str, Any]],
) -> None:
    result, res = tracked
    slip = res["slip"]
    assert res["slip_note"] is None
    ex = slip["exploration"]
    assert ex["seconds"] == 60 and ex["seed"] == res["extra"]["seed"] and ex["terrain"] == "tile"
    assert {"max_speed", "max_turn_rate", "hold", "fence_radius", "distribution"} <= set(ex)
    cmp = slip["comparison"]
    assert [m["model"] for m in cmp["models"]] == list(SLIP_MODELS)
    assert cmp["train"] == ["explore"]  # the minute of exploration alone
    assert cmp["held_out"] == res["models"]["held_out"]  # the same held-out runs
    for m in cmp["models"]:  # fitted, or one sentence why not (e.g. icr not identifiable)
        assert (m["problem"] is None) == (m["values"] is not None), m["model"]
    assert cmp["recommended"] in (*SLIP_MODELS, "undecided") and cmp["reason"]
    curve = cmp["learning_curve"]
    assert [(r["seconds"], r["model"]) for r in curve] == [
        (s, m) for s in CURVE_SECONDS for m in SLIP_MODELS
    ]
    for r in curve:
        assert (r["endpoint_error"] is None) == (r["problem"] is not None)
        assert r["endpoint_error"] is None or r["endpoint_error"] >= 0
    sq = slip["speed_question"]
    assert (sq["v_low"], sq["v_high"]) == (0.1, 0.5)  # the speed experiment's two speeds
    lo, hi = sq["ci95"]
    assert lo <= sq["gain_pct"] <= hi and math.isfinite(lo) and math.isfinite(hi)
    assert sq["measured"]["experiment"] == "speed-sweep"
    assert math.isfinite(sq["measured"]["difference_pct"])
    # the kinematic comparison is what it was: diff, extended and icr only
    assert [m["model"] for m in res["models"]["models"]] == ["diff", "extended", "icr"]
    assert any(s.startswith("Slip model from 60 s of exploration") for s in res["summary"])
    assert (result.folder / "runs" / "explore.csv").is_file()
    assert (result.folder / "runs" / "explore_gt.csv").is_file()


def test_tracked_report_shows_table_curve_figure_and_speed_answer(
    tracked: tuple[LabResult, dict[str, Any]],
) -> None:
    result, res = tracked
    page = result.report.read_text()
    for marker in ('id="slip-model"', 'id="slip-models"', 'id="learning-curve"',
                   'id="slip-speed"', '<figure id="learning_curve">'):  # fmt: skip
        assert marker in page, marker
    assert res["figures"]["learning_curve"] == "figures/learning_curve.png"
    assert (result.folder / "figures" / "learning_curve.png").stat().st_size > 1000
    cmp = res["slip"]["comparison"]
    section = page[page.index('id="slip-model"') : page.index('id="consistency"')]
    assert f"<b>Recommended: {cmp['recommended']}</b>" in section
    for m in SLIP_MODELS:
        assert f'data-label="model">{m}</td>' in section
    for m in cmp["models"]:  # a model that could not be fitted says why, in its row
        if m["problem"]:
            assert "Not fitted from these runs: " in section
    assert "<span>compare</span> <span>runs/explore.csv</span>" in section  # the command
    # the open question on speed has the slip model's answer beside the measured one
    questions = page[page.index('id="open-questions"') :]
    assert "From one minute of exploration, the slip model says 0.5 m/s slips" in questions
    ids = re.findall(r'\bid="([^"]+)"', page)
    assert len(ids) == len(set(ids))


def test_learning_curve_equals_calibrate_compare_on_the_written_runs(
    tracked: tuple[LabResult, dict[str, Any]],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    result, res = tracked
    slip = res["slip"]
    words = shlex.split(slip["command"])
    assert words[:3] == ["odolab", "calibrate", "compare"]
    args = words[1:]
    out = tmp_path / "compare.json"
    args[args.index("--json") + 1] = str(out)
    monkeypatch.chdir(result.folder)  # the command's paths are relative to the run folder
    # the same inputs give the demo's slip fits without fitting again (tests/fixture_cache.py);
    # an input prepared differently would be fitted anew and its numbers compared
    with slip_fits_once():
        assert main([*args, "--workers", "1"]) == 0
    capsys.readouterr()
    cli = json.loads(out.read_text())
    lab = slip["comparison"]
    assert cli["learning_curve"] == lab["learning_curve"]
    assert (cli["recommended"], cli["reason"]) == (lab["recommended"], lab["reason"])
    for a, b in zip(cli["models"], lab["models"], strict=True):
        assert (a["model"], a["problem"], a["segment_error"]) == (
            b["model"], b["problem"], b["segment_error"],
        )  # fmt: skip


def test_slip_covariance_nees_in_the_report_equals_evaluate_on_the_written_files(
    tracked: tuple[LabResult, dict[str, Any]],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """The report judges the slip fit's predictive covariance on the held-out runs (NEES over
    3 s pieces), and the `odolab evaluate --nees` line it gives reproduces the numbers from the
    run folder's files (runs/slip.toml, the held-out runs)."""
    result, res = tracked
    nees = res["slip"]["nees"]
    assert nees["piece_s"] == 3.0 and nees["n"] > 10
    lo, hi = nees["mean_bounds95"]
    assert lo < 3.0 < hi
    page = (result.folder / "report.html").read_text()
    assert "Is its predictive covariance honest?" in page
    assert f"mean NEES {numfmt.plain(nees['mean_nees'], 3)} over {nees['n']} pieces" in page
    words = shlex.split(res["slip"]["nees_command"])
    assert words[:2] == ["odolab", "evaluate"] and "runs/slip.toml" in words
    out = tmp_path / "nees.json"
    monkeypatch.chdir(result.folder)
    capsys.readouterr()
    assert main([*words[1:], "--json", str(out)]) == 0
    assert "the slip model's predictive variance" in capsys.readouterr().out
    cli = json.loads(out.read_text())["nees"]["summary"]
    assert cli["n"] == nees["n"]
    assert cli["mean_nees"] == pytest.approx(nees["mean_nees"], rel=1e-12)
    assert cli["verdict"] == nees["verdict"]


def test_default_truth_explores_nothing_and_says_why(default_demo: tuple[LabResult, Any]) -> None:
    result = default_demo[0]
    res = json.loads(result.results.read_text())
    assert res["slip"] is None
    assert res["slip_note"].startswith("No exploration run: the truth preset jaguar-lab has no")
    page = result.report.read_text()
    assert 'id="slip-model"' not in page and 'id="slip-note"' in page
    assert "learning_curve" not in res["figures"]
    assert not (result.folder / "runs").exists()


def _hand_made_slip() -> dict[str, Any]:
    """A ``slip`` entry with text that must be escaped and a model that was not fitted."""
    est = {"value": 0.3, "ci95": [0.25, 0.35]}
    fitted = {
        "n_params": 3, "problem": None, "values": {"left_wheel_radius": 0.08},
        "stderr": {"left_wheel_radius": 0.001}, "held_out": {"endpoint_error": est},
        "segment_error": est, "ratio_to_best": {"value": 1.0, "ci95": [1.0, 1.0]},
        "delta_bic": None, "verdict": "best",
    }  # fmt: skip
    icr = {"model": "icr", "n_params": 5, "problem": "x_icr is <not> identifiable",
           "values": None}  # fmt: skip
    return {
        "exploration": {"seconds": 60.0, "seed": 1, "terrain": "tile"},
        "about": "explored <b>here</b>",
        "comparison": {
            "recommended": "diff",
            "reason": "diff & co",
            "train": ["explore"],
            "held_out": ["h"],
            "cross_validated": False,
            "models": [{"model": "diff", **fitted}, icr],
            "learning_curve": [
                {"seconds": 10.0, "model": "diff", "endpoint_error": 1.5, "problem": None},
                {
                    "seconds": 10.0,
                    "model": "icr",
                    "endpoint_error": None,
                    "problem": "x_icr <needs> turns",
                },
                {"seconds": 60.0, "model": "diff", "endpoint_error": 1.25, "problem": None},
                {
                    "seconds": 60.0,
                    "model": "icr",
                    "endpoint_error": None,
                    "problem": "x_icr <needs> turns",
                },
            ],
        },
        "speed_question": {
            "v_low": 0.1,
            "v_high": 0.5,
            "gain_pct": 1.4,
            "ci95": [0.5, 2.3],
            "answer": "faster <slips>",
            "problem": None,
        },
        "command": "odolab calibrate compare 'a <b>.csv'",
    }


def test_slip_section_escapes_text_and_shows_the_unfitted_model(tmp_path: Path) -> None:
    import sys

    import numpy as np

    sys.path.insert(0, str(Path(__file__).parents[1] / "analysis"))
    from synth_trials import rotation_trials, translation_trials

    from odolab.analysis import analyze_trials
    from odolab.report import write_report
    from odolab.report.models_section import ModelEvidence, learning_curve_view

    rng = np.random.default_rng(2)
    analysis = analyze_trials(rotation_trials(rng, repeats_at_20pi=3) + translation_trials(rng))
    slip = _hand_made_slip()
    page = write_report(tmp_path, analysis, evidence=ModelEvidence(slip=slip)).read_text()
    section = page[page.index('id="slip-model"') :]
    for raw in ("<b>here</b>", "<not>", "<needs>", "<slips>", "'a <b>.csv'"):
        assert raw not in page, raw
    assert "explored &lt;b&gt;here&lt;/b&gt;" in section and "diff &amp; co" in section
    assert "Not fitted from these runs: x_icr is &lt;not&gt; identifiable." in section
    assert "faster &lt;slips&gt;" in section
    view = learning_curve_view(slip["comparison"]["learning_curve"])
    assert [[c.text for c in row] for row in view["rows"]] == [
        ["diff", "1.50", "1.25"], ["icr", "not fitted", "not fitted"],
    ]  # fmt: skip
    assert view["notes"] == ["icr: not fitted at 10, 60 s (at 60 s: x_icr <needs> turns)."]
    assert (tmp_path / "figures" / "learning_curve.png").stat().st_size > 1000
    res = json.loads((tmp_path / "results.json").read_text())
    assert res["slip"]["about"] == "explored <b>here</b>"  # the JSON keeps the text as it is
