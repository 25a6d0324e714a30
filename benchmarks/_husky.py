"""The DRIVE Husky's nominal parameters (its configuration: wheel radius 0.165 m, track 0.55 m),
as docs/real-logs.md's worked example writes them to husky.toml, for the Husky benchmarks."""

from __future__ import annotations

from odolab.core.params import PRESETS

HUSKY = PRESETS["jaguar-lite"].with_(
    name="husky",
    left_wheel_radius=0.165,
    right_wheel_radius=0.165,
    track_width=0.55,
    encoder_modulus=None,
)


def husky_split() -> tuple[list[object], list[object], list[object]]:
    """The Husky's windows fitted on even command steps and held out on odd ones, as the docs'
    worked example splits them: (training runs, held-out runs, training runs prepared in 2 s
    pieces for the fits)."""
    import os
    from pathlib import Path

    from odolab.calibration.lsq import prepare_run
    from odolab.io.registry import find_runs, read_run
    from odolab.io.run import ReadOptions

    data = Path(os.environ.get("ODOLAB_TEST_DATA", "../shared/data"))
    table = data / "drive-husky" / "husky_windows.csv"
    ro = ReadOptions(params=HUSKY)
    train = [read_run(p, "drive", ro) for p in find_runs([f"{table}#even"], "drive")]
    held = [read_run(p, "drive", ro) for p in find_runs([f"{table}#odd"], "drive")]
    return train, held, [prepare_run(r, 2.0) for r in train]  # type: ignore[misc]


def held_out_error(held: list[object], params: object) -> float:
    """Mean end-point error (m) of ``params`` over the held-out runs."""
    import numpy as np

    from odolab.metrics.runs import RUN_OPTIONS, evaluate_run

    return float(
        np.mean(
            [evaluate_run(r, params, RUN_OPTIONS).evaluation.drift.endpoint_error for r in held]  # type: ignore[arg-type]
        )
    )
