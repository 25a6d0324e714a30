"""Compatibility: the compass and meterstick measurement model moved to :mod:`odolab.core.measurement`.

It is core (the CLI, the CSV import and the notebook all build measurements from readings); import
it from there. This module only re-exports it.
"""

from odolab.core.measurement import *  # noqa: F403
from odolab.core.measurement import __all__ as __all__
