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
from odolab.text import quote_input, safe_file_name
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
    """Write each trial's encoder log as ``<directory>/<trial_id>.csv`` (raw counters).

    The file name is :func:`odolab.text.safe_file_name` of the trial id: whatever the id (``/``,
    ``..``, an absolute path), every file lands inside ``directory``. Two ids that would share a
    file (``A`` and ``a`` on a case-insensitive disk) are refused before anything is written.
    """
    from odolab.io import write_encoder_csv

    folder = Path(directory)
    if folder.exists() and not folder.is_dir():
        raise SimError(f"{folder}: is a file; expected a folder for the encoder logs")
    names: dict[str, str] = {}
    todo = []
    for t in trials:
        if t.encoder_log is None:
            continue
        name = safe_file_name(t.trial_id, what="trial id", suffix=".csv")
        other = names.setdefault(name.casefold(), t.trial_id)
        if other != t.trial_id:
            raise SimError(
                f"{folder}: trial ids {quote_input(other)} and {quote_input(t.trial_id)} would "
                "share one encoder log file; expected ids that differ in more than letter case"
            )
        todo.append((t.encoder_log, folder / name))
    return [write_encoder_csv(log, path) for log, path in todo]
