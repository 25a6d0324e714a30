"""The page's icon (``/favicon.ico``): a small SVG wheel, so that a browser's request for it is
answered (no 404 on every page load)."""

from __future__ import annotations

from starlette.requests import Request
from starlette.responses import Response

__all__ = ["ICON_SVG", "favicon"]

#: A wheel with its spokes, in the header's colours (32 x 32).
ICON_SVG = (
    b'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 32 32">'
    b'<rect width="32" height="32" rx="6" fill="#12324f"/>'
    b'<circle cx="16" cy="16" r="10" fill="none" stroke="#9fd0ff" stroke-width="3"/>'
    b'<path d="M16 6v20M6 16h20" stroke="#fff" stroke-width="2"/>'
    b'<circle cx="16" cy="16" r="3" fill="#fff"/></svg>'
)


async def favicon(request: Request) -> Response:
    return Response(
        ICON_SVG, media_type="image/svg+xml", headers={"cache-control": "max-age=86400"}
    )
