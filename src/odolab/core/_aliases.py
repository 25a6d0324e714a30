"""The old module names of odolab's core, kept working for one release.

odolab 0.1 had its core modules at the top of the package (``odolab.kinematics``,
``odolab.odometry``, ``odolab.models``, ...) and the demo's pipeline in ``odolab.lab``. They now
live in :mod:`odolab.core` and :mod:`odolab.app.demo`. An import of an old name gives the very
same module object as the new one (one class identity, one set of globals), and warns with a
:class:`DeprecationWarning` naming the new place. The aliases go in odolab 0.3.
"""

from __future__ import annotations

import importlib
import importlib.machinery
import sys
import warnings
from types import ModuleType
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from importlib.abc import Loader as _Loader
    from importlib.abc import MetaPathFinder as _Finder
else:  # (importlib.abc imports importlib.resources and tempfile: 20 ms of every odolab start;
    # the import system asks only for the methods)
    _Loader = _Finder = object

#: old top-level name -> its new dotted name (filled in by :func:`install`)
MOVED: dict[str, str] = {}


class _Alias(_Loader):
    def __init__(self, new: str) -> None:
        self.new = new

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        return importlib.import_module(self.new)

    def exec_module(self, module: ModuleType) -> None:
        """The module is already run under its new name: nothing to do."""


class _OldNames(_Finder):
    def find_spec(
        self, fullname: str, path: object = None, target: object = None
    ) -> importlib.machinery.ModuleSpec | None:
        head, _, rest = fullname.partition(".")
        if head != "odolab" or not rest:
            return None
        top, _, below = rest.partition(".")
        if top not in MOVED:
            return None
        new = MOVED[top] + (f".{below}" if below else "")
        warnings.warn(
            f"{fullname} moved to {new}; the old name goes in odolab 0.3",
            DeprecationWarning,
            stacklevel=3,
        )
        return importlib.machinery.ModuleSpec(fullname, _Alias(new))


def install(moved: dict[str, str]) -> None:
    """Let ``import odolab.<old>`` find its new module (``moved``: old name -> new dotted name)."""
    MOVED.update(moved)
    if not any(isinstance(f, _OldNames) for f in sys.meta_path):
        # first: below an old package's name (odolab.models.slip) the path finder would find the
        # file again through the package's __path__ and run a second copy of the module
        sys.meta_path.insert(0, _OldNames())
