"""The JSON API under ``/api/``: the same application functions as the pages and the CLI.

An error is ``{"error": "<sentence>"}`` with a 4xx status, and nothing is stored.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

from starlette.requests import Request
from starlette.responses import Response

from odolab.app.exports import KINDS, STATUSES, check_filter
from odolab.core.errors import OdolabError, StoreError
from odolab.serve.routes._measure import in_words, json_readings, readings_of
from odolab.serve.routes._web import (
    error_json,
    json_body,
    selection_of,
    status_of,
    web,
    web_text,
)
from odolab.serve.routes.table1 import analysis_now
from odolab.serve.routes.trials import awaiting_first, trial_context
from odolab.serve.security import StrictJSONResponse

if TYPE_CHECKING:
    from odolab.core.trials import Trial
    from odolab.store import Notebook

__all__ = ["calibrate", "report", "table1", "trial", "trials"]

_MEASUREMENT_KEYS = ("initial", "final", "turns", "x", "y", "sigma", "replace")
_POST_ONLY = ("measurement", "exclude", "include")
_CALIBRATE_KEYS = ("method", "robot", "terrain", "campaign", "exclude_campaign", "record")


def trial_json(t: Trial) -> dict[str, object]:
    from odolab.store.measure import describe_measurement

    c, p, m = t.command, t.predicted, t.measured
    return {
        "trial_id": t.trial_id,
        "campaign": t.campaign,
        "terrain": t.terrain,
        "kind": c.kind.value,
        "command": {**c.to_dict(), "text": c.describe()},
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


async def trials(request: Request) -> Response:
    q = request.query_params
    try:
        status = check_filter("status", q.get("status"), STATUSES)
        kind = check_filter("kind", q.get("kind"), KINDS)
    except StoreError as err:
        return error_json(err)
    campaign = q.get("campaign") or None
    terrain = q.get("terrain") or None
    found = await web(request).run(
        lambda nb: nb.load_trials(campaign, terrain, kind, status, with_logs=False)
    )
    return StrictJSONResponse({"trials": [trial_json(t) for t in awaiting_first(found)]})


async def trial(request: Request) -> Response:
    trial_id = request.path_params["trial_id"]

    def load(nb: Notebook) -> dict[str, object]:
        ctx = trial_context(nb, trial_id)
        out = trial_json(ctx["t"])
        out["params_version"] = ctx["version"]
        out["has_encoder_log"] = ctx["has_log"]
        out["measurement_history"] = [
            {"replaced": when, **dataclasses.asdict(m), "raw": dict(m.raw)}
            for when, m in ctx["history"]
        ]
        return out

    try:
        return StrictJSONResponse(await web(request).run(load))
    except StoreError as err:
        action = trial_id.rsplit("/", 1)[-1] if "/" in trial_id else ""
        if action in _POST_ONLY and request.method in ("GET", "HEAD"):
            # GET .../measurement: the route exists for POST (a trial called "A/measurement"
            # would have been found above)
            return StrictJSONResponse(
                {"error": f"{request.url.path} takes POST (a JSON body), not GET"},
                status_code=405,
                headers={"allow": "POST"},
            )
        return error_json(err, 404)


async def measure(request: Request) -> Response:
    from odolab.store.measure import record_measurement

    trial_id = request.path_params["trial_id"]
    try:
        body = await json_body(request)
        unknown = sorted(set(body) - set(_MEASUREMENT_KEYS))
        if unknown:
            raise StoreError(f"unknown key {unknown[0]!r}; expected {', '.join(_MEASUREMENT_KEYS)}")
        replace = body.get("replace", False)
        if not isinstance(replace, bool):
            raise StoreError(f"replace is {replace!r}; expected true or false")
        readings = json_readings(body)
    except StoreError as err:
        return error_json(err)

    def save(nb: Notebook) -> tuple[int, dict[str, object]]:
        try:
            saved = record_measurement(nb, trial_id, readings_of(readings), replace=replace)
        except StoreError as err:
            return status_of(err), {"error": in_words(str(err), api=True)}
        return 200, trial_json(saved)

    status, out = await web(request).run(save)
    return StrictJSONResponse(out, status_code=status)


async def exclude(request: Request) -> Response:
    w, trial_id = web(request), request.path_params["trial_id"]
    include = request.url.path.endswith("/include")
    try:
        body = await json_body(request)
        reason = body.get("reason", "")
        if not include and not isinstance(reason, str):
            raise StoreError(f"reason is {reason!r}; expected text")

        def act(nb: Notebook) -> dict[str, object]:
            if include:
                nb.include_trial(trial_id)
            else:
                nb.exclude_trial(trial_id, str(reason))  # text: checked above
            return trial_json(nb.get_trial(trial_id))

        return StrictJSONResponse(await w.run(act))
    except StoreError as err:
        return error_json(err, status_of(err))


async def table1(request: Request) -> Response:
    """Table I of the selection (``?campaign=``, ``?exclude_campaign=``), as ``odolab analyze
    --json`` writes it: the rows, what was skipped, which trials were used."""
    try:
        sel = selection_of(request.query_params)
    except StoreError as err:
        return error_json(err)
    result, error, _, status = await analysis_now(web(request), sel)
    if result is None:
        return StrictJSONResponse({"rows": [], "error": error}, status_code=status)
    return StrictJSONResponse(
        {
            "rows": result.table1,
            "skipped": list(result.analysis.skipped),
            "selection": result.selection.to_dict(),
        }
    )


async def calibrate(request: Request) -> Response:
    """``POST /api/calibrate`` ``{"method": "ratios"|"umbmark", "robot"?, "terrain"?,
    "campaign"?: [...], "exclude_campaign"?: [...], "record"?: true}``: what ``odolab calibrate
    ... --db --json`` writes (recorded as a new parameter version unless ``record`` is false)."""
    from odolab.app.calibration import CalibrationRequest
    from odolab.app.calibration import calibrate as run

    try:
        body = await json_body(request)
        unknown = sorted(set(body) - set(_CALIBRATE_KEYS))
        if unknown:
            raise StoreError(f"unknown key {unknown[0]!r}; expected {', '.join(_CALIBRATE_KEYS)}")
        for key in ("method", "robot", "terrain"):
            if body.get(key) is not None and not isinstance(body[key], str):
                raise StoreError(f"{key} is {body[key]!r}; expected text")
        record = body.get("record", True)
        if not isinstance(record, bool):
            raise StoreError(f"record is {record!r}; expected true or false")
        req = CalibrationRequest(
            str(body.get("method", "")),
            selection_of(body),
            robot=str(body.get("robot") or "") or None,  # text or null: checked above
            terrain=str(body.get("terrain") or "") or None,
            record=record,
        )
        w = web(request)
        return StrictJSONResponse(await w.run(lambda nb: run(nb, req, w.cache).to_dict()))
    except OdolabError as err:
        text = web_text(err).replace("(robot, or the form's robot)", '(send "robot")')
        return error_json(StoreError(text))


async def report(request: Request) -> Response:
    """The report's numbers, as ``results.json`` holds them (without the figures)."""
    from odolab.app.report import ReportRequest, report_results

    try:
        req = ReportRequest(selection_of(request.query_params))
        w = web(request)
        return StrictJSONResponse(await w.run(lambda nb: report_results(nb, req, w.cache)))
    except OdolabError as err:
        return error_json(err)
