"""RPE steps in degrees and radians (evo's ``--delta_unit d/r``), and runs that turn in place:
evaluated, with drift per angle turned, and the undefined numbers said, never a bare NaN."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from metrics_drives import random_drive

from odolab.cli.wording import said
from odolab.core.trajectory import Trajectory
from odolab.io.registry import LogFormat, read_run
from odolab.metrics import (
    RUN_OPTIONS,
    DeltaUnit,
    EvaluationOptions,
    evaluate,
    evaluate_run,
    pair_indices,
)

evo_metrics = pytest.importorskip("evo.core.metrics")
from evo.core import filters, lie_algebra  # noqa: E402
from evo.core.trajectory import PoseTrajectory3D  # noqa: E402
from evo.core.units import Unit  # noqa: E402

#: Ivanjko runs 4 to 9 of these experiments turn in place (about 0.05 m of path, half a turn).
SPIN = "ivanjko/231220200057/231220200057_run-04.csv"


def _evo(traj: Trajectory) -> PoseTrajectory3D:
    xyz = np.column_stack((traj.x, traj.y, np.zeros(len(traj))))
    half = 0.5 * traj.heading
    z = np.zeros(len(traj))
    return PoseTrajectory3D(xyz, np.column_stack((np.cos(half), z, z, np.sin(half))), traj.t.copy())


@pytest.mark.parametrize(
    ("delta", "unit", "evo_unit", "all_pairs"),
    [
        (20.0, DeltaUnit.DEGREES, Unit.degrees, False),
        (0.6, DeltaUnit.RADIANS, Unit.radians, False),
        (45.0, DeltaUnit.DEGREES, Unit.degrees, True),
        (0.4, DeltaUnit.RADIANS, Unit.radians, True),
    ],
)
def test_rpe_by_angle_matches_evo(
    delta: float, unit: DeltaUnit, evo_unit: Unit, all_pairs: bool
) -> None:
    ref = random_drive(400, seed=3)
    est = random_drive(400, seed=3)
    est = Trajectory.from_xyh(est.t, est.x * 1.01, est.y, est.heading * 1.02)
    ours = evaluate(
        ref,
        est,
        EvaluationOptions(delta=delta, delta_unit=unit, all_pairs=all_pairs),
    )
    R = evo_metrics.PoseRelation
    for relation, stats in ((R.translation_part, ours.rpe), (R.rotation_angle_rad, ours.rpe_rot)):
        m = evo_metrics.RPE(relation, delta=delta, delta_unit=evo_unit, all_pairs=all_pairs)
        m.process_data((_evo(ref), _evo(est)))
        theirs = m.get_all_statistics()
        assert stats.n == len(m.error) > 10
        for key in ("rmse", "mean", "median", "max"):
            assert getattr(stats, key) == pytest.approx(theirs[key], abs=1e-9, rel=0), key
    poses = [
        lie_algebra.se3(lie_algebra.so3_exp(np.array([0.0, 0.0, h])), np.array([x, y, 0.0]))
        for x, y, h in zip(est.x, est.y, est.heading, strict=True)
    ]
    i, j = pair_indices(est, delta, unit, all_pairs=all_pairs)
    deg = unit is DeltaUnit.DEGREES
    assert list(zip(i.tolist(), j.tolist(), strict=True)) == filters.filter_pairs_by_angle(
        poses, delta, 0.1 * delta, deg, all_pairs
    )


def test_turn_drift_by_hand() -> None:
    """Turning in place in 200 steps of pi/99 (4 pieces of 50 steps, just over 90 deg each); the
    estimate turns 1 % more: the heading error per angle turned is 1 % in every piece, and drift
    per metre is undefined, with a reason."""
    n = 201
    h = np.arange(n) * (math.pi / 99)
    t = np.arange(n) * 0.05
    zero = np.zeros(n)
    ref = Trajectory.from_xyh(t, zero, zero, h)
    est = Trajectory.from_xyh(t, zero, zero, h * 1.01)
    ev = evaluate(ref, est, RUN_OPTIONS)
    d = ev.drift
    assert d.turn == pytest.approx(200 * math.pi / 99)
    assert d.turn_segments == 4
    assert d.rotation_pct_of_turn == pytest.approx(1.0, rel=1e-9)
    assert math.isnan(d.translation_pct) and d.segments == 0
    doc = ev.to_dict()
    assert doc["drift"]["translation_pct"] is None and doc["rpe"]["rmse"] is None
    assert [said(n) for n in doc["notes"]] == [  # (the settings as the CLI writes them)
        "RPE is undefined: delta = 1 m gives no pose pairs on 201 poses (the reference travels "
        "0 m); a smaller --delta gives some (or, for a run that turns in place, --delta-unit deg)",
        "drift per metre is undefined: the reference travels 0 m, less than one 1 m segment "
        "(it turns in place: 364 deg)",
    ]
    assert "NaN" not in json.dumps(doc)
    by_angle = evaluate(ref, est, EvaluationOptions(delta=90.0, delta_unit=DeltaUnit.DEGREES))
    assert by_angle.rpe_rot.n == 4
    assert by_angle.rpe_rot.rmse == pytest.approx(0.01 * 50 * math.pi / 99, rel=1e-9)


def test_real_spin_in_place_run_is_evaluated(optiodom_dir: Path) -> None:
    """A real OptiOdom run that turns in place: was "delta = 1 m gives no pose pairs"."""
    run = read_run(optiodom_dir / SPIN, LogFormat.OPTIODOM)
    ev = evaluate_run(run).evaluation
    # measured 0.0502 over seed shifts 0-3; bound 0.1; the same at every seed
    assert ev.drift.path_length < 0.1
    assert ev.drift.turn > math.radians(170)
    # measured 1.14 over seed shifts 0-3; bound 20; the same at every seed
    assert 0.0 < ev.drift.rotation_pct_of_turn < 20.0
    assert ev.notes[0].startswith("RPE is undefined: delta = 1 m gives no pose pairs on 81 poses")
    assert ev.notes[1].startswith("drift per metre is undefined: the reference travels")
    opts = EvaluationOptions(
        **{**RUN_OPTIONS.__dict__, "delta": 45.0, "delta_unit": DeltaUnit.DEGREES}
    )
    by_angle = evaluate_run(run, options=opts).evaluation
    assert by_angle.rpe.n >= 3 and math.isfinite(by_angle.rpe_rot.rmse)
    assert not by_angle.rpe_note
