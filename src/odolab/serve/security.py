"""The server's guard: host check, access token, body size limit, session cookie, headers.

One pure ASGI middleware, outermost, so nothing reaches a page or the API without passing it:

- **Host**: bound to loopback, only requests addressed to ``127.0.0.1``, ``localhost`` or
  ``[::1]`` are served (a page on another site cannot reach the notebook by DNS rebinding).
- **Token**: with a token (any bind that is not loopback), every request must carry it: the
  ``?token=`` query once (answered by a redirect that sets an HttpOnly, SameSite=Strict cookie
  and drops the token from the address), the cookie, or an ``Authorization: Bearer`` /
  ``X-Odolab-Token`` header. Anything else gets 401.
- **Body size**: a request body larger than ``max_body`` bytes is refused with 413, whether it
  says so in ``Content-Length`` or not.
- **Another site**: a request that changes something (not GET, HEAD or OPTIONS) whose
  ``Origin`` is not this server, or that a browser marks ``Sec-Fetch-Site: cross-site``, is
  refused with 403 (:func:`cross_site`), whatever token it carries.
- **Session**: a random ``odolab_session`` cookie (HttpOnly, SameSite=Strict) keys the CSRF token
  that every form carries (:func:`csrf_token`, :func:`csrf_ok`).
- **Headers**: a Content-Security-Policy without scripts, no framing, no sniffing, no referrer
  to another site.
"""

from __future__ import annotations

import hashlib
import hmac
import re
import secrets
from http.cookies import SimpleCookie
from urllib.parse import parse_qsl, quote, urlencode, urlsplit

from starlette.datastructures import Headers
from starlette.exceptions import HTTPException
from starlette.responses import JSONResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from odolab.core.text import shorten
from odolab.core.writing import strict_json

__all__ = [
    "LOOPBACK_HOSTS",
    "SESSION_COOKIE",
    "TOKEN_COOKIE",
    "Guard",
    "StrictJSONResponse",
    "cross_site",
    "csrf_ok",
    "csrf_token",
    "make_token",
]


class StrictJSONResponse(JSONResponse):
    """Starlette's JSON answer made by :func:`odolab.core.writing.strict_json`: a non-finite number
    is ``null`` (Starlette's own refuses it, a 500), so every answer parses in a browser; the
    settings the library's text names, in the web's words (:mod:`odolab.serve.wording`)."""

    def render(self, content: object) -> bytes:
        from odolab.serve.wording import WEB

        return WEB.say(strict_json(content, indent=None)).encode("utf-8")


TOKEN_COOKIE = "odolab_token"
SESSION_COOKIE = "odolab_session"
#: Host names a loopback-bound server answers to.
LOOPBACK_HOSTS = frozenset({"127.0.0.1", "localhost", "::1"})

_SECURITY_HEADERS = [
    (
        b"content-security-policy",
        b"default-src 'none'; img-src 'self' data:; style-src 'unsafe-inline'; "
        b"form-action 'self'; base-uri 'none'; frame-ancestors 'none'",
    ),
    (b"x-content-type-options", b"nosniff"),
    (b"x-frame-options", b"DENY"),
    # same-origin: no referrer to another site, and the browser gives our own forms their real
    # Origin (with no-referrer it sent "null", which the cross-site check cannot tell apart)
    (b"referrer-policy", b"same-origin"),
    (b"cache-control", b"no-store"),
]


def make_token() -> str:
    """A new random access token (32 bytes, URL-safe)."""
    return secrets.token_urlsafe(32)


def csrf_token(secret: bytes, session: str) -> str:
    """The CSRF token of a session: HMAC-SHA256 of the session id under the server's secret."""
    return hmac.new(secret, session.encode("utf-8"), hashlib.sha256).hexdigest()


def csrf_ok(secret: bytes, session: str | None, given: object) -> bool:
    """True when ``given`` is the CSRF token of ``session``."""
    if not session or not isinstance(given, str) or not given:
        return False
    return hmac.compare_digest(csrf_token(secret, session).encode(), given.encode("utf-8"))


