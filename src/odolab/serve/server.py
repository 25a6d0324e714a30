"""Running the application: bind a socket, serve until stopped (uvicorn), in the foreground or
in a thread (tests, scripts)."""

from __future__ import annotations

import ipaddress
import socket
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from odolab.core.errors import OdolabError
from odolab.serve.app import ServeSettings, create_app
from odolab.serve.connections import DEFAULT_LIMITS, Limits, uvicorn_config
from odolab.serve.security import LOOPBACK_HOSTS, make_token

__all__ = ["ServerInfo", "bind", "is_loopback", "run_in_thread", "serve", "settings_for"]


def is_loopback(host: str) -> bool:
    """True for ``localhost`` and loopback addresses (127.0.0.0/8, ::1)."""
    if host.strip().lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def settings_for(db: str | Path, host: str) -> ServeSettings:
    """Settings for a server bound to ``host``: a random token unless it is loopback."""
    if is_loopback(host):  # answers to the usual loopback names and the one it is bound to
        bound = host.strip().strip("[]").lower()
        return ServeSettings(db=Path(db), allowed_hosts=LOOPBACK_HOSTS | {bound})
    return ServeSettings(db=Path(db), token=make_token(), allowed_hosts=None)


def bind(host: str, port: int) -> socket.socket:
    """A listening TCP socket on ``host:port`` (port 0: any free one).

    Raises:
        OdolabError: the port is out of range, or the address cannot be listened on.
    """
    if not 0 <= port <= 65535:
        raise OdolabError(f"--port is {port}; expected 0..65535")
    family = socket.AF_INET6 if ":" in host.strip("[]") else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    # accepted connections inherit it: without it a response sent as headers then body waits
    # for the client's delayed ACK (Nagle), about 40 ms a request
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    try:
        sock.bind((host.strip("[]"), port))
    except OSError as err:
        sock.close()
        raise OdolabError(f"cannot listen on {host}:{port} ({err.strerror or err})") from err
    sock.listen(64)
    sock.set_inheritable(True)
    return sock


class ServerInfo:
    """Where a running server is: ``url`` (to open; with ``?token=`` when one is needed)."""

    def __init__(self, sock: socket.socket, settings: ServeSettings) -> None:
        host, port = sock.getsockname()[:2]
        if host in ("0.0.0.0", "::"):  # every address: name this computer, as Jupyter does
            host = socket.gethostname()
        shown = f"[{host}]" if ":" in host else host
        self.port: int = port
        self.base_url = f"http://{shown}:{port}"
        self.token = settings.token
        self.url = self.base_url + "/" + (f"?token={settings.token}" if settings.token else "")


def _uvicorn_server(settings: ServeSettings, limits: Limits) -> object:
    """uvicorn with odolab's connection limits: slow and idle clients closed, a quick stop.

    SIGTERM is a request to stop, and a server that stopped as asked exits 0: uvicorn raises
    the signal again once it has shut down, so the process died by it (status -15). Ctrl-C's
    SIGINT is still raised again (odolab says "interrupted")."""
    import contextlib
    import signal

    import uvicorn

    class _Server(uvicorn.Server):
        @contextlib.contextmanager
        def capture_signals(self) -> Iterator[None]:
            with super().capture_signals():
                yield
                captured = self._captured_signals  # (uvicorn's list; raised again on exit)
                captured[:] = [s for s in captured if s != signal.SIGTERM]

    return _Server(uvicorn_config(create_app(settings), limits))


def serve(
    settings: ServeSettings,
    host: str = "127.0.0.1",
    port: int = 8000,
    *,
    ready: Callable[[ServerInfo], None] | None = None,
    limits: Limits = DEFAULT_LIMITS,
) -> None:
    """Serve until interrupted; ``ready(info)`` is called once the socket listens.

    SIGTERM or Ctrl-C stops it within about a second whatever the clients do: requests still
    running ``limits.graceful_shutdown`` seconds after it are cancelled (see
    :mod:`odolab.serve.connections` for the timeouts on slow and idle clients).
    """
    sock = bind(host, port)
    server = _uvicorn_server(settings, limits)
    if ready is not None:
        ready(ServerInfo(sock, settings))
    try:
        server.run(sockets=[sock])  # type: ignore[attr-defined]
    finally:
        sock.close()


@contextmanager
def run_in_thread(
    settings: ServeSettings,
    host: str = "127.0.0.1",
    port: int = 0,
    *,
    limits: Limits = DEFAULT_LIMITS,
) -> Iterator[ServerInfo]:
    """A server running in a background thread while the ``with`` block runs, then stopped."""
    sock = bind(host, port)
    server = _uvicorn_server(settings, limits)
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)  # type: ignore[attr-defined]
    thread.start()
    try:
        import time

        for _ in range(500):
            if getattr(server, "started", False):
                break
            time.sleep(0.01)
        yield ServerInfo(sock, settings)
    finally:
        server.should_exit = True  # type: ignore[attr-defined]
        thread.join(timeout=10)
        sock.close()
