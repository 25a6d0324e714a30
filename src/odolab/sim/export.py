"""Write simulated (or any) trials as one CSV row per trial; encoder logs as one CSV each.

Columns of :func:`write_trials_csv` (empty cell = not applicable)::

    trial_id, campaign, terrain, status, motion, command_angle, command_distance, command_side,
    command_direction, command_speed,
    predicted_x, predicted_y, predicted_heading,
    instrument, measured_rotation, measured_x, measured_y, sigma_rotation, sigma_xy,
    compass_initial_deg, compass_final_deg, turns,
    true_x, true_y, true_heading, duration, n_samples, exclusion_reason, notes
"""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path

from odolab.errors import SimError
from odolab.trials import Trial

__all__ = ["TRIAL_COLUMNS", "write_encoder_logs", "write_trials_csv"]

TRIAL_COLUMNS = (
    "trial_id",
    "campaign",
    "terrain",
    "status",
    "motion",
    "command_angle",
    "command_distance",
    "command_side",
    "command_direction",
    "command_speed",
    "predicted_x",
    "predicted_y",
    "predicted_heading",
    "instrument",
    "measured_rotation",
    "measured_x",
    "measured_y",
    "sigma_rotation",
    "sigma_xy",
    "compass_initial_deg",
    "compass_final_deg",
    "turns",
    "true_x",
    "true_y",
    "true_heading",
    "duration",
    "n_samples",
    "exclusion_reason",
    "notes",
)


def _cell(v: object) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)
    return str(v)


def _row(t: Trial) -> list[str]:
    c, m, log = t.command, t.measured, t.encoder_log
    raw = m.raw if m is not None else {}
    turns = raw.get("turns")
    vals: list[object] = [
        t.trial_id,
        t.campaign,
        t.terrain,
        t.status.value,
        c.kind.value,
        c.angle,
        c.distance,
        c.side,
        c.direction,
        c.speed,
        t.predicted.x,
        t.predicted.y,
        t.predicted.heading,
        m.instrument if m else None,
        m.rotation if m else None,
        m.x if m else None,
        m.y if m else None,
        m.sigma_rotation if m else None,
        m.sigma_xy if m else None,
        raw.get("compass_initial_deg"),
        raw.get("compass_final_deg"),
        int(turns) if turns is not None else None,
        t.true.x if t.true else None,
        t.true.y if t.true else None,
        t.true.heading if t.true else None,
        float(log.t[-1] - log.t[0]) if log is not None and len(log) else None,
        len(log) if log is not None else None,
        t.exclusion_reason,
        t.notes,
    ]
    return [_cell(v) for v in vals]


def write_trials_csv(trials: Sequence[Trial], path: str | Path) -> Path:
    """Write one row per trial (columns :data:`TRIAL_COLUMNS`); returns the path."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            w.writerow(TRIAL_COLUMNS)
            for t in trials:
                w.writerow(_row(t))
    except OSError as err:
        raise SimError(f"{path}: cannot write the trials CSV ({err})") from err
    return path


def write_encoder_logs(trials: Sequence[Trial], directory: str | Path) -> list[Path]:
    """Write each trial's encoder log as ``<directory>/<trial_id>.csv`` (raw counters)."""
    from odolab.io import write_encoder_csv

    folder = Path(directory)
    out = []
    for t in trials:
        if t.encoder_log is not None:
            out.append(write_encoder_csv(t.encoder_log, folder / f"{t.trial_id}.csv"))
    return out
