"""Serving an app: :class:`ServerThread` runs uvicorn on a background thread (127.0.0.1 by default; HTTPS with a
certificate) and, when it stops, frees what :func:`~benchbot.server.routes.build_app` made (shared-memory
segments, worker threads)."""

from __future__ import annotations

import asyncio
import os
import socket
import threading
import time
from typing import Any

import uvicorn

from benchbot.core.errors import BackendError


def _bind_unix(path: str) -> socket.socket:
    """A stream socket bound to the Unix socket ``path`` (only this user may connect: mode 0600)."""
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        listener.bind(path)
        os.chmod(path, 0o600)
    except OSError:
        listener.close()
        raise
    return listener


class _PromptServer(uvicorn.Server):
    """uvicorn's server, stopped without its fixed pauses: uvicorn looks for ``should_exit`` every 0.1 s and then
    pauses 0.1 s more for its connections to close, 0.15 s in all, which every episode's end paid (the simulator
    service stops an episode's server before it reports the episode finished). :meth:`request_exit` wakes the main
    loop at once, and a server left with no connection and no task shuts down without the pause; one that still has
    some shuts down exactly as uvicorn does."""

    _wake: asyncio.Event | None = None
    _loop: asyncio.AbstractEventLoop | None = None

    async def main_loop(self) -> None:
        """uvicorn's loop (:meth:`on_tick` every 0.1 s until it says to exit), woken early by :meth:`request_exit`."""
        self._loop, self._wake = asyncio.get_running_loop(), asyncio.Event()
        counter = 0
        should_exit = await self.on_tick(counter)
        while not should_exit:
            counter = (counter + 1) % 864000
            try:
                await asyncio.wait_for(self._wake.wait(), 0.1)
            except asyncio.TimeoutError:
                pass
            should_exit = await self.on_tick(counter)

    def request_exit(self) -> None:
        """Ask the server to stop (from any thread), waking its loop."""
        self.should_exit = True
        loop, wake = self._loop, self._wake
        if loop is not None and wake is not None:
            try:
                loop.call_soon_threadsafe(wake.set)
            except RuntimeError:  # the loop has closed: the server has stopped already
                pass

    async def shutdown(self, sockets: list[socket.socket] | None = None) -> None:
        """uvicorn's shutdown; without its 0.1 s pause when no connection and no task is left to wait for."""
        if self.server_state.connections or self.server_state.tasks:
            await super().shutdown(sockets=sockets)
            return
        for server in self.servers:
            server.close()
        for sock in sockets or []:
            sock.close()
        for server in self.servers:
            await server.wait_closed()
        if not self.force_exit:
            await self.lifespan.shutdown()


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
        unix_socket: also serve on a Unix socket made at this path (a sandboxed solution's way in:
            :mod:`benchbot.solutions.sandbox`); its requests have no client address, and their shared-memory
            segments are made in the socket's episode folder (:func:`benchbot.protocol.shared_frames.episode_folder`,
            removed by :meth:`stop`).

    Raises:
        BackendError: (from start) the server did not come up within 10 s, e.g. the port is taken.
    """

    def __init__(self, app: Any, host: str = "127.0.0.1", port: int = 0, *, tls_cert: Any = None,
                 tls_key: Any = None, sock: Any = None, unix_socket: Any = None) -> None:
        self.host = host
        self.app = app
        self.scheme = "https" if tls_cert else "http"
        tls = {"ssl_certfile": str(tls_cert), "ssl_keyfile": str(tls_key) if tls_key else None} if tls_cert else {}
        config = uvicorn.Config(app, host=host, port=port, log_level="warning", lifespan="off", access_log=False,
                                **tls)
        self.server = _PromptServer(config)
        self.port = port
        sockets = [sock] if sock else []
        if unix_socket is not None:
            segments = getattr(app, "segments", None)
            if segments is not None:  # its clients' frames in the episode's folder (shared_frames.episode_folder)
                segments.serve_socket(unix_socket)
            try:
                sockets = [sock or config.bind_socket(), _bind_unix(str(unix_socket))]
            except (OSError, SystemExit) as exc:  # uvicorn's bind_socket exits when the port is taken
                if segments is not None:
                    segments.close()  # the episode's folder goes too
                raise BackendError(f"the backend server could not listen on {host}:{port} and {unix_socket}: "
                                   f"{exc}", "choose another --port") from None
        self.thread = threading.Thread(target=self.server.run, kwargs={"sockets": sockets} if sockets else {},
                                       name="benchbot-http", daemon=True)

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
        self.port = self.server.servers[0].sockets[0].getsockname()[1]  # the TCP socket comes first
        return self

    @property
    def address(self) -> str:
        """``http://host:port/`` (``https://`` when serving TLS)."""
        return f"{self.scheme}://{self.host}:{self.port}/"

    def stop(self) -> None:
        """Stop serving and wait for the thread."""
        self.server.request_exit()
        self.thread.join(timeout=10)
        segments = getattr(self.app, "segments", None)
        if segments is not None:
            segments.close()
        for executor in getattr(self.app, "executors", ()):
            executor.shutdown(wait=False, cancel_futures=True)
