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

from odolab.errors import SimError
from odolab.trials import Trial

__all__ = ["write_encoder_logs"]


def write_encoder_logs(
    directory: str | Path | Sequence[Trial], trials: Sequence[Trial] | str | Path
) -> list[Path]:
    """Write each trial's encoder log as ``<directory>/<trial_id>.csv`` (raw counters).

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
    folder = Path(directory)
    if folder.exists() and not folder.is_dir():
        raise SimError(f"{folder}: is a file; expected a folder for the encoder logs")
    out = []
    for t in trials:
        if t.encoder_log is not None:
            out.append(write_encoder_csv(folder / f"{t.trial_id}.csv", t.encoder_log))
    return out
