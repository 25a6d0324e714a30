"""Table I (the page and its fit figures): :func:`odolab.app.analysis.analyze`, rendered."""

from __future__ import annotations

from typing import TYPE_CHECKING

from starlette.concurrency import run_in_threadpool
from starlette.requests import Request
from starlette.responses import Response

from odolab.analysis.selection import WEB_WORDS
from odolab.core.errors import OdolabError
from odolab.serve.routes._web import Web, plain, selection_of, web, web_text

if TYPE_CHECKING:
    from odolab.app.analysis import AnalysisResult
    from odolab.app.selection import SelectionRequest
    from odolab.store import Notebook

__all__ = ["analysis_now", "fit_plot", "page"]


async def analysis_now(
    w: Web, request: SelectionRequest
) -> tuple[AnalysisResult | None, str | None, int, int]:
    """The analysis of the selection (cached until a trial changes), or the sentence why not
    (in the web's words), the cache key (a version for the figures' URLs) and the HTTP status:
    200, or 400 for a campaign the notebook does not have."""
    from odolab.app.analysis import analyze_selection
    from odolab.app.selection import select

    def job(nb: Notebook) -> tuple[AnalysisResult | None, str | None, int, int]:
        try:
            sel = select(nb, request)
            return analyze_selection(sel, w.cache), None, w.cache.key(sel.trials), 200
        except OdolabError as err:
            from odolab.analysis.selection import UnknownCampaignError

            return None, web_text(err), 0, 400 if isinstance(err, UnknownCampaignError) else 200

    return await w.run(job)


async def page(request: Request) -> Response:
    from urllib.parse import urlencode

    w = web(request)
    sel = selection_of(request.query_params)
    result, error, key, status = await analysis_now(w, sel)
    # the figures are of the same selection as the table
    picked = [("campaign", c) for c in sel.campaigns] + [
        ("exclude_campaign", c) for c in sel.exclude
    ]
    return w.page(
        request,
        "table1.html.j2",
        status,
        rows=result.table1 if result else [],
        analysis=result.analysis if result else None,
        selection=result.selection.describe(WEB_WORDS) if result else None,
        error=error,
        version=f"{key & 0xFFFFFFFF:x}",
        selected=("&" + urlencode(picked)) if picked else "",
    )


async def fit_plot(request: Request) -> Response:
    from odolab.serve.plots import fit_png

    try:
        index = int(request.query_params.get("i", ""))
    except ValueError:
        return plain("i must be a row number of Table I", 400)
    result, _, _, _ = await analysis_now(web(request), selection_of(request.query_params))
    if result is None or not 0 <= index < len(result.analysis.motions):
        return plain("no such row of Table I", 404)
    size = request.query_params.get("size")
    png = await run_in_threadpool(fit_png, result.analysis.motions[index], size)
    return Response(png, media_type="image/png")