_HOST = re.compile(r"(?:\[(?P<v6>[0-9a-f:.]+)\]|(?P<name>[^\[\]:/@\s]+))(?::\d{1,5})?")


def _host_name(host_header: str) -> str:
    """The host of a ``Host`` header (``[::1]:8000`` -> ``::1``); "" unless the whole header
    is a host and an optional port (``[::1].evil.example`` and ``[::1]evil.example:80`` were
    read as ``::1``)."""
    m = _HOST.fullmatch(host_header.strip().lower())
    if m is None:
        return ""
    return m["v6"] or m["name"]


#: Methods that change nothing: the cross-site check is for the others.
_SAFE_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})


def cross_site(headers: Headers, host_header: str) -> str | None:
    """Why a request that changes something comes from another site (None when it does not
    say so): an ``Origin`` that is not this server's (``null`` included), or a browser's
    ``Sec-Fetch-Site: cross-site``/``same-site``. A client without them (curl, odolab's CLI)
    is not refused here; the CSRF token and the SameSite cookies are the first line."""
    site = headers.get("sec-fetch-site", "").strip().lower()
    if site in ("cross-site", "same-site"):
        return f"Sec-Fetch-Site is {site}"
    origin = headers.get("origin")
    if origin is None:
        return None
    parsed = urlsplit(origin.strip())
    if parsed.scheme not in ("http", "https") or not parsed.netloc:
        return f"its Origin is {shorten(origin, 80)!r}"
    if parsed.netloc.lower() != host_header.strip().lower():
        return f"its Origin {shorten(origin, 80)!r} is not this server ({shorten(host_header, 80)})"
    return None


def _same_site(path: str) -> str:
    """``path`` as a Location on this server: percent-encoded (no line break, nothing beyond
    ASCII) and with one leading slash, so that ``//other.example/`` cannot name another site."""
    return "/" + quote(path.lstrip("/\\"), safe="/:@!$&'()*+,;=-._~")


def _cookie(name: str, value: str) -> bytes:
    return f"{name}={value}; Path=/; HttpOnly; SameSite=Strict".encode("latin-1")


#: A refused request: the status, the sentence, extra response headers.
_Refusal = tuple[int, str, list[tuple[bytes, bytes]]]


def _site_refusal(scope: Scope, headers: Headers) -> _Refusal | None:
    if scope.get("method", "GET").upper() not in _SAFE_METHODS:
        why = cross_site(headers, headers.get("host", ""))
        if why is not None:  # a second line behind the CSRF token and SameSite cookies
            return (
                403,
                f"a write from another site is refused ({why}); expected a request from "
                "this server's own pages or a client of its own (no Origin header)",
                [],
            )
    return None


def _cookies(headers: Headers) -> dict[str, str]:
    """The request's cookies (none when the header is malformed)."""
    if "cookie" not in headers:
        return {}
    jar: SimpleCookie = SimpleCookie()
    try:
        jar.load(headers["cookie"])
    except Exception:  # a malformed cookie header is treated as no cookie
        jar = SimpleCookie()
    return {k: v.value for k, v in jar.items()}


