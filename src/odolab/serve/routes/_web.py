"""What every route shares: the settings, the templates, one notebook connection per request
(in a worker thread), the CSRF check of a form, a JSON body, and the analysis cache.

A route takes it from ``request.app.state.web`` (:func:`web`).
"""

from __future__ import annotations

import functools
import hashlib
import hmac
import math
import re
from collections.abc import Awaitable, Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, TypedDict, TypeVar
from urllib.parse import quote, urlencode

import jinja2
from starlette.concurrency import run_in_threadpool
from starlette.datastructures import QueryParams
from starlette.exceptions import HTTPException
from starlette.requests import Request
from starlette.responses import HTMLResponse, RedirectResponse, Response

from odolab.app.analysis import AnalysisCache
from odolab.core.errors import StoreError
from odolab.core.text import display_value
from odolab.serve.security import StrictJSONResponse, csrf_ok, csrf_token

if TYPE_CHECKING:
    from odolab.app.selection import SelectionRequest
    from odolab.serve.app import ServeSettings
    from odolab.store import Notebook

__all__ = ["FormError", "Web", "web"]

_T = TypeVar("_T")
_SAFE_NAME = re.compile(r"[^A-Za-z0-9._-]+")


#: The longest header line of one part of a form that python-multipart reads (bytes; its
#: ``DEFAULT_MAX_HEADER_SIZE``): a longer file name makes the whole form unreadable.
_MAX_PART_HEADER = 4096 + 128


class FormError(Exception):
    """A form post refused before it reached the notebook (no CSRF token...); ``status``: the
    HTTP status its page is answered with."""

    def __init__(self, message: str, status: int = 403) -> None:
        super().__init__(message)
        self.status = status


def fnum(value: object, spec: str = ".4g") -> str:
    """A number for a page (``–`` for none or NaN)."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "–"
    if isinstance(value, int | float):
        return format(value, spec)
    return str(value)


def exact(value: object) -> str:
    """A number as Python writes it back exactly (``data-value`` attributes: the parity suite
    reads them; the page shows :func:`fnum`'s digits)."""
    if isinstance(value, float | int) and not isinstance(value, bool):
        return repr(float(value))
    return ""


def ci_parts(value: object, ci: object) -> tuple[str, str]:
    """A value and its 95 % interval as the CLI and the report write them (the interval rule,
    :func:`odolab.core.numfmt.with_ci`), apart for a page's two columns: ``("0.933", "[0.888,
    0.978]")``; ``–`` for what is missing."""
    from odolab.core import numfmt

    if not isinstance(value, int | float) or isinstance(value, bool):
        return "–", "–"
    lo, hi = ci if isinstance(ci, list | tuple) and len(ci) == 2 else (None, None)
    text = numfmt.with_ci(float(value), lo, hi)
    head, sep, tail = text.partition(" [")
    return head, f"[{tail}" if sep else "–"


class SigmaGroup(TypedDict):
    """One repeated group of a Table I row (``odolab.analysis.table1``'s ``sigmas``)."""

    at: float
    commanded: float
    n: int
    sigma: float | None
    sigma_ci95: list[float | None]


def sigma_words(group: SigmaGroup, unit: str) -> str:
    """One repeated group's sigma on a page: ``0.0033 m @ -1 (n 3)``: its digits by the interval
    rule and the commanded distance or angle with its sign, as the CLI and the report write
    them (a reverse run's group is ``@ -1``)."""
    from odolab.core import numfmt

    value, _ = ci_parts(group.get("sigma"), group.get("sigma_ci95"))
    at = numfmt.plain(float(group["commanded"]), strip=True)
    return f"{value} {unit} @ {at} (n {group['n']})"


def templates() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("odolab.serve", "templates"),
        autoescape=True,  # every value is HTML-escaped unless marked safe (none is)
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        finalize=display_value,  # control and bidi characters shown, as the CLI shows them
    )
    env.filters["q"] = lambda s: quote(str(s), safe="")
    env.filters["num"] = fnum
    env.filters["exact"] = exact
    env.filters["ci_parts"] = ci_parts
    env.filters["sigma_words"] = sigma_words
    env.globals["pi"] = math.pi
    from odolab.serve.routes import _measure

    env.filters["readings"] = _measure.reading_words
    env.globals["max_chars"] = _measure.MAX_CHARS
    env.globals["signed"] = _measure.HTML_PATTERN
    env.globals["unsigned"] = _measure.HTML_PATTERN_UNSIGNED
    return env


