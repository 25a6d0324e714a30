"""Slow and idle clients are closed, and SIGTERM stops ``odolab serve`` whatever clients do
(issue 24, finding 9)."""

from __future__ import annotations

import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from odolab.serve import run_in_thread, settings_for
from odolab.serve.connections import Limits

#: short timeouts, so that a test waits well under a second for the server to act
QUICK = Limits(header_timeout=0.4, body_idle_timeout=0.4, min_body_rate=1024.0, tick=0.1)
#: how long a test waits for what should take well under a second (generous: a loaded machine)
PATIENCE = 10.0

HALF_BODY = (
    b"POST /api/trials/R20/measurement HTTP/1.1\r\nHost: 127.0.0.1\r\n"
    b"Content-Type: application/json\r\nContent-Length: 1000\r\n\r\n"
    b'{"final": 12'
)


def _connect(port: int) -> socket.socket:
    sock = socket.create_connection(("127.0.0.1", port), timeout=PATIENCE)
    sock.settimeout(PATIENCE)
    return sock


def _closed_by_server(sock: socket.socket) -> bool:
    """True when the server closes the connection (recv gives end of file) within PATIENCE."""
    try:
        while True:
            data = sock.recv(65536)
            if not data:
                return True
    except ConnectionResetError:
        return True
    except TimeoutError:
        return False


def _get(sock: socket.socket, path: str = "/api/trials") -> bytes:
    """One keep-alive GET on ``sock``: the response's status line."""
    sock.sendall(f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n".encode())
    buf = b""
    while b"\r\n\r\n" not in buf:
        chunk = sock.recv(65536)
        assert chunk, "the server closed a connection that was in use"
        buf += chunk
    head, _, body = buf.partition(b"\r\n\r\n")
    length = next(
        int(line.split(b":", 1)[1])
        for line in head.split(b"\r\n")
        if line.lower().startswith(b"content-length:")
    )
    while len(body) < length:
        body += sock.recv(65536)
    return head.split(b"\r\n", 1)[0]


@pytest.fixture
def quick_server(lab_db: Path) -> Iterator[int]:
    with run_in_thread(settings_for(lab_db, "127.0.0.1"), limits=QUICK) as info:
        yield info.port


def test_connections_that_send_nothing_are_closed(quick_server: int) -> None:
    socks = [_connect(quick_server) for _ in range(30)]
    try:
        assert [_closed_by_server(s) for s in socks] == [True] * 30
    finally:
        for s in socks:
            s.close()


def test_a_client_is_served_while_hundreds_hold_half_open_connections(lab_db: Path) -> None:
    """No connection limit that idle connections use up (uvicorn's limit_concurrency counts
    them: with it, 250 half-open connections got everyone else a 503)."""
    with run_in_thread(settings_for(lab_db, "127.0.0.1")) as info:  # the default timeouts
        held = [_connect(info.port) for _ in range(250)]
        try:
            with _connect(info.port) as sock:
                assert _get(sock) == b"HTTP/1.1 200 OK"
        finally:
            for s in held:
                s.close()


def test_half_headers_and_half_a_body_are_closed(quick_server: int) -> None:
    with _connect(quick_server) as headers:
        headers.sendall(b"GET /api/trials HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ")
        with _connect(quick_server) as body:
            body.sendall(HALF_BODY)
            assert _closed_by_server(headers)
            assert _closed_by_server(body)


def test_a_body_trickled_a_byte_at_a_time_is_closed(quick_server: int) -> None:
    with _connect(quick_server) as sock:
        sock.sendall(HALF_BODY)
        sock.settimeout(0.05)
        closed = False
        deadline = time.monotonic() + PATIENCE
        while not closed and time.monotonic() < deadline:
            try:
                sock.sendall(b"1")  # a byte every 50 ms: never idle for 0.4 s, but 20 B/s
                closed = sock.recv(1) == b""
            except TimeoutError:
                continue
            except (BrokenPipeError, ConnectionResetError):
                closed = True
        assert closed


BIG = 64 * 1024 * 1024  # a response far larger than the sockets' buffers


async def _big_response(scope: dict, receive: object, send: object) -> None:  # type: ignore[type-arg]
    """A tiny ASGI app: 64 MiB of zeros to every request."""
    assert scope["type"] == "http"
    await send(  # type: ignore[operator]
        {"type": "http.response.start", "status": 200,
         "headers": [(b"content-length", str(BIG).encode())]}
    )  # fmt: skip
    chunk = bytes(1024 * 1024)
    for k in range(BIG // len(chunk)):
        await send(  # type: ignore[operator]
            {"type": "http.response.body", "body": chunk, "more_body": k < BIG // len(chunk) - 1}
        )


def test_a_client_that_stops_reading_the_response_is_closed() -> None:
    import threading

    import uvicorn

    from odolab.serve.connections import uvicorn_config
    from odolab.serve.server import bind

    sock = bind("127.0.0.1", 0)
    server = uvicorn.Server(uvicorn_config(_big_response, QUICK))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    try:
        client = socket.socket()
        client.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        client.connect(sock.getsockname())
        with client:
            client.sendall(b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
            time.sleep(2.0)  # the client reads nothing: the server's send buffer fills, stalls
            client.settimeout(PATIENCE)
            got = 0
            try:
                while chunk := client.recv(1 << 20):
                    got += len(chunk)
            except ConnectionResetError:
                pass
            # before: the whole 64 MiB came (the server waited for the client for ever)
            assert got < BIG // 2
    finally:
        server.should_exit = True
        thread.join(timeout=10)
        sock.close()


def test_a_client_that_keeps_asking_is_served_past_the_timeouts(quick_server: int) -> None:
    """The timeouts are on what a client owes, not on a connection's age."""
    with _connect(quick_server) as sock:
        statuses = []
        for _ in range(12):  # 12 requests over ~1.2 s on one connection (timeouts: 0.4 s)
            statuses.append(_get(sock))
            time.sleep(0.1)
        assert statuses == [b"HTTP/1.1 200 OK"] * 12


def test_sigterm_stops_the_server_while_a_client_holds_half_a_body(lab_db: Path) -> None:
    proc = subprocess.Popen(
        [sys.executable, "-m", "odolab.cli", "serve", "--db", str(lab_db), "--port", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stdout is not None
        url = [proc.stdout.readline() for _ in range(3)][2].strip()
        port = int(url.rsplit(":", 1)[1].strip("/"))
        with _connect(port) as ok, _connect(port) as slow, _connect(port) as idle:
            assert _get(ok) == b"HTTP/1.1 200 OK"  # the server answers
            slow.sendall(HALF_BODY)  # the application now waits for the rest of the body
            idle.sendall(b"GET / HTTP/1.1\r\n")
            time.sleep(0.3)
            proc.send_signal(signal.SIGTERM)
            # before: still running 15 s later (uvicorn waited for the body for ever)
            code = proc.wait(timeout=5)
            assert code == 0  # it stopped as asked (it died by the signal: -15)
            assert _closed_by_server(slow)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=10)
