"""The calibration form: :func:`odolab.app.calibration.calibrate`, rendered."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from starlette.requests import Request
from starlette.responses import Response

from odolab.errors import OdolabError
from odolab.serve.routes._web import FormError, text_field, web

if TYPE_CHECKING:
    from odolab.app.calibration import CalibrationRequest
    from odolab.store import Notebook

__all__ = ["page", "post"]


def _choices(nb: Notebook) -> dict[str, Any]:
    trials = nb.load_trials(with_logs=False)
    return {"robots": nb.robots(), "terrains": sorted({t.terrain for t in trials})}


async def page(request: Request) -> Response:
    w = web(request)
    ctx = await w.run(_choices)
    return w.page(request, "calibrate.html.j2", result=None, error=None, **ctx)


def _run(nb: Notebook, req: CalibrationRequest) -> dict[str, Any]:
    from odolab.app.calibration import calibrate

    ctx = _choices(nb)
    try:
        ctx["result"], ctx["error"] = calibrate(nb, req), None
    except OdolabError as err:
        ctx["result"], ctx["error"] = None, str(err)
    return ctx


async def post(request: Request) -> Response:
    from odolab.app.calibration import CalibrationRequest

    w = web(request)
    try:
        form = await w.form(request)
    except FormError as err:
        return w.error_page(request, err, 403)
    req = CalibrationRequest(
        str(form.get("method", "")),
        robot=text_field(form, "robot"),
        terrain=text_field(form, "terrain"),
    )
    ctx = await w.run(lambda nb: _run(nb, req))
    return w.page(request, "calibrate.html.j2", 400 if ctx["error"] else 200, **ctx)