def safe_upload_name(filename: str | None) -> str:
    """A file name made only of letters, digits and ``._-`` (no folder), for messages only."""
    base = (filename or "").replace("\\", "/").rsplit("/", 1)[-1]
    name = _SAFE_NAME.sub("_", base).strip("._")[:80]
    return name or "upload.csv"


def web_text(err: BaseException) -> str:
    """An error's sentence in the web's words: its settings named as the pages' fields and the
    API's keys (:data:`odolab.serve.wording.FIELDS`: ``campaign``, ``robot``), not the CLI's
    flags."""
    from odolab.analysis.selection import WEB_WORDS, SelectionError
    from odolab.serve.wording import WEB

    return err.worded(WEB_WORDS) if isinstance(err, SelectionError) else WEB.error(err)


def web_status(err: BaseException) -> int:
    """400, 404 or 409 for a store error (:func:`status_of`); 400 for a campaign the
    notebook does not have (a bad request), as for any other bad input."""
    from odolab.analysis.selection import UnknownCampaignError

    if isinstance(err, UnknownCampaignError):
        return 400
    return status_of(err) if isinstance(err, StoreError) else 400


def status_of(err: StoreError) -> int:
    """404 for an unknown trial, 409 for a measurement that needs ``replace``, else 400."""
    text = str(err)
    if text.startswith("no trial "):
        return 404
    return 409 if " is already measured " in text else 400


def selection_of(q: QueryParams | Mapping[str, object]) -> SelectionRequest:
    """``?campaign=A&campaign=B&exclude_campaign=C&robot=R`` (the CLI's ``--campaign``,
    ``--exclude-campaign``, ``--robot``) as a selection request."""
    from odolab.app.selection import SelectionRequest

    def many(key: str) -> tuple[str, ...]:
        if isinstance(q, QueryParams):
            values: list[object] = list(q.getlist(key))
        else:
            raw = q.get(key) or []
            values = raw if isinstance(raw, list) else [raw]
        names: list[str] = []
        for v in values:
            if not isinstance(v, str):
                raise StoreError(f"{key} is {v!r}; expected names (text)")
            names.append(v)
        return tuple(v for v in names if v)

    robot = many("robot")
    if len(robot) > 1:
        raise StoreError(f"robot is given {len(robot)} times; expected one robot's name")
    return SelectionRequest(many("campaign"), many("exclude_campaign"), robot[0] if robot else None)