class Guard:
    """ASGI middleware: see the module docstring."""

    def __init__(
        self,
        app: ASGIApp,
        *,
        token: str | None,
        allowed_hosts: frozenset[str] | None,
        max_body: int,
    ) -> None:
        self.app = app
        self.token = token
        self.allowed_hosts = allowed_hosts
        self.max_body = max_body

    async def _reply(
        self, send: Send, status: int, text: str, *, api: bool, extra: list[tuple[bytes, bytes]]
    ) -> None:
        if api:
            body = strict_json({"error": text}, indent=None).encode()
            ctype = b"application/json"
        else:
            body = text.encode("utf-8")
            ctype = b"text/plain; charset=utf-8"
        headers = [(b"content-type", ctype), (b"content-length", str(len(body)).encode())]
        await send(
            {
                "type": "http.response.start",
                "status": status,
                "headers": headers + _SECURITY_HEADERS + extra,
            }
        )
        await send({"type": "http.response.body", "body": body})

    def _token_ok(self, given: str | None) -> bool:
        assert self.token is not None
        return bool(given) and hmac.compare_digest(
            given.encode("utf-8"),  # type: ignore[union-attr]
            self.token.encode("utf-8"),
        )

    def _host_refusal(self, headers: Headers) -> _Refusal | None:
        if self.allowed_hosts is not None:
            host = _host_name(headers.get("host", ""))
            if host not in self.allowed_hosts:
                return (
                    400,
                    f"this odolab server answers only to {', '.join(sorted(self.allowed_hosts))}",
                    [],
                )
        return None

    def _token_refusal(
        self, scope: Scope, headers: Headers, path: str, cookies: dict[str, str]
    ) -> _Refusal | None:
        """A wrong or missing token refused, a right one in the query answered with a redirect
        that sets it as a cookie; None when the request may pass."""
        if self.token is None:
            return None
        query = parse_qsl(scope.get("query_string", b"").decode("latin-1"), True)
        in_query = [v for k, v in query if k == "token"]
        if in_query:
            if not self._token_ok(in_query[-1]):
                return 401, "wrong token", []
            rest = urlencode([(k, v) for k, v in query if k != "token"])
            location = _same_site(path) + (f"?{rest}" if rest else "")
            return (
                303,
                "token accepted",
                [
                    (b"location", location.encode("utf-8")),
                    (b"set-cookie", _cookie(TOKEN_COOKIE, self.token)),
                ],
            )
        auth = headers.get("authorization", "")
        given = (
            auth[7:].strip()
            if auth.lower().startswith("bearer ")
            else headers.get("x-odolab-token") or cookies.get(TOKEN_COOKIE)
        )
        if not self._token_ok(given):
            return (
                401,
                "this odolab server needs its token: open the address that `odolab serve` "
                "printed (it ends in ?token=...)",
                [(b"www-authenticate", b"Bearer")],
            )
        return None

    def _size_refusal(self, headers: Headers) -> _Refusal | None:
        length = headers.get("content-length")
        if length is not None:
            try:
                too_big = int(length) > self.max_body
            except ValueError:
                too_big = True
            if too_big:
                return 413, f"the request is larger than {self.max_body} bytes", []
        return None

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = Headers(scope=scope)
        path: str = scope.get("path", "")
        refusal = self._host_refusal(headers) or _site_refusal(scope, headers)
        cookies: dict[str, str] = {}
        if refusal is None:
            cookies = _cookies(headers)
            refusal = self._token_refusal(scope, headers, path, cookies)
            refusal = refusal or self._size_refusal(headers)
        if refusal is not None:
            status, text, extra = refusal
            await self._reply(send, status, text, api=path.startswith("/api/"), extra=extra)
            return
        session = cookies.get(SESSION_COOKIE, "")
        new_session = None
        if len(session) < 32 or not session.replace("-", "").replace("_", "").isalnum():
            session = new_session = secrets.token_urlsafe(32)
        state: dict[str, object] = scope.setdefault("state", {})
        state["session"] = session
        received = 0
        limit = self.max_body

        async def limited_receive() -> Message:
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > limit:
                    raise HTTPException(413, f"the request is larger than {limit} bytes")
            return message

        async def guarded_send(message: Message) -> None:
            if message["type"] == "http.response.start":
                extra = list(_SECURITY_HEADERS)
                if new_session is not None:
                    extra.append((b"set-cookie", _cookie(SESSION_COOKIE, new_session)))
                message = {**message, "headers": [*message.get("headers", []), *extra]}
            await send(message)

        await self.app(scope, limited_receive, guarded_send)
