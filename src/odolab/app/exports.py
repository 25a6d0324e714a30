"""Exports of the notebook's trials: ``odolab trials export`` and the web's /data/export."""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from odolab.core.errors import StoreError, opt
from odolab.core.trials import MotionKind, TrialStatus

if TYPE_CHECKING:
    from odolab.core.params import RobotParams
    from odolab.export.mcap import OdometryStream
    from odolab.store import Notebook

__all__ = [
    "FORMATS",
    "KINDS",
    "STATUSES",
    "ExportRequest",
    "check_filter",
    "export_bytes",
    "export_trials",
    "format_of",
    "mcap_stream",
]

#: The export formats: CSV (a spreadsheet, no encoder logs) and JSON (everything).
FORMATS = ("csv", "json")
#: The values a trial filter may take (the export's and the web's): statuses and kinds.
STATUSES = tuple(s.value for s in TrialStatus)
KINDS = tuple(k.value for k in MotionKind)


def check_filter(name: str, value: str | None, allowed: tuple[str, ...]) -> str | None:
    """A filter's value, None when not given (None or ""), refused when not in ``allowed``."""
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
            check_filter("kind", self.kind, KINDS),
            check_filter("status", self.status, STATUSES),
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


def mcap_stream(
    paths: Sequence[Path],
    robot: RobotParams | None,
    method: str,
    *,
    fmt: str | None = None,
    db: Path | None = None,
    campaign: str | None = None,
    open_notebook: Callable[[Path], AbstractContextManager[Notebook]] | None = None,
) -> OdometryStream:
    """What ``odolab export mcap`` writes, from what it was given: a notebook campaign (``db``
    and ``campaign``, opened with ``open_notebook``), one run of format ``fmt``, a robot run
    folder (with run.json), or GT EST trajectory files.

    Raises:
        OdolabError: sources that are none of these.
    """
    from odolab.core.errors import OdolabError
    from odolab.export.mcap import (
        stream_from_campaign,
        stream_from_run,
        stream_from_run_folder,
        stream_from_trajectories,
    )

    paths = list(paths)
    if campaign is not None or db is not None:
        if campaign is None or db is None or paths:
            raise OdolabError("a notebook campaign needs {{db}} and {{campaign}}, and no SOURCE")
        from odolab.store import Notebook

        with (open_notebook or Notebook)(db) as nb:  # the face's rule for a missing notebook
            return stream_from_campaign(nb, campaign, robot, method)
    if fmt is not None:
        from odolab.io.registry import read_run
        from odolab.io.run import ReadOptions

        if len(paths) != 1:
            raise OdolabError(f"{opt('format')} takes one run, got {len(paths)} paths")
        ro = ReadOptions(ticks_per_rev=robot.ticks_per_rev) if robot else ReadOptions()
        return stream_from_run(read_run(paths[0], fmt, ro), robot, method)
    if len(paths) == 1 and (paths[0] / "run.json").is_file():
        return stream_from_run_folder(paths[0], robot, method)
    if len(paths) == 2:
        from odolab.io import read_trajectory

        return stream_from_trajectories(read_trajectory(paths[1]), read_trajectory(paths[0]))
    raise OdolabError(
        "export mcap takes a robot run folder (with run.json), one run with {{format}}, "
        "GT EST trajectory files, or {{db}} with {{campaign}}"
    )
