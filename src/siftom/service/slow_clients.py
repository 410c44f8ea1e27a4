"""Deadlines for slow clients: a connection that has not sent a request's headers within
``header_timeout_s``, or its body within ``body_timeout_s`` of the headers, is closed.

uvicorn times out idle keep-alive connections, but not a request that arrives slowly: a client
sending a header line every few seconds (or nothing at all after connecting), or a body a byte
at a time, would hold its socket, and its slot of the server, for as long as it likes. No token
is needed to do that, since the headers that carry it never finish.

:func:`deadline_protocol` makes uvicorn's HTTP/1.1 protocol (h11) with both deadlines; pass it as
``uvicorn.Config(http=...)``. The header clock starts when the connection opens, or at the first
byte of the next request on a kept-alive connection; the body clock when the headers are
complete. A client past the header deadline gets ``408 Request Timeout`` and the connection is
closed; one past the body deadline is disconnected (the handler reading the body sees the client
gone). WebSocket connections are left alone once upgraded (they have their own idle limit).
"""

from __future__ import annotations

import asyncio
from typing import Any

import h11
from uvicorn.protocols.http.h11_impl import H11Protocol

HEADER_TIMEOUT_S = 10.0  # a request line and headers are a few hundred bytes
BODY_TIMEOUT_S = 60.0  # the largest body (2 MiB by default) at about 35 kB/s
_BODY_408 = b"the request's headers were not sent in time; send them at once"
_TIMEOUT_408 = (b"HTTP/1.1 408 Request Timeout\r\ncontent-type: text/plain; charset=utf-8\r\nconnection: close\r\n"
                b"content-length: " + str(len(_BODY_408)).encode() + b"\r\n\r\n" + _BODY_408)


class DeadlineH11Protocol(H11Protocol):
    """uvicorn's h11 protocol with a header deadline and a body deadline (see module doc)."""

    header_timeout_s: float = HEADER_TIMEOUT_S
    body_timeout_s: float = BODY_TIMEOUT_S

    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        self._deadline: asyncio.TimerHandle | None = None
        self._phase: str | None = None
        super().connection_made(transport)
        self._arm()

    def data_received(self, data: bytes) -> None:
        super().data_received(data)
        self._arm()

    def connection_lost(self, exc: Exception | None) -> None:
        self._disarm()
        super().connection_lost(exc)

    def handle_websocket_upgrade(self, event: h11.Request) -> None:
        self._disarm()
        self._phase = "upgraded"
        super().handle_websocket_upgrade(event)

    def _disarm(self) -> None:
        if self._deadline is not None:
            self._deadline.cancel()
            self._deadline = None

    def _arm(self) -> None:
        """Start the clock of the phase the request is in (kept while the phase lasts)."""
        if self._phase == "upgraded":
            return
        if self.transport.is_closing():
            self._disarm()
            return
        state = self.conn.their_state
        phase = "headers" if state is h11.IDLE else "body" if state is h11.SEND_BODY else None
        if phase == self._phase:
            return
        self._disarm()
        self._phase = phase
        if phase is not None:
            limit = self.header_timeout_s if phase == "headers" else self.body_timeout_s
            self._deadline = self.loop.call_later(limit, self._expired, phase)

    def _expired(self, phase: str) -> None:
        self._deadline = None
        if self.transport.is_closing() or self._phase != phase:
            return
        limit = self.header_timeout_s if phase == "headers" else self.body_timeout_s
        self.logger.info("%s - closed: the request's %s took longer than %g s", self.client, phase, limit)
        if phase == "headers":  # no request yet, so an answer may go out
            self.transport.write(_TIMEOUT_408)
        self.transport.close()


def deadline_protocol(header_timeout_s: float = HEADER_TIMEOUT_S, body_timeout_s: float = BODY_TIMEOUT_S) -> Any:
    """The protocol class for ``uvicorn.Config(http=...)`` with these deadlines (seconds)."""
    if not (header_timeout_s > 0 and body_timeout_s > 0):
        from siftom.errors import OptionsError

        raise OptionsError(f"the header and body deadlines must be > 0 s, got {header_timeout_s} and {body_timeout_s}")
    return type("DeadlineH11Protocol", (DeadlineH11Protocol,),
                {"header_timeout_s": float(header_timeout_s), "body_timeout_s": float(body_timeout_s)})
