"""The report page and its download: :func:`odolab.app.report.report_html` (what ``odolab
report`` writes, for the same selection).

Drawing the report takes tens of seconds (every figure anew: 19-46 s for the demo notebook's
38 figures on the project's machine), so it is drawn once per state of the notebook and kept:
opening the report page starts it in the background, the page says how far it is (it reloads
itself every few seconds while the report is drawn: a download started from it would be cut by
the reload, so its button appears only when the report is ready, and is then immediate);
``/report.html`` asked for directly waits for the drawing under way (it never draws twice).
Any change to a trial, a campaign or a parameter version makes a new report.
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from starlette.concurrency import run_in_threadpool
from starlette.requests import Request
from starlette.responses import Response

from odolab.core.errors import OdolabError
from odolab.serve.routes._web import Web, selection_of, web, web_text

if TYPE_CHECKING:
    from odolab.app.selection import SelectionRequest
    from odolab.store import Notebook

__all__ = ["ReportJob", "download", "notebook_state", "page"]

#: Seconds between the page's reloads while the report is drawn.
REFRESH_S = 3


def notebook_state(nb: Notebook) -> str:
    """What the report depends on, as text: every trial (without its log), campaign and
    parameter version. Equal text, equal report."""
    import hashlib

    parts = [repr(nb.load_trials(with_logs=False)), repr(nb.campaigns())]
    parts += [repr(nb.params_versions(r)) for r in nb.robots()]
    return hashlib.sha256("\0".join(parts).encode()).hexdigest()


@dataclass
class ReportJob:
    """One drawing of the report, for one selection and one state of the notebook."""

    state: str
    started: float = field(default_factory=time.monotonic)
    finished: float | None = None
    body: bytes | None = None
    error: str | None = None
    done: threading.Event = field(default_factory=threading.Event)

    @property
    def seconds(self) -> float:
        return (self.finished or time.monotonic()) - self.started


_LOCK = threading.Lock()


def _job(w: Web, sel: SelectionRequest) -> ReportJob:
    """The report job of the notebook as it is now: the one kept or under way when nothing
    changed since it started, else a new one started in a thread of its own."""
    from odolab.app.report import ReportRequest, report_html

    with w.notebook() as nb:
        state = notebook_state(nb)
    key = f"report\0{sel!r}"
    with _LOCK:
        job = w.recent.get(key)
        if isinstance(job, ReportJob) and job.state == state and job.error is None:
            return job
        job = ReportJob(state)
        w.remember(key, job)

    def draw() -> None:
        try:
            with w.notebook() as nb:
                job.body = report_html(nb, ReportRequest(sel))
        except OdolabError as err:
            job.error = web_text(err)
        except Exception as err:  # a bug in the report: a sentence here, the traceback logged
            logging.getLogger(__name__).exception("the report could not be drawn")
            job.error = (
                f"the report could not be drawn ({type(err).__name__} in odolab; the server's "
                "log has the details); odolab report --db gives the same report"
            )
        finally:
            job.finished = time.monotonic()
            job.done.set()

    threading.Thread(target=draw, name="odolab-report", daemon=True).start()
    return job


async def _requested(request: Request) -> tuple[Web, ReportJob | Response]:
    """The report job the query asks for, or the error page of its refusal."""
    w = web(request)
    try:
        sel = selection_of(request.query_params)
        return w, await run_in_threadpool(_job, w, sel)
    except OdolabError as err:
        return w, w.error_page(request, err)


async def page(request: Request) -> Response:
    w, job = await _requested(request)
    if isinstance(job, Response):
        return job
    last = _last_seconds(w)
    return w.page(
        request, "report.html.j2", job=job, seconds=job.seconds, last=last,
        refresh=REFRESH_S, query=request.url.query,
    )  # fmt: skip


def _last_seconds(w: Web) -> float | None:
    """How long the latest finished drawing took (for the page's estimate)."""
    with _LOCK:  # a worker thread may be adding a job
        jobs = list(w.recent.values())
    times = [j.seconds for j in jobs if isinstance(j, ReportJob) and j.body is not None]
    return times[-1] if times else None


async def download(request: Request) -> Response:
    w, job = await _requested(request)
    if isinstance(job, Response):
        return job
    await run_in_threadpool(job.done.wait)
    if job.body is None:
        return w.error_page(request, OdolabError(job.error or "the report could not be drawn"))
    return Response(
        job.body,
        media_type="text/html; charset=utf-8",
        headers={"content-disposition": 'attachment; filename="odolab-report.html"'},
    )
