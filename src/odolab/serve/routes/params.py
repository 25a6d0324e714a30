"""The robots' parameter versions, and one version as a TOML download."""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

from starlette.requests import Request
from starlette.responses import Response

from odolab.core.errors import StoreError
from odolab.serve.routes._web import plain, safe_upload_name, web

if TYPE_CHECKING:
    from odolab.store import Notebook

__all__ = ["page", "toml"]


async def page(request: Request) -> Response:
    def load(nb: Notebook) -> dict[str, object]:
        return {"robots": {r: nb.params_versions(r) for r in nb.robots()}}

    w = web(request)
    return w.page(request, "params.html.j2", **await w.run(load))


def _toml(nb: Notebook, robot: str, version: int) -> bytes:
    from odolab.core.params import save_params

    pv = next((v for v in nb.params_versions(robot) if v.version == version), None)
    if pv is None:
        raise StoreError(f"no parameter version {version} of robot {robot!r} in {nb.path}")
    provenance = {
        "method": pv.method,
        "created": pv.created,
        "notebook_version": pv.version,
        "source_trials": list(pv.source_trials),
        "notes": pv.notes,
    }
    with tempfile.TemporaryDirectory(prefix="odolab-serve-") as tmp:
        return save_params(Path(tmp) / "params.toml", pv.params, provenance=provenance).read_bytes()


async def toml(request: Request) -> Response:
    robot = request.query_params.get("robot", "")
    try:
        version = int(request.query_params.get("version", ""))
    except ValueError:
        return plain("version must be a whole number", 400)
    try:
        body = await web(request).run(lambda nb: _toml(nb, robot, version))
    except StoreError as err:
        return plain(str(err), 404)
    name = f"{safe_upload_name(robot)}-v{version}.toml"
    return Response(
        body,
        media_type="application/toml",
        headers={"content-disposition": f'attachment; filename="{name}"'},
    )
