"""Write simulated (or any) trials: one CSV in the lab notebook's layout; encoder logs as CSVs.

:func:`write_trials_csv` writes the same columns as ``odolab trials export`` (see
docs/notebook.md: units in the column names, compass readings and counted turns, true pose), so
a simulated campaign can be imported into a notebook with ``odolab trials import``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from odolab.errors import SimError
from odolab.store.csvio import COLUMNS
from odolab.store.csvio import write_trials_csv as _write_notebook_csv
from odolab.trials import Trial

__all__ = ["TRIAL_COLUMNS", "write_encoder_logs", "write_trials_csv"]

#: the notebook's CSV columns (``raw_<key>`` columns follow for other raw readings)
TRIAL_COLUMNS = tuple(COLUMNS)


def write_trials_csv(trials: Sequence[Trial], path: str | Path) -> Path:
    """Write one row per trial in the notebook's CSV layout; returns the path."""
    try:
        return _write_notebook_csv(path, ((t, None) for t in trials))
    except OSError as err:
        raise SimError(f"{path}: cannot write the trials CSV ({err})") from err


def write_encoder_logs(trials: Sequence[Trial], directory: str | Path) -> list[Path]:
    """Write each trial's encoder log as ``<directory>/<trial_id>.csv`` (raw counters)."""
    from odolab.io import write_encoder_csv

    folder = Path(directory)
    if folder.exists() and not folder.is_dir():
        raise SimError(f"{folder}: is a file; expected a folder for the encoder logs")
    out = []
    for t in trials:
        if t.encoder_log is not None:
            out.append(write_encoder_csv(t.encoder_log, folder / f"{t.trial_id}.csv"))
    return out
