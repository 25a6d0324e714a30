"""Exports of the notebook's trials: ``odolab trials export`` and the web's /data/export."""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from odolab.errors import StoreError
from odolab.trials import MotionKind, TrialStatus

if TYPE_CHECKING:
    from odolab.store import Notebook

__all__ = ["FORMATS", "ExportRequest", "export_bytes", "export_trials", "format_of"]

#: The export formats: CSV (a spreadsheet, no encoder logs) and JSON (everything).
FORMATS = ("csv", "json")
_STATUSES = tuple(s.value for s in TrialStatus)
_KINDS = tuple(k.value for k in MotionKind)


def _check(name: str, value: str | None, allowed: tuple[str, ...]) -> str | None:
    if value is None or value == "":
        return None
    if value not in allowed:
        raise StoreError(f"{name} is {value!r}; expected one of {', '.join(allowed)}")
    return value


@dataclass(frozen=True)
class ExportRequest:
    """Which trials (every filter given must match) in which format (csv or json)."""

    format: str = "csv"
    campaign: str | None = None
    terrain: str | None = None
    kind: str | None = None
    status: str | None = None

    def checked(self) -> ExportRequest:
        """The request with its format and filters checked (one sentence for a bad one)."""
        if self.format not in FORMATS:
            raise StoreError(f"format is {self.format!r}; expected one of {', '.join(FORMATS)}")
        return ExportRequest(
            self.format,
            self.campaign or None,
            self.terrain or None,
            _check("kind", self.kind, _KINDS),
            _check("status", self.status, _STATUSES),
        )


def format_of(path: str | Path) -> str:
    """The export format a file name asks for: json for ``.json``, else csv."""
    return "json" if Path(path).suffix.lower() == ".json" else "csv"


def export_trials(nb: Notebook, path: str | Path, request: ExportRequest) -> int:
    """Write the trials ``request`` selects to ``path``; return how many."""
    r = request.checked()
    if r.format == "json":
        return nb.export_json(path, r.campaign, r.terrain, r.kind, r.status)
    return nb.export_csv(path, r.campaign, r.terrain, r.kind, r.status)


def export_bytes(nb: Notebook, request: ExportRequest) -> bytes:
    """The export's file content (the web's download)."""
    r = request.checked()
    with tempfile.TemporaryDirectory(prefix="odolab-export-") as tmp:
        path = Path(tmp) / f"trials.{r.format}"
        export_trials(nb, path, r)
        return path.read_bytes()