@dataclass
class Web:
    """The application's shared state."""

    settings: ServeSettings
    env: jinja2.Environment = field(default_factory=templates)
    cache: AnalysisCache = field(default_factory=AnalysisCache)
    #: results of recent form posts, for the page their redirect shows (post/redirect/get)
    recent: dict[str, object] = field(default_factory=dict)

    @property
    def db(self) -> Path:
        return Path(self.settings.db)

    def notebook(self) -> Notebook:
        from odolab.store import Notebook

        if not self.db.is_file():
            raise StoreError(f"{self.db}: no such notebook")
        return Notebook(self.db, check=False)  # checked when the server started

    async def run(self, fn: Callable[[Notebook], _T]) -> _T:
        """``fn(notebook)`` in a worker thread, on a connection of its own."""

        def job() -> _T:
            with self.notebook() as nb:
                return fn(nb)

        return await run_in_threadpool(job)

    def page(
        self, request: Request, template: str, status_code: int = 200, /, **context: object
    ) -> HTMLResponse:
        html = self.env.get_template(template).render(
            csrf=csrf_token(self.settings.secret, request.state.session),
            path=request.url.path,
            **context,
        )
        from odolab.serve.wording import WEB  # the library's settings in the web's words

        return HTMLResponse(WEB.say(html), status_code=status_code)

    def error_page(self, request: Request, err: Exception, status_code: int = 400) -> Response:
        return self.page(request, "error.html.j2", status_code, error=web_text(err))

    async def form(self, request: Request) -> Mapping[str, object]:
        try:
            form = await request.form(max_files=2, max_fields=50)
        except HTTPException as err:  # python-multipart's bare "Invalid multipart data."
            if err.status_code != 400:
                raise
            detail = str(err.detail).rstrip(".")
            if "invalid multipart" not in detail.lower():  # starlette's own sentence
                raise FormError(f"the form could not be read: {detail}", 400) from err
            raise FormError(
                "the form could not be read (invalid multipart data): a header line of one of "
                f"its parts, such as the file's name, is longer than {_MAX_PART_HEADER:,} "
                "bytes, or the form is damaged; expected a file name of at most a few hundred "
                "characters",
                400,
            ) from err
        if not csrf_ok(self.settings.secret, request.state.session, form.get("csrf")):
            raise FormError(
                "form refused: its CSRF token is missing or wrong; reload the page and send it again"
            )
        return form

    async def form_or_page(self, request: Request) -> Mapping[str, object] | Response:
        """The posted form (:meth:`form`), or the error page that refuses it."""
        try:
            return await self.form(request)
        except FormError as err:
            return self.error_page(request, err, err.status)

    def saved_signature(self, trial_id: str, text: str) -> str:
        """HMAC of the confirmation shown after a post, under the server's secret."""
        msg = f"saved\0{trial_id}\0{text}".encode()
        return hmac.new(self.settings.secret, msg, hashlib.sha256).hexdigest()

    def remember(self, key: str, value: object) -> None:
        """Keep ``value`` for the page a redirect shows (the 16 latest)."""
        self.recent.pop(key, None)
        self.recent[key] = value
        while len(self.recent) > 16:
            self.recent.pop(next(iter(self.recent)))

    def signed_redirect(self, path: str, text: str) -> Response:
        """303 to ``path?done=TEXT&sig=...`` (post/redirect/get): the page says ``text`` only
        when this server signed it."""
        sig = self.saved_signature(f"page\0{path}", text)
        return RedirectResponse(f"{path}?{urlencode({'done': text, 'sig': sig})}", status_code=303)

    def signed_text(self, request: Request) -> str | None:
        """The ``done`` text of a :meth:`signed_redirect` to this page (None when unsigned)."""
        text = request.query_params.get("done")
        sig = self.saved_signature(f"page\0{request.url.path}", text or "")
        if text is None or not hmac.compare_digest(sig, request.query_params.get("sig", "")):
            return None
        return text

    def trial_saved(self, trial_id: str, text: str) -> Response:
        """Back to the trial page (post/redirect/get), saying what was stored; the message is
        signed, so that only this server's redirect can show it."""
        sig = self.saved_signature(trial_id, text)
        query = urlencode({"id": trial_id, "saved": text, "sig": sig})
        return RedirectResponse(f"/trial?{query}", status_code=303)


def web(request: Request) -> Web:
    """The application's shared state, from a request."""
    state: Web = request.app.state.web
    return state


#: A route that takes a posted form: the request, the application's state and the checked form.
FormRoute = Callable[[Request, Web, Mapping[str, object]], Awaitable[Response]]


def posted(route: FormRoute) -> Callable[[Request], Awaitable[Response]]:
    """The route (a POST) given its checked form (:meth:`Web.form`); a form that is refused
    gets the error page instead (:meth:`Web.form_or_page`)."""

    @functools.wraps(route)
    async def with_form(request: Request) -> Response:
        w = web(request)
        form = await w.form_or_page(request)
        if isinstance(form, Response):
            return form
        return await route(request, w, form)

    return with_form


def text_field(form: Mapping[str, object], name: str) -> str | None:
    value = form.get(name)
    if not isinstance(value, str) or not value.strip():
        return None
    return value.strip()


def error_json(err: Exception, status: int = 400) -> StrictJSONResponse:
    return StrictJSONResponse({"error": web_text(err)}, status_code=status)


def plain(text: str, status: int) -> Response:
    return Response(text, status, media_type="text/plain")


async def json_body(request: Request) -> dict[str, object]:
    ctype = request.headers.get("content-type", "").split(";")[0].strip().lower()
    if ctype != "application/json":
        raise HTTPException(415, "send the body as JSON (Content-Type: application/json)")
    import json

    try:
        body = await request.json()
    except json.JSONDecodeError as err:
        where = f"line {err.lineno}, column {err.colno}"
        raise StoreError(f"the body is not valid JSON ({err.msg.lower()} at {where})") from err
    except ValueError as err:  # an integer of more than 4300 digits, text that is not UTF-8
        raise StoreError(
            "the body is not valid JSON for odolab (a number with thousands of digits, or "
            "text that is not UTF-8)"
        ) from err
    except RecursionError as err:  # [[[[...]]]] nested deeper than the parser recurses
        raise StoreError("the body is not valid JSON (nested too deeply)") from err
    if not isinstance(body, dict):
        raise StoreError("the body must be a JSON object")
    return body
