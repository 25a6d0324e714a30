"""The lab notebook in the browser: ``odolab serve --db lab.db`` (see docs/serve.md).

Server-rendered pages (Starlette + Jinja2, no JavaScript) for entering measurements on a phone,
Table I and its fits, parameter versions, calibration, the report, import and export; and a JSON
API under ``/api/``. Bound to 127.0.0.1 by default; any other address requires a random token.

>>> from odolab.serve import ServeSettings, create_app
>>> app = create_app(ServeSettings(db="lab.db"))           # doctest: +SKIP
"""

from odolab.serve.app import MAX_UPLOAD_BYTES, ServeSettings, create_app
from odolab.serve.server import ServerInfo, is_loopback, run_in_thread, serve, settings_for

__all__ = [
    "MAX_UPLOAD_BYTES",
    "ServeSettings",
    "ServerInfo",
    "create_app",
    "is_loopback",
    "run_in_thread",
    "serve",
    "settings_for",
]
