"""Serving an app: :class:`ServerThread` runs uvicorn on a background thread (127.0.0.1 by default; HTTPS with a
certificate) and, when it stops, frees what :func:`~benchbot.core.server.routes.build_app` made (shared-memory
segments, worker threads)."""

from __future__ import annotations

import threading
import time
from typing import Any

import uvicorn

from benchbot.core.errors import BackendError


class ServerThread:
    """Serves an app with uvicorn on a background thread (127.0.0.1 by default).

    Args:
        app: the ASGI app.
        host: bind address.
        port: TCP port; 0 picks a free one (read :attr:`port` after :meth:`start`).
        tls_cert, tls_key: serve HTTPS with this PEM certificate chain and private key (the key may be in the
            certificate's file); plain HTTP when None.
        sock: a socket already bound to ``host:port`` (e.g. reserved before a long start-up, so that a taken port is
            said first); the server listens on it and closes it when it stops. None: bind ``host:port`` at start.

    Raises:
        BackendError: (from start) the server did not come up within 10 s, e.g. the port is taken.
    """

    def __init__(self, app: Any, host: str = "127.0.0.1", port: int = 0, *, tls_cert: Any = None,
                 tls_key: Any = None, sock: Any = None) -> None:
        self.host = host
        self.app = app
        self.scheme = "https" if tls_cert else "http"
        tls = {"ssl_certfile": str(tls_cert), "ssl_keyfile": str(tls_key) if tls_key else None} if tls_cert else {}
        self.server = uvicorn.Server(
            uvicorn.Config(app, host=host, port=port, log_level="warning", lifespan="off", access_log=False, **tls)
        )
        self.thread = threading.Thread(target=self.server.run, kwargs={"sockets": [sock]} if sock else {},
                                       name="benchbot-http", daemon=True)
        self.port = port

    def start(self) -> "ServerThread":
        """Start serving and wait until the socket listens (at most 10 s); returns self.

        Raises:
            BackendError: the server did not come up (e.g. the port is taken).
        """
        self.thread.start()
        deadline = time.monotonic() + 10.0
        while not self.server.started:
            if not self.thread.is_alive() or time.monotonic() > deadline:
                raise BackendError(
                    f"the backend server could not listen on {self.host}:{self.port}", "choose another --port"
                )
            time.sleep(0.01)
        self.port = self.server.servers[0].sockets[0].getsockname()[1]
        return self

    @property
    def address(self) -> str:
        """``http://host:port/`` (``https://`` when serving TLS)."""
        return f"{self.scheme}://{self.host}:{self.port}/"

    def stop(self) -> None:
        """Stop serving and wait for the thread."""
        self.server.should_exit = True
        self.thread.join(timeout=10)
        segments = getattr(self.app, "segments", None)
        if segments is not None:
            segments.close()
        for executor in getattr(self.app, "executors", ()):
            executor.shutdown(wait=False, cancel_futures=True)
