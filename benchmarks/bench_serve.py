"""Web server speed: odolab serve (Starlette on uvicorn) against Flask on Werkzeug, same work.

Run:  PYTHONPATH=src python benchmarks/bench_serve.py [N]
Both servers answer the same two requests with the same library calls over loopback, two
clients at once: ``GET /api/trials`` (open the notebook, load the trials, JSON) and
``POST /api/trials/ID/measurement`` (the CLI's checks, one BEGIN IMMEDIATE write, replace=True).
The Flask baseline runs only when flask is installed (it is not a dependency of odolab).
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import httpx

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.serve.conftest import build_notebook


def _load(base: str, n: int) -> tuple[float, float]:
    """Requests per second for the list and for a measurement, two clients at once."""
    rates = []
    for kind in ("list", "measure"):
        done = threading.Barrier(3)

        def client(k: str, i0: int, done: threading.Barrier) -> None:
            with httpx.Client(base_url=base, timeout=60) as c:
                done.wait()
                for i in range(n):
                    if k == "list":
                        r = c.get("/api/trials")
                    else:
                        x = 2.3 + ((i0 + i) % 100) / 1000
                        r = c.post("/api/trials/F1/measurement",
                                   json={"x": x, "y": 0.0, "replace": True})  # fmt: skip
                    assert r.status_code == 200, r.text
                done.wait()

        threads = [threading.Thread(target=client, args=(kind, j * n, done)) for j in range(2)]
        for t in threads:
            t.start()
        done.wait()
        t0 = time.perf_counter()
        done.wait()
        rates.append(2 * n / (time.perf_counter() - t0))
        for t in threads:
            t.join()
    return rates[0], rates[1]


def _flask_app(db: Path) -> Any:
    from flask import Flask, jsonify, request

    from odolab.core.errors import StoreError
    from odolab.serve.app import _trial_json
    from odolab.store import Notebook
    from odolab.store.measure import record_measurement

    app = Flask("baseline")

    @app.get("/api/trials")
    def trials() -> Any:
        with Notebook(db) as nb:
            return jsonify({"trials": [_trial_json(t) for t in nb.load_trials(with_logs=False)]})

    @app.post("/api/trials/<path:tid>/measurement")
    def measure(tid: str) -> Any:
        body = request.get_json()
        try:
            with Notebook(db) as nb:
                return jsonify(_trial_json(record_measurement(nb, tid, **body)))
        except StoreError as err:
            return jsonify({"error": str(err)}), 400

    return app


_FLASK_SERVER = """
import sys
from pathlib import Path
sys.path.insert(0, sys.argv[2])
from werkzeug.serving import WSGIRequestHandler, make_server
from benchmarks.bench_serve import _flask_app

class Quiet(WSGIRequestHandler):
    def log_request(self, *args, **kwargs):
        pass

server = make_server("127.0.0.1", 0, _flask_app(Path(sys.argv[1])), threaded=True,
                     request_handler=Quiet)
print(f"http://127.0.0.1:{server.server_port}/", flush=True)
server.serve_forever()
"""


def _measure_server(cmd: list[str], n: int) -> tuple[float, float]:
    """Start a server process, read its address (last word of its third line or first)."""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    try:
        line = ""
        while "http://" not in line:
            line = proc.stdout.readline()
            if not line and proc.poll() is not None:
                raise RuntimeError(f"{cmd[0]} exited")
        base = line.strip().split()[-1].split("/?")[0].rstrip("/")
        _load(base, 10)  # warm up
        return _load(base, n)
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def main(n: int = 150) -> None:
    d = Path(tempfile.mkdtemp())
    db = build_notebook(d / "lab.db")
    root = str(Path(__file__).resolve().parents[1])
    ours = _measure_server(
        [sys.executable, "-m", "odolab.cli", "serve", "--db", str(db), "--port", "0"], n
    )
    print(
        f"odolab serve (Starlette/uvicorn): list {ours[0]:.0f} req/s, measure {ours[1]:.0f} req/s"
    )
    try:
        import flask  # noqa: F401
    except ImportError:
        print("flask not installed: no baseline (pip install flask to compare)")
        return
    theirs = _measure_server([sys.executable, "-c", _FLASK_SERVER, str(db), root], n)
    print(f"Flask/Werkzeug threaded (same calls): list {theirs[0]:.0f} req/s, "
          f"measure {theirs[1]:.0f} req/s")  # fmt: skip
    print(f"ratio ours/Flask: list {ours[0] / theirs[0]:.2f}, measure {ours[1] / theirs[1]:.2f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 150)
