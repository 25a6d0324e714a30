"""The calibration form: :func:`odolab.app.calibration.calibrate`, rendered."""

from __future__ import annotations

from typing import TYPE_CHECKING, TypedDict
from urllib.parse import urlencode

from starlette.requests import Request
from starlette.responses import RedirectResponse, Response

from odolab.analysis.selection import Wording as SelectionWording
from odolab.core.errors import OdolabError
from odolab.serve.routes._web import posted, text_field, web, web_text
from odolab.serve.wording import CALIBRATE_WORDS

if TYPE_CHECKING:
    from collections.abc import Mapping

    from odolab.app.calibration import CalibrationOutcome, CalibrationRequest
    from odolab.serve.routes._web import Web
    from odolab.store import Notebook, ParamsVersion

__all__ = ["page", "post"]


class _Choices(TypedDict):
    robots: list[str]
    terrains: list[str]
    selection_words: SelectionWording


class _Form(_Choices):
    stored: ParamsVersion | None  #: the version a calibration recorded (?robot=R&version=V)


class _Done(_Choices):
    result: CalibrationOutcome | None
    error: str | None


def _choices(nb: Notebook) -> _Choices:
    trials = nb.load_trials(with_logs=False)
    return {
        "robots": nb.robots(),
        "terrains": sorted({t.terrain for t in trials}),
        "selection_words": CALIBRATE_WORDS,
    }


async def page(request: Request) -> Response:
    """The form; after a calibration (``?robot=R&version=V``, where its post redirects) the
    version it recorded: in full while this server remembers the calibration, else as the
    notebook stores it."""
    w, q = web(request), request.query_params
    robot, version = q.get("robot"), q.get("version", "")

    def load(nb: Notebook) -> _Form:
        stored = None
        if robot and version.isascii() and version.isdigit():  # "²" is a digit to isdigit
            found = [v for v in nb.params_versions(robot) if v.version == int(version)]
            stored = found[0] if found else None
        return {**_choices(nb), "stored": stored}

    ctx = await w.run(load)
    result = w.recent.get(f"calibrate\0{robot}\0{version}") if ctx["stored"] else None
    return w.page(request, "calibrate.html.j2", result=result, error=None, **ctx)


def _run(nb: Notebook, req: CalibrationRequest) -> _Done:
    from odolab.app.calibration import calibrate

    ctx = _choices(nb)
    try:
        return {**ctx, "result": calibrate(nb, req), "error": None}
    except OdolabError as err:
        text = web_text(err).replace("(robot, or the form's robot)", "(choose it under robot)")
        return {**ctx, "result": None, "error": text}


@posted
async def post(request: Request, w: Web, form: Mapping[str, object]) -> Response:
    from odolab.app.calibration import CalibrationRequest

    req = CalibrationRequest(
        str(form.get("method", "")),
        robot=text_field(form, "robot"),
        terrain=text_field(form, "terrain"),
    )
    ctx = await w.run(lambda nb: _run(nb, req))
    result = ctx["result"]
    if result is None or result.version is None:
        return w.page(request, "calibrate.html.j2", 400, stored=None, **ctx)
    # post/redirect/get: a reload of the result page does not calibrate again
    w.remember(f"calibrate\0{result.robot}\0{result.version}", result)
    query = urlencode({"robot": result.robot, "version": result.version})
    return RedirectResponse(f"/calibrate?{query}", status_code=303)
