"""The lab report: figures (each takes an optional ``ax``), Table I for the terminal, and
``write_report`` (self-contained HTML + PNGs + results.json).

The names are loaded when first used (PEP 562): ``odolab analyze`` prints Table I through
:func:`table1_rich` without importing the HTML writer, matplotlib's figures and what the
report's model section needs (about a second of imports)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from odolab.report.html import build_results, summary_sentences, write_report
    from odolab.report.table import table1_rich

__all__ = ["build_results", "summary_sentences", "table1_rich", "write_report"]

_WHERE = {
    "build_results": "odolab.report.html",
    "summary_sentences": "odolab.report.html",
    "write_report": "odolab.report.html",
    "table1_rich": "odolab.report.table",
}


def __getattr__(name: str) -> object:
    import importlib

    if name not in _WHERE:
        raise AttributeError(f"module 'odolab.report' has no attribute {name!r}")
    return getattr(importlib.import_module(_WHERE[name]), name)
