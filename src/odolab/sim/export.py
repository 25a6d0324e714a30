"""Write simulated (or any) trials' encoder logs as CSVs.

The trials themselves are written by the notebook's CSV writer,
:func:`odolab.store.csvio.write_trials_csv` (the same columns as ``odolab trials export``), which
``odolab sim run`` calls: the simulator sits below the notebook and never imports it.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from odolab.errors import SimError
from odolab.trials import Trial

__all__ = ["write_encoder_logs"]


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
