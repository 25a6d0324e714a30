"""The trial pages: the list (with filters), one trial, its measurement, exclusion, run plot."""

from __future__ import annotations

from typing import TYPE_CHECKING, TypedDict

from starlette.requests import Request
from starlette.responses import Response

from odolab.app.exports import KINDS, STATUSES, check_filter
from odolab.core.errors import OdolabError, StoreError
from odolab.core.trials import TrialStatus
from odolab.serve.routes._web import plain, posted, text_field, web

if TYPE_CHECKING:
    from collections.abc import Mapping

    from odolab.core.trials import Measurement, Trial
    from odolab.serve.routes._web import Web
    from odolab.store import Notebook

__all__ = ["awaiting_first", "index", "trial_context", "trial_page"]


def awaiting_first(trials: list[Trial]) -> list[Trial]:
    order = {TrialStatus.AWAITING: 0, TrialStatus.MEASURED: 1, TrialStatus.EXCLUDED: 2}
    return sorted(trials, key=lambda t: order[t.status])


def _listing(nb: Notebook, filters: dict[str, str | None]) -> dict[str, object]:
    everything = nb.load_trials(with_logs=False)
    counts: dict[str, dict[str, int]] = {}
    for t in everything:
        counts.setdefault(t.campaign, dict.fromkeys(STATUSES, 0))[t.status.value] += 1

    def keep(t: Trial) -> bool:
        values = {
            "status": t.status.value,
            "kind": t.command.kind.value,
            "campaign": t.campaign,
            "terrain": t.terrain,
        }
        return all(filters[k] in (None, v) for k, v in values.items())

    trials = [t for t in everything if keep(t)]
    return {
        "campaigns": nb.campaigns(),
        "counts": counts,
        "terrains": sorted({t.terrain for t in everything}),
        "trials": awaiting_first(trials),
        "total": len(everything),
    }


async def index(request: Request) -> Response:
    w, q = web(request), request.query_params
    error = None
    filters = {k: (q.get(k) or None) for k in ("status", "kind", "campaign", "terrain")}
    try:
        check_filter("status", filters["status"], STATUSES)
        check_filter("kind", filters["kind"], KINDS)
    except StoreError as err:
        error = str(err)
        filters["status"] = filters["kind"] = None
    data = await w.run(lambda nb: _listing(nb, filters))
    return w.page(
        request, "index.html.j2", filters=filters, statuses=STATUSES, kinds=KINDS, error=error,
        **data,
    )  # fmt: skip


class TrialContext(TypedDict):
    """What the trial page shows of one trial (and the API's trial answer starts from)."""

    virtual: str | None  #: what a virtual board's instruments show, in words
    t: Trial
    robot: str
    version: int
    history: list[tuple[str, Measurement]]  #: replaced measurements, with when
    rotation: bool
    has_log: bool


def trial_context(nb: Notebook, trial_id: str) -> TrialContext:
    from odolab.store.measure import describe_readings, virtual_readings

    t = nb.get_trial(trial_id)
    robot, version = nb.trial_params_version(trial_id)
    readings = virtual_readings(t)  # a run on a virtual board: what its instruments show
    return {
        "virtual": describe_readings(readings) if readings is not None else None,
        "t": t,
        "robot": robot,
        "version": version,
        "history": nb.measurement_history(trial_id),
        "rotation": t.command.kind.turns_in_place,
        "has_log": t.encoder_log is not None and len(t.encoder_log) > 1,
    }


async def trial_page(request: Request) -> Response:
    import hmac

    w = web(request)
    trial_id = request.query_params.get("id", "")
    try:
        ctx = await w.run(lambda nb: trial_context(nb, trial_id))
    except StoreError as err:
        return w.error_page(request, err, 404)
    saved = request.query_params.get("saved")
    if saved is not None and not hmac.compare_digest(
        w.saved_signature(trial_id, saved), request.query_params.get("sig", "")
    ):
        saved = None  # a link made elsewhere cannot show "measured: ..." on the page
    return w.page(request, "trial.html.j2", values={}, error=None, invalid=(), saved=saved, **ctx)


async def _refused(
    request: Request, trial_id: str, err: StoreError, values: dict[str, str | None]
) -> Response:
    """The trial page again with the refusal's sentence in the page's words, the fields it is
    about marked, and the values typed (nothing stored); the error page when the trial itself
    is unknown."""
    from odolab.serve.routes._measure import fields_of, in_words

    w = web(request)
    try:
        ctx = await w.run(lambda nb: trial_context(nb, trial_id))
    except StoreError as err2:
        return w.error_page(request, err2, 404)
    return w.page(
        request, "trial.html.j2", 400, values=values, error=in_words(str(err)),
        invalid=fields_of(err), saved=None, **ctx,
    )  # fmt: skip


@posted
async def measure(request: Request, w: Web, form: Mapping[str, object]) -> Response:
    from odolab.serve.routes._measure import FIELDS, form_readings, readings_of
    from odolab.store.measure import describe_measurement, record_measurement

    trial_id = str(form.get("id", ""))
    values = {k: text_field(form, k) for k in FIELDS}
    replace = form.get("replace") == "on"
    values["replace"] = "on" if replace else None

    def save(nb: Notebook) -> str:
        saved = record_measurement(nb, trial_id, readings_of(readings), replace=replace)
        return describe_measurement(saved)

    try:
        readings = form_readings(form)
        text = await w.run(save)
    except StoreError as err:
        return await _refused(request, trial_id, err, values)
    return w.trial_saved(trial_id, f"measured: {text}")


@posted
async def exclude(request: Request, w: Web, form: Mapping[str, object]) -> Response:
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
        text = await w.run(act)
    except StoreError as err:
        return await _refused(request, trial_id, err, {})
    return w.trial_saved(trial_id, text)


async def plot(request: Request) -> Response:
    from odolab.serve.plots import run_png

    trial_id = request.query_params.get("id", "")
    size = request.query_params.get("size")
    try:
        png = await web(request).run(lambda nb: run_png(nb.get_trial(trial_id), size))
    except OdolabError as err:
        return plain(str(err), 404)
    if png is None:
        return plain("this trial has no encoder log", 404)
    return Response(png, media_type="image/png")
