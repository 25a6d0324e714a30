"""The lab report: figures (each takes an optional ``ax``), Table I for the terminal, and
``write_report`` (self-contained HTML + PNGs + results.json)."""

from __future__ import annotations

from odolab.report.html import build_results, summary_sentences, write_report
from odolab.report.table import table1_rich

__all__ = ["build_results", "summary_sentences", "table1_rich", "write_report"]
