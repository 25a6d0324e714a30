"""The demo's lab, end to end: moved to :mod:`odolab.app.demo` (the application layer); this
module re-exports its public names so that ``from odolab.lab import run_lab`` keeps working."""

from __future__ import annotations

from odolab.app.demo import *  # noqa: F403  (its __all__: run_lab, LabResult, STEPS, ...)
from odolab.app.demo import __all__ as __all__
