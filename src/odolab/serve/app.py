"""The web application over a lab notebook: server-rendered pages and a JSON API.

Every request opens the notebook file itself (one SQLite connection per request, in a worker
thread): the store's WAL mode and ``BEGIN IMMEDIATE`` writes let the CLI, a robot run and this
server write at the same time. The rules for a measurement and their sentences are the CLI's
(:mod:`odolab.store.measure`); an error is shown on the page, or returned by the API as
``{"error": "<sentence>"}`` with a 4xx status, and nothing is stored.
"""

from __future__ import annotations

import dataclasses
import hashlib
import hmac
import math
import re
import secrets
import tempfile
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar
from urllib.parse import quote, urlencode

import jinja2
from starlette.applications import Starlette
from starlette.concurrency import run_in_threadpool
from starlette.datastructures import UploadFile
from starlette.exceptions import HTTPException
from starlette.middleware import Middleware
from starlette.requests import Request
from starlette.responses import HTMLResponse, JSONResponse, RedirectResponse, Response
from starlette.routing import Route

from odolab.errors import OdolabError, StoreError
from odolab.serve.security import LOOPBACK_HOSTS, Guard, csrf_ok, csrf_token
from odolab.trials import MotionKind, TrialStatus

if TYPE_CHECKING:
    from odolab.analysis import LabAnalysis
    from odolab.store import Notebook
    from odolab.trials import Trial

__all__ = ["ServeSettings", "create_app"]

_T = TypeVar("_T")

#: Largest request body (an upload included) the server reads, in bytes.
MAX_UPLOAD_BYTES = 8 * 1024 * 1024
_STATUSES = tuple(s.value for s in TrialStatus)
_KINDS = tuple(k.value for k in MotionKind)
_MEASUREMENT_KEYS = ("initial", "final", "turns", "x", "y", "sigma", "replace")
_SAFE_NAME = re.compile(r"[^A-Za-z0-9._-]+")


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


# -- helpers --------------------------------------------------------------------------------------


