"""ASGI middleware bounding every request body in size and in time.

* A ``Content-Length`` above ``max_body`` is answered ``413`` at once, before
  a byte of the body is read.
* Otherwise (and for chunked bodies, which have no length) the body is read
  here, counting bytes as they stream in: past ``max_body`` the answer is
  ``413``; if the whole body has not arrived ``body_timeout`` seconds after
  the headers (a client that announces more than it sends, or trickles) the
  answer is ``408``. Both close the connection.
* The complete body (at most ``max_body`` bytes) is then handed to the
  application as one message, so no parser ever sees an oversized body.

Requests that announce no body (``Content-Length: 0`` or none, not chunked;
every ``GET``) pass straight through at no cost.
"""

from __future__ import annotations

import asyncio
import json
import sys

_CLOSE_HEADERS = [(b"content-type", b"application/json"), (b"connection", b"close")]


async def send_error(send, status: int, msg: str, kind: str) -> None:
    """Send a complete JSON error answer and ask the server to close the connection."""
    body = json.dumps({"detail": [{"loc": ["body"], "msg": msg, "type": kind}]}).encode()
    headers = _CLOSE_HEADERS + [(b"content-length", str(len(body)).encode())]
    await send({"type": "http.response.start", "status": status, "headers": headers})
    await send({"type": "http.response.body", "body": body, "more_body": False})


class BodyTimeout(Exception):
    """A request body did not arrive within ``body_timeout`` seconds."""

    pass


if sys.version_info >= (3, 11):
    def _timeout_at(when: float):
        return asyncio.timeout_at(when)
else:  # pragma: no cover - Python 3.10
    class _timeout_at:
        """Cancel the current task at loop time ``when`` (a minimal ``asyncio.timeout_at``)."""

        def __init__(self, when: float):
            self.when = when

        async def __aenter__(self):
            task = asyncio.current_task()
            self.expired = False

            def fire():
                self.expired = True
                task.cancel()

            self.handle = asyncio.get_running_loop().call_at(self.when, fire)

        async def __aexit__(self, exc_type, exc, tb):
            self.handle.cancel()
            if self.expired and exc_type is asyncio.CancelledError:
                raise TimeoutError from None
            return False


class BodyLimitMiddleware:
    """Reject bodies over ``max_body`` bytes (413) or slower than ``body_timeout`` seconds (408)."""

    def __init__(self, app, max_body: int, body_timeout: float):
        self.app = app
        self.max_body = int(max_body)
        self.body_timeout = float(body_timeout)

    async def __call__(self, scope, receive, send):
        """ASGI entry point: pass HTTP requests on with their body bounded (see the class)."""
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        length = None
        chunked = False
        for name, value in scope["headers"]:
            if name == b"content-length":
                try:
                    length = int(value)
                except ValueError:
                    length = -1
            elif name == b"transfer-encoding" and b"chunked" in value.lower():
                chunked = True
        if not chunked and not length:  # no body announced (None or 0)
            return await self.app(scope, receive, send)
        if length is not None and length > self.max_body:
            return await send_error(send, 413,
                                    f"request body of {length} bytes exceeds the limit of {self.max_body} "
                                    "bytes", "body_too_large")
        try:
            body = await self._read_body(receive)
        except BodyTimeout:
            return await send_error(send, 408,
                                    f"the request body did not arrive within {self.body_timeout:g} s",
                                    "body_timeout")
        except OverflowError:
            return await send_error(send, 413, f"request body exceeds the limit of {self.max_body} bytes",
                                    "body_too_large")
        if body is None:  # the client went away
            return None
        replayed = False

        async def replay():
            nonlocal replayed
            if not replayed:
                replayed = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()

        return await self.app(scope, replay, send)

    async def _read_body(self, receive) -> bytes | None:
        """The whole body, or None on disconnect; OverflowError past ``max_body``, BodyTimeout when late."""
        chunks = []
        size = 0
        loop = asyncio.get_running_loop()
        try:
            async with _timeout_at(loop.time() + self.body_timeout):
                while True:
                    message = await receive()
                    if message["type"] == "http.disconnect":
                        return None
                    chunk = message.get("body", b"")
                    size += len(chunk)
                    if size > self.max_body:
                        raise OverflowError
                    chunks.append(chunk)
                    if not message.get("more_body", False):
                        break
        except TimeoutError:
            raise BodyTimeout from None
        return chunks[0] if len(chunks) == 1 else b"".join(chunks)
