"""Write simulated (or any) trials' encoder logs as CSVs.

The trials themselves are written by the notebook's CSV writer,
:func:`odolab.store.csvio.write_trials_csv` (the same columns as ``odolab trials export``), which
``odolab sim run`` calls: the simulator sits below the notebook and never imports it.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from pathlib import Path

from odolab.core.errors import SimError
from odolab.core.text import quote_input, safe_file_name
from odolab.core.trials import Trial
from odolab.core.writing import given_folder

__all__ = ["write_encoder_logs"]


def write_encoder_logs(
    directory: str | Path | Sequence[Trial], trials: Sequence[Trial] | str | Path
) -> list[Path]:
    """Write each trial's encoder log as ``<directory>/<trial_id>.csv`` (raw counters).

    The file name is :func:`odolab.core.text.safe_file_name` of the trial id: whatever the id (``/``,
    ``..``, an absolute path), every file lands inside ``directory``. Two ids that would share a
    file (``A`` and ``a`` on a case-insensitive disk) are refused before anything is written.
    (The old order ``(trials, directory)`` is still accepted, with a DeprecationWarning.)
    """
    from odolab.io import write_encoder_csv

    if isinstance(trials, str | os.PathLike):
        warnings.warn(
            "write_encoder_logs(trials, directory) is the old argument order; call "
            "write_encoder_logs(directory, trials)",
            DeprecationWarning,
            stacklevel=2,
        )
        directory, trials = trials, directory
    if not isinstance(directory, str | os.PathLike) or isinstance(trials, str | os.PathLike):
        raise TypeError("write_encoder_logs(directory, trials) takes a folder and trials")
    folder = given_folder(
        directory,
        expected="a folder for the encoder logs",
        cannot="the folder for the encoder logs",
        error=SimError,
    )
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
    return [write_encoder_csv(path, log) for log, path in todo]
