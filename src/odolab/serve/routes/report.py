"""The report page and its download: :func:`odolab.app.report.report_html` (what ``odolab
report`` writes, for the same selection)."""

from __future__ import annotations

from starlette.requests import Request
from starlette.responses import Response

from odolab.errors import OdolabError
from odolab.serve.routes._web import selection_of, web

__all__ = ["download", "page"]


async def page(request: Request) -> Response:
    return web(request).page(request, "report.html.j2")


async def download(request: Request) -> Response:
    from odolab.app.report import ReportRequest, report_html

    w = web(request)
    req = ReportRequest(selection_of(request.query_params))
    try:
        body = await w.run(lambda nb: report_html(nb, req))
    except OdolabError as err:
        return w.error_page(request, err)
    return Response(
        body,
        media_type="text/html; charset=utf-8",
        headers={"content-disposition": 'attachment; filename="odolab-report.html"'},
    )
