"""uvicorn's h11 protocol with the connection bounds uvicorn lacks.

uvicorn closes a keep-alive connection ``timeout_keep_alive`` seconds after
its last response, but it waits forever for the *first* request of a new
connection, and for the rest of a request whose headers arrive in pieces
(each byte cancels the keep-alive timer). Idle sockets then pile up until the
process runs out of file descriptors. :class:`GuardedH11Protocol` adds:

* a **header timeout**: from the moment a connection is accepted, or the
  first byte of a request after a keep-alive gap, the request headers must be
  complete within ``header_timeout`` seconds, or the connection is closed;
* a **connection cap**: a socket accepted while ``max_connections`` are open
  is closed at once (its file descriptor freed immediately), so the process
  never reaches its descriptor limit.

Body timeouts are the ASGI middleware's job (:mod:`service.limits`).
"""

from __future__ import annotations

import h11
from uvicorn.protocols.http.h11_impl import H11Protocol

from .settings import ServiceSettings


class GuardedH11Protocol(H11Protocol):
    """uvicorn's ``H11Protocol`` plus a header timeout and a connection cap (module docstring).

    The bounds are the process's :class:`ServiceSettings` from the environment
    (``kinserve serve`` sets it before uvicorn starts, in every worker), read
    once; pass this class to uvicorn as ``http="kinserve.service.connection:GuardedH11Protocol"``.
    """

    _header_timer = None
    _bounds: tuple[float, int] | None = None

    @classmethod
    def bounds(cls) -> tuple[float, int]:
        """``(header_timeout, max_connections)`` of this process."""
        if cls._bounds is None:
            s = ServiceSettings.from_env()
            cls._bounds = (s.header_timeout, s.max_connections)
        return cls._bounds

    def connection_made(self, transport) -> None:
        """Accept the connection, or close it at once over the connection cap."""
        super().connection_made(transport)
        if len(self.connections) > self.bounds()[1]:
            self.transport.close()
            return
        self._arm_header_timer()

    def data_received(self, data: bytes) -> None:
        """Feed ``data`` to h11; start the header timer while a request's headers are incomplete."""
        super().data_received(data)
        if self.transport.is_closing():
            return
        if self.conn.their_state is h11.IDLE:
            # headers still incomplete: the clock started at accept or with the first byte after a keep-alive
            # gap
            if self._header_timer is None:
                self._arm_header_timer()
        else:
            self._cancel_header_timer()

    def on_response_complete(self) -> None:
        """Stop the header timer: the keep-alive timer runs until the next byte."""
        self._cancel_header_timer()  # the keep-alive timer takes over until the next byte
        super().on_response_complete()

    def connection_lost(self, exc) -> None:
        """Stop the header timer and let uvicorn clean up."""
        self._cancel_header_timer()
        super().connection_lost(exc)

    def _arm_header_timer(self) -> None:
        self._cancel_header_timer()
        self._header_timer = self.loop.call_later(self.bounds()[0], self._header_timeout)

    def _cancel_header_timer(self) -> None:
        if self._header_timer is not None:
            self._header_timer.cancel()
            self._header_timer = None

    def _header_timeout(self) -> None:
        self._header_timer = None
        if not self.transport.is_closing() and self.conn.their_state is h11.IDLE:
            self.transport.close()
