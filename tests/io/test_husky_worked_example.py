"""The numbers of docs/real-logs.md's worked example (the DRIVE Husky, fitted on even command
steps, held out on odd ones): nominal -> fitted models -> compare -> NEES.

One end-to-end run over the whole table (about 30 s on two cores): the doc's numbers are the
Husky's, not a subset's."""

from __future__ import annotations

import numpy as np
import pytest
from tests.shared_data import require

from odolab.calibration.compare import compare_models
from odolab.io import find_runs, read_run
from odolab.io.run import ReadOptions
from odolab.metrics.consistency import nees_of_runs, nees_summary
from odolab.metrics.runs import RUN_OPTIONS, evaluate_run
from odolab.params import PRESETS

pytestmark = pytest.mark.slow

HUSKY = PRESETS["jaguar-lite"].with_(
    name="husky",
    left_wheel_radius=0.165,
    right_wheel_radius=0.165,
    track_width=0.55,
    encoder_modulus=None,
)


def test_husky_even_steps_fitted_odd_steps_held_out() -> None:
    table = require("drive-husky") / "husky_windows.csv"
    ro = ReadOptions(params=HUSKY)
    train = [read_run(p, "drive", ro) for p in find_runs([f"{table}#even"], "drive")]
    held = [read_run(p, "drive", ro) for p in find_runs([f"{table}#odd"], "drive")]
    assert (len(train), len(held)) == (289, 314)
    updates = np.array([r.meta["truth_updates"] for r in [*train, *held]], dtype=float)
    assert np.median(updates) == 20  # of 40 rows: the lidar's ~10 Hz, the rest held values

    nominal = np.mean(
        [evaluate_run(r, HUSKY, RUN_OPTIONS).evaluation.drift.endpoint_error for r in held]
    )
    assert round(float(nominal), 3) == 0.462

    c = compare_models(train, held, HUSKY, models=("diff", "extended", "icr", "slip"))
    end = {s.model: s.held_out["endpoint_error"].value for s in c.scores}
    assert {k: round(v, 3) for k, v in end.items()} == {
        "diff": 0.227,
        "extended": 0.227,
        "icr": 0.208,
        "slip": 0.181,
    }
    assert round(end["slip"] / min(end["diff"], end["extended"], end["icr"]), 2) == 0.87
    assert c.segments == 154 and c.recommended == "slip"
    ratios = {s.model: s.ratio_to_best for s in c.scores}
    icr = ratios["icr"]
    assert icr is not None
    assert (round(icr.value, 3), round(icr.low, 3), round(icr.high, 3)) == (1.150, 1.090, 1.218)
    # the risk per run, against the best kinematic model on the decision's segments (diff)
    assert c.score("slip").runs_worse == (55, 153)
    assert c.score("extended").runs_worse == (0, 153)  # the same model as diff here
    assert "slip is worse than diff (the best kinematic model) on 55 of 153" in c.reason
    seg = c.score("slip").segment_error
    assert seg is not None and round(seg.value, 3) == 0.218

    diff, icr_fit = c.score("diff").fit, c.score("icr").fit
    assert diff is not None and icr_fit is not None
    assert round(diff.values["track_width"], 1) == 1.1  # the Husky turns less than its wheels say
    assert round(icr_fit.values["y_icr_left"], 1) == 0.6
    assert round(-icr_fit.values["y_icr_right"], 1) == 0.7
    slip = c.score("slip").fit
    assert slip is not None
    results, skipped, _ = nees_of_runs(held, lambda _r: slip.params, segment_s=1.0)
    s = nees_summary(results)
    assert not skipped and s.n == 314
    assert round(s.mean, 2) == 3.53 and tuple(round(b, 2) for b in s.mean_bounds95) == (2.74, 3.28)
