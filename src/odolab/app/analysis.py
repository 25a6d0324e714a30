"""Table I and the analysis of the selected trials: what ``odolab analyze``, the web's Table I
page and ``/api/table1`` show."""

from __future__ import annotations

import threading
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

from odolab.app.selection import EVERY_CAMPAIGN, Selection, SelectionRequest, select

if TYPE_CHECKING:
    from odolab.analysis import LabAnalysis
    from odolab.core.trials import Trial
    from odolab.store import Notebook

__all__ = ["AnalysisCache", "AnalysisResult", "analyze", "analyze_selection"]


@dataclass(frozen=True)
class AnalysisResult:
    """The selection, its analysis and Table I's rows."""

    selection: Selection
    analysis: LabAnalysis
    table1: list[dict[str, object]] = field(default_factory=list)

    def to_dict(self) -> dict[str, object]:
        """What ``analyze --json`` writes and ``/api/table1`` answers (the same keys): the
        analysis (:meth:`~odolab.analysis.LabAnalysis.to_dict`), Table I's rows and the
        selection."""
        return {
            **self.analysis.to_dict(),
            "table1": self.table1,
            "selection": self.selection.to_dict(),
        }


class AnalysisCache:
    """The analysis of a list of trials, recomputed only when one of them changed (a server
    keeps one; each call of :func:`analyze` without it computes anew)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._key: int | None = None
        self._value: LabAnalysis | None = None
        self._error: Exception | None = None

    def key(self, trials: list[Trial]) -> int:
        """The trials' every field but their encoder logs, which no analysis reads (Table I
        loads trials without them, the report and UMBmark with)."""
        return hash(repr([replace(t, encoder_log=None) for t in trials]))

    def get(self, trials: list[Trial]) -> LabAnalysis:
        from odolab.analysis import analyze_trials
        from odolab.core.errors import OdolabError

        key = self.key(trials)
        with self._lock:
            if key != self._key:
                try:
                    self._value, self._error = analyze_trials(trials), None
                except OdolabError as err:
                    self._value, self._error = None, err
                self._key = key
            if self._error is not None:
                raise self._error
            assert self._value is not None
            return self._value


def analyze_selection(selection: Selection, cache: AnalysisCache | None = None) -> AnalysisResult:
    """Analyze the trials of ``selection`` (see :func:`analyze`)."""
    from odolab.analysis import analyze_trials, table1

    if cache is not None:
        analysis = cache.get(selection.trials)
    else:
        analysis = analyze_trials(selection.trials)
    return AnalysisResult(selection, analysis, table1(analysis))


def analyze(
    nb: Notebook,
    request: SelectionRequest = EVERY_CAMPAIGN,
    *,
    cache: AnalysisCache | None = None,
) -> AnalysisResult:
    """Table I and the analysis of the trials ``request`` selects (validation campaigns left
    out unless named). Raises :class:`~odolab.core.errors.InsufficientDataError` when no fit is
    possible and ``SelectionError`` for a campaign the notebook does not have."""
    return analyze_selection(select(nb, request), cache)
