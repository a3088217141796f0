"""The studio's HTTP connections: uvicorn's h11 protocol with a header timeout.

uvicorn closes an idle keep-alive connection after ``timeout_keep_alive``, but only once a
response is complete, and a single byte received stops that timer: a connection that never
sends a whole request head (a half-open one, or a slow-loris sending a byte now and then) is
held forever, and enough of them fill the server. Here every connection waiting for a request
head, fresh or between keep-alive requests, is closed :data:`HEADER_TIMEOUT` seconds after it
began to wait unless the head has arrived whole.
"""

from __future__ import annotations

import asyncio

import h11
from uvicorn.protocols.http.h11_impl import H11Protocol

#: Seconds a connection may take to send a whole request head.
HEADER_TIMEOUT = 5.0


class HeaderTimeoutProtocol(H11Protocol):
    """:class:`H11Protocol` closing a connection that has not sent a request head in time."""

    _head_deadline: asyncio.TimerHandle | None = None

    def connection_made(self, transport) -> None:
        super().connection_made(transport)
        self._wait_for_head()

    def on_response_complete(self) -> None:
        super().on_response_complete()
        if not self.transport.is_closing():
            self._wait_for_head()

    def connection_lost(self, exc: Exception | None) -> None:
        if self._head_deadline is not None:
            self._head_deadline.cancel()
        super().connection_lost(exc)

    def _wait_for_head(self) -> None:
        if self._head_deadline is not None:
            self._head_deadline.cancel()
        self._head_deadline = self.loop.call_later(HEADER_TIMEOUT, self._head_late)

    def _head_late(self) -> None:
        self._head_deadline = None
        waiting = self.conn.their_state is h11.IDLE and (self.cycle is None or self.cycle.response_complete)
        if waiting and not self.transport.is_closing():
            self.transport.close()
