"""The ASGI middleware around the app, outermost first: :class:`MergeSlashes` (``//`` counts as ``/``),
:class:`TokenGuard` (401 without the token; only when the server has one) and :class:`BodyLimit` (413 past
:data:`~benchbot.core.limits.MAX_REQUEST_BYTES`). :func:`~benchbot.server.routes.build_app` stacks them.
Each passes the wrapped app's ``state`` on."""

from __future__ import annotations

import hmac
from typing import Any, Callable

from benchbot.core import limits
from benchbot.protocol import wire
from benchbot.server.http_errors import PayloadTooLargeError, error_response

TOKEN_HEADER = wire.TOKEN_HEADER.lower()  # as ASGI gives header names


class BodyLimit:
    """ASGI middleware: a request body past ``max_bytes`` is answered 413 — at once when ``Content-Length`` says so
    (nothing of the body is read), else as soon as the bytes received pass the bound. The app gets the body in one
    piece.

    Args:
        app: the ASGI app. max_bytes: the bound (:data:`~benchbot.core.limits.MAX_REQUEST_BYTES`).
    """

    def __init__(self, app: Any, max_bytes: int) -> None:
        self.app, self.max_bytes = app, max_bytes
        self.state = getattr(app, "state", None)

    async def _refuse(self, scope: dict, receive: Callable, send: Callable, size: str) -> None:
        response = error_response(413, PayloadTooLargeError(
            f"request body of {size} bytes is past the limit of {self.max_bytes} bytes",
            f"send less; ${limits.MAX_REQUEST_BYTES.env} on the backend raises the limit"))
        response.headers["connection"] = "close"
        await response(scope, receive, send)

    async def __call__(self, scope: dict, receive: Callable, send: Callable) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        declared = dict(scope.get("headers") or []).get(b"content-length")
        if declared is not None:
            try:
                length = int(declared)
            except ValueError:
                length = -1
            if length < 0:
                response = error_response(400, "Content-Length is not a whole number of bytes",
                                          "send a valid request")
                await response(scope, receive, send)
                return
            if length > self.max_bytes:
                await self._refuse(scope, receive, send, str(length))
                return
        chunks: list[bytes] = []
        size = 0
        while True:
            message = await receive()
            if message["type"] == "http.disconnect":
                return
            chunk = message.get("body", b"")
            size += len(chunk)
            if size > self.max_bytes:
                await self._refuse(scope, receive, send, f"more than {self.max_bytes}")
                return
            chunks.append(chunk)
            if not message.get("more_body", False):
                break
        body = b"".join(chunks)
        delivered = False

        async def replay() -> dict:
            nonlocal delivered
            if not delivered:
                delivered = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()

        await self.app(scope, replay, send)


class MergeSlashes:
    """ASGI middleware: ``//`` in a path counts as ``/``, as in the original's Flask (Werkzeug merges slashes);
    the original client asks for ``//`` and ``results_functions//create``."""

    def __init__(self, app: Any) -> None:
        self.app = app
        self.state = getattr(app, "state", None)

    async def __call__(self, scope: dict, receive: Callable, send: Callable) -> None:
        if scope["type"] == "http" and "//" in scope.get("path", ""):
            path = scope["path"]
            while "//" in path:
                path = path.replace("//", "/")
            scope = dict(scope, path=path, raw_path=path.encode("utf-8", "surrogateescape"))
        await self.app(scope, receive, send)


class TokenGuard:
    """ASGI middleware: 401 unless the request carries ``token`` (``X-BenchBot-Token: <token>`` or
    ``Authorization: Bearer <token>``); compared in constant time."""

    def __init__(self, app: Any, token: str) -> None:
        self.app, self.token = app, token.encode()
        self.state = getattr(app, "state", None)

    async def __call__(self, scope: dict, receive: Callable, send: Callable) -> None:
        if scope["type"] == "http":
            headers = dict(scope.get("headers") or [])
            given = headers.get(TOKEN_HEADER.encode(), b"")
            auth = headers.get(b"authorization", b"")
            if not given and auth.lower().startswith(b"bearer "):
                given = auth[7:].strip()
            if not hmac.compare_digest(given, self.token):
                response = error_response(401, "missing or wrong BenchBot token",
                                          "set BENCHBOT_TOKEN to the token `benchbot run` printed")
                await response(scope, receive, send)
                return
        await self.app(scope, receive, send)