class _AnalysisCache:
    """The analysis of the notebook's trials, recomputed only when a trial changed."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._key: int | None = None
        self._value: LabAnalysis | None = None
        self._error: str | None = None

    def get(self, trials: list[Trial]) -> tuple[int, LabAnalysis | None, str | None]:
        from odolab.analysis import analyze_trials

        key = hash(repr(trials))
        with self._lock:
            if key != self._key:
                try:
                    self._value, self._error = analyze_trials(trials), None
                except OdolabError as err:
                    self._value, self._error = None, str(err)
                self._key = key
            return key, self._value, self._error


def _fnum(value: object, spec: str = ".4g") -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "–"
    if isinstance(value, int | float):
        return format(value, spec)
    return str(value)


def _templates() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("odolab.serve", "templates"),
        autoescape=True,  # every value is HTML-escaped unless marked safe (none is)
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
    )
    env.filters["q"] = lambda s: quote(str(s), safe="")
    env.filters["num"] = _fnum
    env.globals["pi"] = math.pi
    return env


def _trial_json(t: Trial) -> dict[str, Any]:
    from odolab.store.measure import describe_measurement

    c, p, m = t.command, t.predicted, t.measured
    return {
        "trial_id": t.trial_id,
        "campaign": t.campaign,
        "terrain": t.terrain,
        "kind": c.kind.value,
        "command": {
            "kind": c.kind.value,
            "angle": c.angle,
            "distance": c.distance,
            "side": c.side,
            "direction": c.direction,
            "speed": c.speed,
            "text": c.describe(),
        },
        "predicted": {"t": p.t, "x": p.x, "y": p.y, "theta": p.theta, "heading": p.heading},
        "measured": None
        if m is None
        else {
            "instrument": m.instrument,
            "rotation": m.rotation,
            "x": m.x,
            "y": m.y,
            "sigma_rotation": m.sigma_rotation,
            "sigma_xy": m.sigma_xy,
            "raw": dict(m.raw),
            "text": describe_measurement(t),
        },
        "status": t.status.value,
        "exclusion_reason": t.exclusion_reason,
        "notes": t.notes,
        "robot": t.params.name,
    }


def _awaiting_first(trials: list[Trial]) -> list[Trial]:
    order = {TrialStatus.AWAITING: 0, TrialStatus.MEASURED: 1, TrialStatus.EXCLUDED: 2}
    return sorted(trials, key=lambda t: order[t.status])


def _check_filter(name: str, value: str | None, allowed: tuple[str, ...]) -> str | None:
    if value is None or value == "":
        return None
    if value not in allowed:
        raise StoreError(f"{name} is {value!r}; expected one of {', '.join(allowed)}")
    return value


def _safe_upload_name(filename: str | None) -> str:
    """A file name made only of letters, digits and ``._-`` (no folder), for messages only."""
    base = (filename or "").replace("\\", "/").rsplit("/", 1)[-1]
    name = _SAFE_NAME.sub("_", base).strip("._")[:80]
    return name or "upload.csv"


def _status_of(err: StoreError) -> int:
    """404 for an unknown trial, 409 for a measurement that needs ``replace``, else 400."""
    text = str(err)
    if text.startswith("no trial "):
        return 404
    return 409 if " is already measured " in text else 400


class _FormError(Exception):
    """A form post refused before it reached the notebook (no CSRF token...)."""


def create_app(settings: ServeSettings) -> Starlette:
    """The ASGI application serving ``settings.db``."""
    env = _templates()
    cache = _AnalysisCache()
    db = Path(settings.db)

    def notebook() -> Notebook:
        from odolab.store import Notebook

        if not db.is_file():
            raise StoreError(f"{db}: no such notebook")
        return Notebook(db)

    async def in_notebook(fn: Callable[[Notebook], _T]) -> _T:
        def job() -> _T:
            with notebook() as nb:
                return fn(nb)

        return await run_in_threadpool(job)

    def page(
        request: Request, template: str, status_code: int = 200, **context: Any
    ) -> HTMLResponse:
        session = request.state.session
        html = env.get_template(template).render(
            csrf=csrf_token(settings.secret, session),
            path=request.url.path,
            **context,
        )
        return HTMLResponse(html, status_code=status_code)

    async def form_of(request: Request) -> Mapping[str, Any]:
        form = await request.form(max_files=2, max_fields=50)
        if not csrf_ok(settings.secret, request.state.session, form.get("csrf")):
            raise _FormError(
                "form refused: its CSRF token is missing or wrong; reload the page and send it again"
            )
        return form

    def text_field(form: Mapping[str, Any], name: str) -> str | None:
        value = form.get(name)
        if not isinstance(value, str) or not value.strip():
            return None
        return value.strip()

    def error_json(err: Exception, status: int = 400) -> JSONResponse:
        return JSONResponse({"error": str(err)}, status_code=status)

    # -- pages ------------------------------------------------------------------------------------

    async def index(request: Request) -> Response:
        q = request.query_params
        error = None
        filters = {k: (q.get(k) or None) for k in ("status", "kind", "campaign", "terrain")}
        try:
            _check_filter("status", filters["status"], _STATUSES)
            _check_filter("kind", filters["kind"], _KINDS)
        except StoreError as err:
            error = str(err)
            filters["status"] = filters["kind"] = None

        def load(nb: Notebook) -> dict[str, Any]:
            everything = nb.load_trials(with_logs=False)
            counts: dict[str, dict[str, int]] = {}
            for t in everything:
                c = counts.setdefault(t.campaign, dict.fromkeys(_STATUSES, 0))
                c[t.status.value] += 1
            trials = [
                t
                for t in everything
                if all(
                    v is None or v == w
                    for v, w in (
                        (filters["status"], t.status.value),
                        (filters["kind"], t.command.kind.value),
                        (filters["campaign"], t.campaign),
                        (filters["terrain"], t.terrain),
                    )
                )
            ]
            return {
                "campaigns": nb.campaigns(),
                "counts": counts,
                "terrains": sorted({t.terrain for t in everything}),
                "trials": _awaiting_first(trials),
                "total": len(everything),
            }

        data = await in_notebook(load)
        return page(
            request,
            "index.html.j2",
            filters=filters,
            statuses=_STATUSES,
            kinds=_KINDS,
            error=error,
            **data,
        )

    def trial_context(nb: Notebook, trial_id: str) -> dict[str, Any]:
        t = nb.get_trial(trial_id)
        robot, version = nb.trial_params_version(trial_id)
        return {
            "t": t,
            "robot": robot,
            "version": version,
            "history": nb.measurement_history(trial_id),
            "rotation": t.command.kind.value in ("rotation", "pivot"),
            "has_log": t.encoder_log is not None and len(t.encoder_log) > 1,
        }

    async def trial_page(request: Request) -> Response:
        trial_id = request.query_params.get("id", "")
        try:
            ctx = await in_notebook(lambda nb: trial_context(nb, trial_id))
        except StoreError as err:
            return page(request, "error.html.j2", 404, error=str(err))
        saved = request.query_params.get("saved")
        if saved is not None and not hmac.compare_digest(
            saved_signature(trial_id, saved), request.query_params.get("sig", "")
        ):
            saved = None  # a link made elsewhere cannot show "measured: ..." on the page
        return page(request, "trial.html.j2", values={}, error=None, saved=saved, **ctx)

    async def trial_refused(
        request: Request, trial_id: str, err: StoreError, values: dict[str, str | None]
    ) -> Response:
        """The trial page again with the refusal's sentence and the values typed (nothing
        stored); the error page when the trial itself is unknown."""
        try:
            ctx = await in_notebook(lambda nb: trial_context(nb, trial_id))
        except StoreError as err2:
            return page(request, "error.html.j2", 404, error=str(err2))
        return page(request, "trial.html.j2", 400, values=values, error=str(err), saved=None, **ctx)

    def saved_signature(trial_id: str, text: str) -> str:
        """HMAC of the confirmation shown after a post, under the server's secret."""
        msg = f"saved\0{trial_id}\0{text}".encode()
        return hmac.new(settings.secret, msg, hashlib.sha256).hexdigest()

    def trial_saved(trial_id: str, text: str) -> Response:
        """Back to the trial page (post/redirect/get), saying what was stored; the message is
        signed, so that only this server's redirect can show it."""
        sig = saved_signature(trial_id, text)
        query = urlencode({"id": trial_id, "saved": text, "sig": sig})
        return RedirectResponse(f"/trial?{query}", status_code=303)

    async def trial_measure(request: Request) -> Response:
        from odolab.store.measure import describe_measurement, record_measurement

        try:
            form = await form_of(request)
        except _FormError as err:
            return page(request, "error.html.j2", 403, error=str(err))
        trial_id = str(form.get("id", ""))
        names = ("initial", "final", "turns", "x", "y", "sigma")
        values = {k: text_field(form, k) for k in names}
        replace = form.get("replace") == "on"

        def save(nb: Notebook) -> str:
            saved = record_measurement(nb, trial_id, **values, replace=replace)
            return describe_measurement(saved)

        try:
            text = await in_notebook(save)
        except StoreError as err:
            return await trial_refused(request, trial_id, err, values)
        return trial_saved(trial_id, f"measured: {text}")

    async def trial_exclude(request: Request) -> Response:
        try:
            form = await form_of(request)
        except _FormError as err:
            return page(request, "error.html.j2", 403, error=str(err))
        trial_id = str(form.get("id", ""))
        include = request.url.path.endswith("/include")
        reason = str(form.get("reason", ""))

        def act(nb: Notebook) -> str:
            if include:
                nb.include_trial(trial_id)
                return "included again"
            nb.exclude_trial(trial_id, reason)
            return f"excluded: {reason.strip()}"

        try:
            text = await in_notebook(act)
        except StoreError as err:
            return await trial_refused(request, trial_id, err, {})
        return trial_saved(trial_id, text)

    async def trial_plot(request: Request) -> Response:
        from odolab.serve.plots import run_png

        trial_id = request.query_params.get("id", "")
        try:
            png = await in_notebook(lambda nb: run_png(nb.get_trial(trial_id)))
        except OdolabError as err:
            return Response(str(err), status_code=404, media_type="text/plain")
        if png is None:
            return Response("this trial has no encoder log", 404, media_type="text/plain")
        return Response(png, media_type="image/png")

    def analysis_now(nb: Notebook) -> tuple[int, LabAnalysis | None, str | None]:
        return cache.get(nb.load_trials(with_logs=False))

    async def table1_page(request: Request) -> Response:
        from odolab.analysis import table1

        key, analysis, error = await in_notebook(analysis_now)
        rows = table1(analysis) if analysis is not None else []
        return page(
            request,
            "table1.html.j2",
            rows=rows,
            analysis=analysis,
            error=error,
            version=f"{key & 0xFFFFFFFF:x}",
        )

    async def fit_plot(request: Request) -> Response:
        from odolab.serve.plots import fit_png

        try:
            index = int(request.query_params.get("i", ""))
        except ValueError:
            return Response("i must be a row number of Table I", 400, media_type="text/plain")
        _, analysis, _ = await in_notebook(analysis_now)
        if analysis is None or not 0 <= index < len(analysis.motions):
            return Response("no such row of Table I", 404, media_type="text/plain")
        png = await run_in_threadpool(fit_png, analysis.motions[index])
        return Response(png, media_type="image/png")

    async def params_page(request: Request) -> Response:
        def load(nb: Notebook) -> dict[str, Any]:
            return {"robots": {r: nb.params_versions(r) for r in nb.robots()}}

        return page(request, "params.html.j2", **await in_notebook(load))

    async def params_toml(request: Request) -> Response:
        from odolab.params import save_params

        robot = request.query_params.get("robot", "")
        try:
            version = int(request.query_params.get("version", ""))
        except ValueError:
            return Response("version must be a whole number", 400, media_type="text/plain")

        def build(nb: Notebook) -> bytes:
            pv = next((v for v in nb.params_versions(robot) if v.version == version), None)
            if pv is None:
                raise StoreError(f"no parameter version {version} of robot {robot!r} in {db}")
            provenance = {
                "method": pv.method,
                "created": pv.created,
                "notebook_version": pv.version,
                "source_trials": list(pv.source_trials),
                "notes": pv.notes,
            }
            with tempfile.TemporaryDirectory(prefix="odolab-serve-") as tmp:
                path = save_params(Path(tmp) / "params.toml", pv.params, provenance=provenance)
                return path.read_bytes()

        try:
            body = await in_notebook(build)
        except StoreError as err:
            return Response(str(err), 404, media_type="text/plain")
        name = f"{_safe_upload_name(robot)}-v{version}.toml"
        return Response(
            body,
            media_type="application/toml",
            headers={"content-disposition": f'attachment; filename="{name}"'},
        )

    async def calibrate_page(request: Request) -> Response:
        def load(nb: Notebook) -> dict[str, Any]:
            trials = nb.load_trials(with_logs=False)
            return {"robots": nb.robots(), "terrains": sorted({t.terrain for t in trials})}

        return page(
            request, "calibrate.html.j2", result=None, error=None, **await in_notebook(load)
        )

    async def calibrate_run(request: Request) -> Response:
        from odolab.serve.calibrate import calibrate_notebook

        try:
            form = await form_of(request)
        except _FormError as err:
            return page(request, "error.html.j2", 403, error=str(err))
        method = str(form.get("method", ""))
        robot = str(form.get("robot", ""))
        terrain = text_field(form, "terrain")

        def run(nb: Notebook) -> dict[str, Any]:
            trials = nb.load_trials(with_logs=False)
            ctx: dict[str, Any] = {
                "robots": nb.robots(),
                "terrains": sorted({t.terrain for t in trials}),
            }
            try:
                ctx["result"] = calibrate_notebook(nb, method, robot, terrain)
                ctx["error"] = None
            except OdolabError as err:
                ctx["result"], ctx["error"] = None, str(err)
            return ctx

        ctx = await in_notebook(run)
        return page(request, "calibrate.html.j2", 400 if ctx["error"] else 200, **ctx)

    async def report_page(request: Request) -> Response:
        return page(request, "report.html.j2")

    async def report_html(request: Request) -> Response:
        from odolab.serve.calibrate import report_bytes

        try:
            body = await in_notebook(report_bytes)
        except OdolabError as err:
            return page(request, "error.html.j2", 400, error=str(err))
        return Response(
            body,
            media_type="text/html; charset=utf-8",
            headers={"content-disposition": 'attachment; filename="odolab-report.html"'},
        )

    async def data_page(request: Request) -> Response:
        def load(nb: Notebook) -> dict[str, Any]:
            return {"campaign_names": sorted(nb.campaign_names())}

        return page(request, "data.html.j2", message=None, error=None, **await in_notebook(load))

    async def import_upload(request: Request) -> Response:
        try:
            form = await form_of(request)
        except _FormError as err:
            return page(request, "error.html.j2", 403, error=str(err))
        upload = form.get("file")
        create_campaigns = form.get("create_campaigns") == "on"
        names = await in_notebook(lambda nb: sorted(nb.campaign_names()))
        if not isinstance(upload, UploadFile) or not upload.filename:
            return page(
                request,
                "data.html.j2",
                400,
                message=None,
                error="choose a .csv or .json file to import",
                campaign_names=names,
            )
        name = _safe_upload_name(upload.filename)
        content = await upload.read()

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
            n = await in_notebook(do_import)
        except OdolabError as err:
            return page(
                request, "data.html.j2", 400, message=None, error=str(err), campaign_names=names
            )
        return page(
            request,
            "data.html.j2",
            message=f"{n} trials imported from {name}",
            error=None,
            campaign_names=sorted(await in_notebook(lambda nb: nb.campaign_names())),
        )

    async def export(request: Request) -> Response:
        q = request.query_params
        fmt = q.get("format", "csv")
        try:
            if fmt not in ("csv", "json"):
                raise StoreError(f"format is {fmt!r}; expected one of csv, json")
            status = _check_filter("status", q.get("status"), _STATUSES)
            kind = _check_filter("kind", q.get("kind"), _KINDS)
        except StoreError as err:
            return Response(str(err), 400, media_type="text/plain")
        campaign = q.get("campaign") or None
        terrain = q.get("terrain") or None

        def build(nb: Notebook) -> bytes:
            with tempfile.TemporaryDirectory(prefix="odolab-export-") as tmp:
                path = Path(tmp) / f"trials.{fmt}"
                if fmt == "json":
                    nb.export_json(path, campaign, terrain, kind, status)
                else:
                    nb.export_csv(path, campaign, terrain, kind, status)
                return path.read_bytes()

        body = await in_notebook(build)
        return Response(
            body,
            media_type="application/json" if fmt == "json" else "text/csv; charset=utf-8",
            headers={"content-disposition": f'attachment; filename="trials.{fmt}"'},
        )

    # -- JSON API ---------------------------------------------------------------------------------

    async def api_trials(request: Request) -> Response:
        q = request.query_params
        try:
            status = _check_filter("status", q.get("status"), _STATUSES)
            kind = _check_filter("kind", q.get("kind"), _KINDS)
        except StoreError as err:
            return error_json(err)
        campaign = q.get("campaign") or None
        terrain = q.get("terrain") or None
        trials = await in_notebook(
            lambda nb: nb.load_trials(campaign, terrain, kind, status, with_logs=False)
        )
        return JSONResponse({"trials": [_trial_json(t) for t in _awaiting_first(trials)]})

    async def api_trial(request: Request) -> Response:
        trial_id = request.path_params["trial_id"]

        def load(nb: Notebook) -> dict[str, Any]:
            ctx = trial_context(nb, trial_id)
            out = _trial_json(ctx["t"])
            out["params_version"] = ctx["version"]
            out["has_encoder_log"] = ctx["has_log"]
            out["measurement_history"] = [
                {"replaced": when, **dataclasses.asdict(m), "raw": dict(m.raw)}
                for when, m in ctx["history"]
            ]
            return out

        try:
            return JSONResponse(await in_notebook(load))
        except StoreError as err:
            return error_json(err, 404)

    async def json_body(request: Request) -> dict[str, Any]:
        ctype = request.headers.get("content-type", "").split(";")[0].strip().lower()
        if ctype != "application/json":
            raise HTTPException(415, "send the body as JSON (Content-Type: application/json)")
        try:
            body = await request.json()
        except ValueError as err:
            raise StoreError(f"the body is not valid JSON ({err})") from err
        except RecursionError as err:  # [[[[...]]]] nested deeper than the parser recurses
            raise StoreError("the body is not valid JSON (nested too deeply)") from err
        if not isinstance(body, dict):
            raise StoreError("the body must be a JSON object")
        return body

    async def api_measure(request: Request) -> Response:
        from odolab.store.measure import record_measurement

        trial_id = request.path_params["trial_id"]
        try:
            body = await json_body(request)
            unknown = sorted(set(body) - set(_MEASUREMENT_KEYS))
            if unknown:
                raise StoreError(
                    f"unknown key {unknown[0]!r}; expected {', '.join(_MEASUREMENT_KEYS)}"
                )
            replace = body.get("replace", False)
            if not isinstance(replace, bool):
                raise StoreError(f"replace is {replace!r}; expected true or false")
        except StoreError as err:
            return error_json(err)
        readings = {k: body.get(k) for k in _MEASUREMENT_KEYS if k != "replace"}

        def save(nb: Notebook) -> tuple[int, dict[str, Any]]:
            try:
                saved = record_measurement(nb, trial_id, **readings, replace=replace)
            except StoreError as err:
                return _status_of(err), {"error": str(err)}
            return 200, _trial_json(saved)

        status, out = await in_notebook(save)
        return JSONResponse(out, status_code=status)

    async def api_exclude(request: Request) -> Response:
        trial_id = request.path_params["trial_id"]
        try:
            body = await json_body(request)
            reason = body.get("reason", "")
            if not isinstance(reason, str):
                raise StoreError(f"reason is {reason!r}; expected text")
            await in_notebook(lambda nb: nb.exclude_trial(trial_id, reason))
            return JSONResponse(_trial_json(await in_notebook(lambda nb: nb.get_trial(trial_id))))
        except StoreError as err:
            return error_json(err, _status_of(err))

    async def api_include(request: Request) -> Response:
        trial_id = request.path_params["trial_id"]
        try:
            await json_body(request)
            await in_notebook(lambda nb: nb.include_trial(trial_id))
            return JSONResponse(_trial_json(await in_notebook(lambda nb: nb.get_trial(trial_id))))
        except StoreError as err:
            return error_json(err, _status_of(err))

    async def api_table1(request: Request) -> Response:
        from odolab.analysis import table1

        _, analysis, error = await in_notebook(analysis_now)
        if analysis is None:
            return JSONResponse({"rows": [], "error": error})
        return JSONResponse({"rows": table1(analysis), "skipped": list(analysis.skipped)})

    async def http_error(request: Request, exc: Exception) -> Response:
        assert isinstance(exc, HTTPException)
        if request.url.path.startswith("/api/"):
            return JSONResponse({"error": exc.detail}, status_code=exc.status_code)
        return Response(exc.detail, exc.status_code, media_type="text/plain")

    async def store_error(request: Request, exc: Exception) -> Response:
        if request.url.path.startswith("/api/"):
            return error_json(exc)
        return page(request, "error.html.j2", 400, error=str(exc))

    routes = [
        Route("/", index),
        Route("/trial", trial_page),
        Route("/trial/measure", trial_measure, methods=["POST"]),
        Route("/trial/exclude", trial_exclude, methods=["POST"]),
        Route("/trial/include", trial_exclude, methods=["POST"]),
        Route("/trial/plot.png", trial_plot),
        Route("/table1", table1_page),
        Route("/table1/fit.png", fit_plot),
        Route("/params", params_page),
        Route("/params.toml", params_toml),
        Route("/calibrate", calibrate_page),
        Route("/calibrate", calibrate_run, methods=["POST"]),
        Route("/report", report_page),
        Route("/report.html", report_html),
        Route("/data", data_page),
        Route("/data/import", import_upload, methods=["POST"]),
        Route("/data/export", export),
        Route("/api/trials", api_trials),
        Route("/api/table1", api_table1),
        Route("/api/trials/{trial_id:path}/measurement", api_measure, methods=["POST"]),
        Route("/api/trials/{trial_id:path}/exclude", api_exclude, methods=["POST"]),
        Route("/api/trials/{trial_id:path}/include", api_include, methods=["POST"]),
        Route("/api/trials/{trial_id:path}", api_trial),
    ]
    return Starlette(
        routes=routes,
        middleware=[
            Middleware(
                Guard,
                token=settings.token,
                allowed_hosts=settings.allowed_hosts,
                max_body=settings.max_upload_bytes,
            )
        ],
        exception_handlers={HTTPException: http_error, OdolabError: store_error},
    )
