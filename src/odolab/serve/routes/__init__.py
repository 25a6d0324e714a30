"""The web notebook's routes, a module per page family; each route parses the request, calls
one function of :mod:`odolab.app` (or the store for a plain listing), and renders the result."""

from __future__ import annotations

from starlette.routing import Route

from odolab.serve.routes import api, calibrate, data, favicon, params, report, table1, trials

__all__ = ["ROUTES"]

ROUTES = [
    Route("/", trials.index),
    Route("/favicon.ico", favicon.favicon),
    Route("/trial", trials.trial_page),
    Route("/trial/measure", trials.measure, methods=["POST"]),
    Route("/trial/exclude", trials.exclude, methods=["POST"]),
    Route("/trial/include", trials.exclude, methods=["POST"]),
    Route("/trial/plot.png", trials.plot),
    Route("/table1", table1.page),
    Route("/table1/fit.png", table1.fit_plot),
    Route("/params", params.page),
    Route("/params.toml", params.toml),
    Route("/calibrate", calibrate.page),
    Route("/calibrate", calibrate.post, methods=["POST"]),
    Route("/report", report.page),
    Route("/report.html", report.download),
    Route("/data", data.page),
    Route("/data/import", data.upload, methods=["POST"]),
    Route("/data/export", data.export),
    Route("/api/trials", api.trials),
    Route("/api/table1", api.table1),
    Route("/api/calibrate", api.calibrate, methods=["POST"]),
    Route("/api/report", api.report),
    Route("/api/trials/{trial_id:path}/measurement", api.measure, methods=["POST"]),
    Route("/api/trials/{trial_id:path}/exclude", api.exclude, methods=["POST"]),
    Route("/api/trials/{trial_id:path}/include", api.exclude, methods=["POST"]),
    Route("/api/trials/{trial_id:path}", api.trial),
]
