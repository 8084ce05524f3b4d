"""ServerThread: serving an app on a background thread, and stopping it."""

from __future__ import annotations

import http.client
import socket
import time

import uvicorn

from benchbot.server.server_thread import ServerThread


def test_a_server_thread_stops_at_once_when_its_clients_are_gone_and_as_uvicorn_does_otherwise(monkeypatch):
    """``ServerThread.stop`` wakes uvicorn's loop and, with no connection left, shuts down without uvicorn's pause
    (its ``shutdown`` is not called); a connection still open is shut down by uvicorn's own path. Either way the
    thread has ended and nothing listens any more."""
    calls = []
    real = uvicorn.Server.shutdown

    async def counted(self, sockets=None):
        calls.append(len(self.server_state.connections))
        await real(self, sockets=sockets)

    monkeypatch.setattr(uvicorn.Server, "shutdown", counted)

    async def app(scope, receive, send):
        await send({"type": "http.response.start", "status": 200, "headers": []})
        await send({"type": "http.response.body", "body": b"ok"})

    for keep_open in (False, True):
        server = ServerThread(app).start()
        conn = http.client.HTTPConnection("127.0.0.1", server.port, timeout=5)
        conn.request("GET", "/")
        assert conn.getresponse().read() == b"ok"
        if not keep_open:
            conn.close()
            for _ in range(200):  # until uvicorn has seen the connection go
                if not server.server.server_state.connections:
                    break
                time.sleep(0.01)
        server.stop()
        assert not server.thread.is_alive()
        with socket.socket() as probe:
            assert probe.connect_ex(("127.0.0.1", server.port)) != 0
        conn.close()
    assert calls == [1]  # only the server with an open connection went through uvicorn's shutdown
