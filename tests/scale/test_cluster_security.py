"""The local Dask cluster has no port another local process can use (issue 24, finding 6).

While a local cluster runs, a stranger on this machine scans every port that odolab and its
worker processes listen on and tries what a stranger can: a plain ``distributed.Client`` (the
attack that ran a function in odolab's worker before), a client with TLS and a certificate of its
own, and the web server's pages. Every try fails; odolab's own client still computes.
"""

from __future__ import annotations

import os
import urllib.error
import urllib.request

import psutil
import pytest

from odolab.metrics.cluster import Cluster, _client, map_outcomes


def _listening_ports() -> set[int]:
    """TCP ports on which this process or its children listen."""
    me = psutil.Process(os.getpid())
    ports: set[int] = set()
    for proc in [me, *me.children(recursive=True)]:
        try:
            conns = proc.net_connections(kind="tcp")
        except (psutil.NoSuchProcess, psutil.AccessDenied):
            continue
        ports |= {c.laddr.port for c in conns if c.status == psutil.CONN_LISTEN}
    return ports


def _pid(_: int) -> int:
    return os.getpid()


def _http_status(port: int, path: str) -> int | None:
    """The HTTP status of GET path, or None when the port does not speak plain HTTP."""
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}{path}", timeout=3) as resp:
            return int(resp.status)
    except urllib.error.HTTPError as err:
        return int(err.code)
    except (OSError, ValueError):
        return None


def _stranger_runs_code(address: str, security: object | None) -> bool:
    """True when a client connects to ``address`` and gets a function run."""
    import gc

    from distributed import Client

    # a client whose connection failed is left half made; collected at a random moment, its
    # __del__ can run inside the next Client's start and wait forever on the lock that start
    # holds (a hang seen in CI): no collection while a client starts, and one right after
    gc.disable()
    try:
        with Client(address, timeout=3, security=security) as c:  # type: ignore[arg-type]
            return bool(c.submit(os.getpid, pure=False).result(timeout=5))
    except Exception:
        return False
    finally:
        gc.enable()
        gc.collect()


def test_a_local_process_cannot_use_the_local_cluster() -> None:
    from distributed.security import Security

    before = _listening_ports()
    with _client(Cluster(workers=2)) as client:
        info = client.scheduler_info()
        workers = list(info["workers"])
        assert len(workers) == 2
        assert client.scheduler.address.startswith("tls://127.0.0.1:")
        assert all(w.startswith("tls://127.0.0.1:") for w in workers)
        # odolab's own client computes in the worker processes
        pids = set(client.gather(client.map(_pid, range(4), pure=False)))
        assert pids and os.getpid() not in pids

        # a plain client given the scheduler's address (the attack that worked before)
        assert not _stranger_runs_code(client.scheduler.address, None)
        ports = _listening_ports() - before
        assert len(ports) >= 5  # scheduler, its web server, 2 nannies, 2 workers (+ web servers)
        stranger_tls = Security.temporary()  # a certificate of the stranger's own
        web = 0
        for port in sorted(ports):
            status = _http_status(port, "/health")
            if status is not None:  # a web server: it serves nothing at all
                web += 1
                for path in ("/health", "/info/main/workers.html", "/json/identity.json",
                             "/metrics", "/statics/"):  # fmt: skip
                    assert _http_status(port, path) == 404, (port, path)
                continue
            assert not _stranger_runs_code(f"tcp://127.0.0.1:{port}", None), port
            assert not _stranger_runs_code(f"tls://127.0.0.1:{port}", stranger_tls), port
        assert web >= 1


def _double(x: int) -> int:
    return 2 * x


def _double_with_dask_noise(x: int) -> int:
    """``_double``, logging on the worker what Dask logs when a worker outlives its scheduler
    at shutdown (a 40-line error with its traceback, once in 4 runs of the README's line)."""
    import logging

    logging.getLogger("distributed.worker").error(
        "Failed to communicate with scheduler during heartbeat."
    )
    return 2 * x


def test_the_tls_cluster_gives_the_in_process_results(capfd: pytest.CaptureFixture[str]) -> None:
    items = list(range(12))
    here = map_outcomes(_double, items, cluster=Cluster(workers=1))
    there = map_outcomes(_double_with_dask_noise, items, cluster=Cluster(workers=2), batch=2)
    assert [o.result for o in there] == [o.result for o in here] == [2 * x for x in items]
    assert all(str(o.worker).startswith("tls://127.0.0.1:") for o in there)
    # odolab's own output stays odolab's: Dask's logs of its workers do not reach the terminal
    # (issue 38, item 13)
    assert "Failed to communicate with scheduler" not in capfd.readouterr().err
