"""The lab notebook: a SQLite store of robots, parameter versions, campaigns and trials.

>>> from odolab.store import Notebook
>>> with Notebook("odolab.db") as nb:                       # doctest: +SKIP
...     nb.add_trials(trials)                                # a robot run
...     frame = nb.trials_frame(campaign="rot-lab")          # for the analysis

See docs/notebook.md for the CLI (``odolab trials ...``, ``odolab notebook ...``) and the CSV.
"""

from odolab.core.measurement import (
    COMPASS_SIGMA_RAD,
    METERSTICK_SIGMA_M,
    rotation_from_compass,
    rotation_measurement_from_compass,
    translation_measurement,
)
from odolab.store.codec import decode_log, encode_log
from odolab.store.csvio import read_trials_csv, write_trials_csv
from odolab.store.notebook import Campaign, Notebook, NotebookInfo, ParamsVersion, Progress
from odolab.store.schema import SCHEMA_VERSION

__all__ = [
    "COMPASS_SIGMA_RAD",
    "METERSTICK_SIGMA_M",
    "SCHEMA_VERSION",
    "Campaign",
    "Notebook",
    "NotebookInfo",
    "ParamsVersion",
    "Progress",
    "decode_log",
    "encode_log",
    "read_trials_csv",
    "rotation_from_compass",
    "rotation_measurement_from_compass",
    "translation_measurement",
    "write_trials_csv",
]
