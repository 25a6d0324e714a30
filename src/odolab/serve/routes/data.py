"""Import (an upload) and export (:func:`odolab.app.exports.export_bytes`) of trials."""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

from starlette.datastructures import UploadFile
from starlette.requests import Request
from starlette.responses import Response

from odolab.core.errors import OdolabError, StoreError
from odolab.serve.routes._web import plain, posted, safe_upload_name, web

if TYPE_CHECKING:
    from collections.abc import Mapping

    from odolab.serve.routes._web import Web
    from odolab.store import Notebook

__all__ = ["export", "page", "upload"]


def _names(nb: Notebook) -> list[str]:
    return sorted(nb.campaign_names())


async def page(request: Request) -> Response:
    w = web(request)
    names = await w.run(_names)
    message = w.signed_text(request)  # "N trials imported from NAME", after an import
    return w.page(request, "data.html.j2", message=message, error=None, campaign_names=names)


@posted
async def upload(request: Request, w: Web, form: Mapping[str, object]) -> Response:
    file = form.get("file")
    create_campaigns = form.get("create_campaigns") == "on"
    names = await w.run(_names)
    if not isinstance(file, UploadFile) or not file.filename:
        error = "choose a .csv or .json file to import"
        return w.page(request, "data.html.j2", 400, message=None, error=error, campaign_names=names)
    name = safe_upload_name(file.filename)
    content = await file.read()

    def do_import(nb: Notebook) -> int:
        with tempfile.TemporaryDirectory(prefix="odolab-upload-") as tmp:
            path = Path(tmp) / name
            path.write_bytes(content)
            try:
                if name.lower().endswith(".json"):
                    return nb.import_json(path)
                return nb.import_csv(path, create_campaigns=create_campaigns)
            except OdolabError as err:
                raise type(err)(str(err).replace(str(path), name)) from err

    try:
        n = await w.run(do_import)
    except OdolabError as err:
        return w.page(
            request, "data.html.j2", 400, message=None, error=str(err), campaign_names=names
        )
    # post/redirect/get: a reload of the page that says so does not import again
    return w.signed_redirect("/data", f"{n} trials imported from {name}")


async def export(request: Request) -> Response:
    from odolab.app.exports import ExportRequest, export_bytes

    q = request.query_params
    req = ExportRequest(
        q.get("format", "csv"), q.get("campaign"), q.get("terrain"), q.get("kind"), q.get("status")
    )
    try:
        req = req.checked()
    except StoreError as err:
        return plain(str(err), 400)
    body = await web(request).run(lambda nb: export_bytes(nb, req))
    fmt = req.format
    return Response(
        body,
        media_type="application/json" if fmt == "json" else "text/csv; charset=utf-8",
        headers={"content-disposition": f'attachment; filename="trials.{fmt}"'},
    )
