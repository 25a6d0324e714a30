"""The kinematic-model report section: escaped HTML and figures from real results."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from odolab.analysis.questions import load_experiment, run_experiment
from odolab.calibration.compare import compare_models
from odolab.core.params import PRESETS
from odolab.report.models_section import (
    models_section_html,
    plot_model_comparison,
    plot_questions,
)
from odolab.sim.presets import TRUTH_PRESETS

from .test_identification import random_run

NOMINAL = PRESETS["jaguar-lite"]


def test_section_html_and_figures(tmp_path: Path) -> None:
    import matplotlib.pyplot as plt

    runs = [random_run(s) for s in (200, 201, 202)]
    cmp = compare_models(runs, (), NOMINAL, models=("diff", "icr"), n_boot=200)
    q = run_experiment(
        load_experiment("stops"), TRUTH_PRESETS["jaguar-lab-tracked"], NOMINAL, repeats=4
    )
    html = models_section_html(cmp, [q])
    assert f"<b>Recommended: {cmp.recommended}</b>" in html
    assert "abrupt stop slips" in html
    # text from files is escaped
    tricky = q.experiment.__class__(**{**q.experiment.__dict__, "question": "<b>x</b>?"})
    tq = q.__class__(**{**q.__dict__, "experiment": tricky})
    assert "&lt;b&gt;x&lt;/b&gt;?" in models_section_html(None, [tq])
    ax = plot_model_comparison(cmp)
    assert [t.get_text() for t in ax.get_xticklabels()] == ["diff", "icr"]
    ax.figure.savefig(tmp_path / "models.png")
    fig = plot_questions([q])
    fig.savefig(tmp_path / "questions.png")
    # a question and conditions from a user's file are drawn as typed: `$\foo$` was
    # matplotlib's parse error (a traceback) before odolab.core.text.figure_text
    typed = q.experiment.__class__(**{**q.experiment.__dict__, "question": r"Does $\foo$ slip?"})
    conditions = [
        dataclasses.replace(c, condition=dataclasses.replace(c.condition, label=r"$\foo$"))
        for c in q.conditions
    ]
    mq = q.__class__(**{**q.__dict__, "experiment": typed, "conditions": conditions})
    plot_questions([mq]).savefig(tmp_path / "typed.png")
    plt.close("all")
    assert (tmp_path / "questions.png").stat().st_size > 1000
    assert np.isfinite(cmp.score("icr").held_out["endpoint_error"].value)
