"""How ``odolab serve`` treats connections: slow and idle clients are closed, and a stop is quick.

uvicorn (0.54, the h11 protocol) closes a connection that stays idle after a response
(``timeout_keep_alive``), but nothing else: a client that connects and sends nothing, one that
sends its request line a byte at a time, or one that sends half a request body and waits, holds
its connection (and, for a body, a task of the application) for ever; and on SIGTERM uvicorn
waits for every such request to finish before it exits. :class:`GuardedH11Protocol` adds what
is missing, per connection, checked every :attr:`Limits.tick` seconds:

- the request line and headers must arrive within :attr:`Limits.header_timeout` seconds of the
  connection (or of the previous response);
- a request body must keep arriving: no pause longer than :attr:`Limits.body_idle_timeout`, and
  on average at least :attr:`Limits.min_body_rate` bytes per second once
  :attr:`Limits.header_timeout` seconds have passed (a client trickling a byte now and then is
  closed too). Time while the application, not the client, holds the body back (uvicorn's flow
  control has paused reading) does not count against the client;
- a response must keep leaving: a client that stops reading it (the server's send buffer full,
  no byte taken for :attr:`Limits.body_idle_timeout` seconds) is closed;
- a connection whose request has arrived whole waits for the application as long as it takes.

:func:`uvicorn_config` puts these together with uvicorn's own limits: ``timeout_keep_alive``,
h11's limit on incomplete headers, and
``timeout_graceful_shutdown`` (after SIGTERM, requests still running are cancelled after it, so
the server stops within about a second whatever the clients do).
"""

from __future__ import annotations

import asyncio
import logging
from dataclasses import dataclass
from typing import TYPE_CHECKING

import h11
from uvicorn.protocols.http.h11_impl import H11Protocol

if TYPE_CHECKING:
    import uvicorn
    from starlette.applications import Starlette
    from uvicorn.server import ServerState

__all__ = ["GuardedH11Protocol", "Limits", "uvicorn_config"]


@dataclass(frozen=True)
class Limits:
    """Timeouts (seconds) and sizes of the server's connections."""

    header_timeout: float = 10.0
    body_idle_timeout: float = 10.0
    min_body_rate: float = 1024.0  # bytes/s, averaged over the body so far
    keep_alive: int = 5
    max_header_bytes: int = 64 * 1024
    graceful_shutdown: float = 0.5
    tick: float = 0.5


DEFAULT_LIMITS = Limits()


class GuardedH11Protocol(H11Protocol):
    """uvicorn's h11 protocol with a deadline on what the client owes (see the module's text)."""

    limits: Limits = DEFAULT_LIMITS

    def __init__(
        self,
        config: uvicorn.Config,
        server_state: ServerState,
        app_state: dict[str, object],
        _loop: asyncio.AbstractEventLoop | None = None,
    ) -> None:
        super().__init__(config, server_state, app_state, _loop)
        self._guard: asyncio.TimerHandle | None = None
        self._phase: object = None  # the client's h11 state when the clock started
        self._since = 0.0  # when the client started to owe bytes (less paused time)
        self._last_byte = 0.0
        self._request_bytes = 0  # bytes of the current request (headers and body) so far
        self._unsent = 0  # bytes waiting in the send buffer at the last check
        self._sent_at = 0.0  # when the client last took some of the response

    # -- uvicorn's protocol interface --------------------------------------------------------

    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        super().connection_made(transport)
        self._restart(h11.IDLE)
        self._arm()

    def data_received(self, data: bytes) -> None:
        self._last_byte = self.loop.time()
        self._request_bytes += len(data)
        super().data_received(data)

    def on_response_complete(self) -> None:
        self._restart(h11.IDLE)  # the next request's headers are owed from now
        super().on_response_complete()

    def connection_lost(self, exc: Exception | None) -> None:
        if self._guard is not None:
            self._guard.cancel()
            self._guard = None
        super().connection_lost(exc)

    # -- the guard ---------------------------------------------------------------------------

    def _restart(self, phase: object) -> None:
        now = self.loop.time()
        self._phase, self._since, self._last_byte, self._request_bytes = phase, now, now, 0
        self._sent_at = now

    def _arm(self) -> None:
        self._guard = self.loop.call_later(self.limits.tick, self._check)

    def _close(self) -> None:
        if self.cycle is not None and not self.cycle.response_complete:
            self.cycle.disconnected = True  # the application's receive() gets http.disconnect
            self.cycle.message_event.set()
        self.transport.close()

    def _check(self) -> None:
        self._guard = None
        if self.transport.is_closing():
            return
        lim = self.limits
        now = self.loop.time()
        state = self.conn.their_state
        waiting = state is h11.IDLE and (self.cycle is None or self.cycle.response_complete)
        if state is not self._phase:  # a new phase (headers -> body -> application): new clock
            self._phase, self._since, self._last_byte = state, now, now
        unsent = self.transport.get_write_buffer_size()
        if not self.flow.write_paused or unsent < self._unsent:
            self._sent_at = now  # the client reads (or nothing waits for it)
        self._unsent = unsent
        if now - self._sent_at > lim.body_idle_timeout:
            self._close()  # the client stopped reading the response
            return
        if self.flow.read_paused:  # the application holds the body back, not the client
            self._since += lim.tick
            self._last_byte = now
        elapsed = now - self._since
        if waiting and elapsed > lim.header_timeout:
            self._close()  # no request (or only part of its headers) in time
            return
        if state is h11.SEND_BODY and (
            now - self._last_byte > lim.body_idle_timeout
            or (elapsed > lim.header_timeout and self._request_bytes < lim.min_body_rate * elapsed)
        ):
            self._close()  # the body stopped, or trickles
            return
        self._arm()


class _QuietStop(logging.Filter):
    """Drops uvicorn's ERROR line about the requests a stop cancels: a stop is not an error."""

    def filter(self, record: logging.LogRecord) -> bool:
        return "timeout graceful shutdown exceeded" not in record.getMessage()


def uvicorn_config(app: Starlette, limits: Limits = DEFAULT_LIMITS) -> uvicorn.Config:
    """A ``uvicorn.Config`` for ``app`` with :class:`GuardedH11Protocol` and ``limits``."""
    import uvicorn

    protocol = type("OdolabH11Protocol", (GuardedH11Protocol,), {"limits": limits})
    config = uvicorn.Config(
        app,
        http=protocol,
        log_level="warning",
        lifespan="off",
        access_log=False,
        timeout_keep_alive=limits.keep_alive,
        timeout_graceful_shutdown=limits.graceful_shutdown,  # type: ignore[arg-type]
        # no limit_concurrency: uvicorn counts open connections, idle ones too, so a flood of
        # half-open connections made it answer 503 to everyone until they timed out
        h11_max_incomplete_event_size=limits.max_header_bytes,
    )
    error_log = logging.getLogger("uvicorn.error")
    if not any(isinstance(f, _QuietStop) for f in error_log.filters):
        error_log.addFilter(_QuietStop())
    return config
