"""The web application over a lab notebook: server-rendered pages and a JSON API.

Every request opens the notebook file itself (one SQLite connection per request, in a worker
thread): the store's WAL mode and ``BEGIN IMMEDIATE`` writes let the CLI, a robot run and this
server write at the same time. The routes (:mod:`odolab.serve.routes`) only parse, call the
application layer (:mod:`odolab.app`: the same functions as the CLI) and render; the rules for
a measurement and their sentences are the CLI's (:mod:`odolab.store.measure`). An error is shown
on the page, or returned by the API as ``{"error": "<sentence>"}`` with a 4xx status, and
nothing is stored.
"""

from __future__ import annotations

import secrets
from dataclasses import dataclass, field
from pathlib import Path

from starlette.applications import Starlette
from starlette.exceptions import HTTPException
from starlette.middleware import Middleware
from starlette.requests import Request
from starlette.responses import Response

from odolab.core.errors import OdolabError
from odolab.serve.security import LOOPBACK_HOSTS, Guard, StrictJSONResponse

__all__ = ["MAX_UPLOAD_BYTES", "ServeSettings", "create_app"]

#: Largest request body (an upload included) the server reads, in bytes.
MAX_UPLOAD_BYTES = 8 * 1024 * 1024


@dataclass(frozen=True)
class ServeSettings:
    """What the application serves and how it guards it.

    ``token``: required on every request when given (any bind that is not loopback).
    ``allowed_hosts``: Host header names served (None: any, for a token-guarded bind).
    """

    db: Path
    token: str | None = None
    allowed_hosts: frozenset[str] | None = LOOPBACK_HOSTS
    max_upload_bytes: int = MAX_UPLOAD_BYTES
    secret: bytes = field(default_factory=lambda: secrets.token_bytes(32), repr=False)


async def _http_error(request: Request, exc: Exception) -> Response:
    assert isinstance(exc, HTTPException)
    detail = exc.detail
    if exc.status_code == 405:  # Starlette's "Method Not Allowed", in words, with its Allow
        allowed = (exc.headers or {}).get("Allow", "")
        detail = f"{request.url.path} does not take {request.method}; it takes {allowed}"
    if request.url.path.startswith("/api/"):
        return StrictJSONResponse(
            {"error": detail}, status_code=exc.status_code, headers=exc.headers
        )
    return Response(detail, exc.status_code, media_type="text/plain", headers=exc.headers)


async def _odolab_error(request: Request, exc: Exception) -> Response:
    from odolab.serve.routes._web import error_json, web

    if request.url.path.startswith("/api/"):
        return error_json(exc)
    return web(request).error_page(request, exc)


def create_app(settings: ServeSettings) -> Starlette:
    """The ASGI application serving ``settings.db``."""
    from odolab.serve.routes import ROUTES
    from odolab.serve.routes._web import Web

    app = Starlette(
        routes=ROUTES,
        middleware=[
            Middleware(
                Guard,
                token=settings.token,
                allowed_hosts=settings.allowed_hosts,
                max_body=settings.max_upload_bytes,
            )
        ],
        exception_handlers={HTTPException: _http_error, OdolabError: _odolab_error},
    )
    app.state.web = Web(settings)
    return app
