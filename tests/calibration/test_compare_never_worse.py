"""`calibrate compare` never recommends a learned model that is worse than the best kinematic
one on the held-out data (issue 37): checked on the rule itself, with made-up scores."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from odolab.calibration.compare import (
    Estimate,
    ModelScore,
    _choose,
    _never_worse,
    _resample_weights,
)


def _scores(slip_end: float, slip_runs_worse: tuple[int, int]) -> tuple[list[ModelScore], dict]:
    rng = np.random.default_rng(5)
    seg = {
        "diff": 1.0 + 0.05 * rng.standard_normal(30),
        "icr": 1.3 + 0.05 * rng.standard_normal(30),
        "slip": 0.5 + 0.05 * rng.standard_normal(30),
    }
    ends = {"diff": 1.0, "icr": 1.4, "slip": slip_end}
    out = []
    for m, e in seg.items():
        out.append(
            ModelScore(
                m,
                3,
                None,
                held_out={"endpoint_error": Estimate(ends[m], ends[m], ends[m])},
                segment_errors=[list(e[:10]), list(e[10:20]), list(e[20:])],
                runs_worse=slip_runs_worse if m == "slip" else None,
            )
        )
    return out, {m: np.asarray(v) for m, v in seg.items()}


def _decide(slip_end: float, runs_worse: tuple[int, int]) -> tuple[str, str]:
    scores, errors = _scores(slip_end, runs_worse)
    idx = _resample_weights([10, 10, 10], np.random.default_rng(0), 500)
    # verdicts against the best of all (slip), as compare gives them; fit=None skips BIC
    best = min(errors, key=lambda m: float(np.mean(errors[m])))
    marked = [replace(s, verdict="best" if s.model == best else "worse") for s in scores]
    what = "30 held-out segments"
    rec, why = _choose(marked, next(s for s in marked if s.verdict == "best"), what)
    assert rec == "slip"
    return _never_worse(marked, errors, idx, rec, why, what)


def test_a_learned_model_better_everywhere_stays_recommended() -> None:
    rec, why = _decide(0.6, (1, 3))
    assert rec == "slip"
    assert "per run, slip is worse than diff (the best kinematic model) on 1 of 3" in why


def test_worse_on_held_out_end_points_falls_back_to_the_kinematic_choice() -> None:
    rec, why = _decide(1.8, (1, 3))
    assert rec == "diff"
    assert "held-out mean end-point error 1.8 m is above the best kinematic model's 1 m" in why
    assert "among the kinematic models, diff has the lowest mean error" in why


def test_worse_on_most_runs_falls_back_too() -> None:
    rec, why = _decide(0.6, (2, 3))
    assert rec == "diff"
    assert "worse than diff on most held-out runs" in why
