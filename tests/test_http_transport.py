"""HttpTransport, the client's one HTTP stack (http.client), against small standard-library servers: one kept-alive
connection per thread for every route, the one error decoder, the retry of a connection closed while idle (and
no other), timeouts, event hooks, close. No simulator: the tests with the real backend are test_server_api.py,
test_shared_frames.py and test_security_server.py."""

from __future__ import annotations

import http.server
import json
import threading
import time

import pytest

from benchbot.api.benchbot import HttpRequest, HttpResponse, HttpTransport, _refusal, _reply_refusal
from benchbot.protocol import wire


class Backend(http.server.ThreadingHTTPServer):
    """Replies to ``native/step`` with a MessagePack step and to every other route with ``{"route": ...}``;
    ``replies`` overrides a route's reply ``(status, content type, body)``. Counts connections and requests."""

    daemon_threads = True

    def __init__(self, close_after_reply: bool = False, drop_without_reply: bool = False) -> None:
        self.connections, self.requests = 0, []
        self.replies: dict[str, tuple[int, str, bytes]] = {}
        self.close_after_reply, self.drop_without_reply = close_after_reply, drop_without_reply
        self.delay_s = 0.0
        super().__init__(("127.0.0.1", 0), Handler)
        threading.Thread(target=self.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True).start()

    def handle_error(self, request, client_address) -> None:
        pass  # a client that timed out has gone: its reply meets a broken pipe

    @property
    def address(self) -> str:
        return f"http://127.0.0.1:{self.server_address[1]}/"


class Handler(http.server.BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"  # keep-alive

    def setup(self) -> None:
        super().setup()
        self.server.connections += 1

    def log_message(self, *args) -> None:
        pass

    def _reply(self) -> None:
        server: Backend = self.server
        body = self.rfile.read(int(self.headers.get("content-length", 0)))
        server.requests.append((self.command, self.path, dict(self.headers), body))
        if server.drop_without_reply:
            self.close_connection = True
            return
        time.sleep(server.delay_s)
        route = self.path.lstrip("/")
        if route in server.replies:
            status, kind, content = server.replies[route]
        elif route == "native/step":
            status, kind = 200, wire.MSGPACK_TYPE
            content = wire.pack({"result": "SUCCESS", "observations": {}, "state": {"step": len(server.requests)}})
        else:
            status, kind, content = 200, "application/json", json.dumps({"route": route}).encode()
        self.send_response(status)
        self.send_header("content-type", kind)
        self.send_header("content-length", str(len(content)))
        self.end_headers()
        self.wfile.write(content)
        # closed as a backend closes an idle kept-alive connection: without saying so in the reply
        self.close_connection = server.close_after_reply

    do_GET = do_POST = _reply


@pytest.fixture
def backend():
    servers = []

    def make(**kwargs) -> Backend:
        servers.append(Backend(**kwargs))
        return servers[-1]

    yield make
    for server in servers:
        server.shutdown()
        server.server_close()


def test_refusals_are_decoded_in_one_place():
    refused = _reply_refusal("native/step", 409, json.dumps({"error": "not now", "hint": "reset"}).encode())
    assert isinstance(refused, ValueError) and str(refused) == "not now (reset)"
    failed = _reply_refusal("robot/reset", 500, json.dumps({"error": "broke", "hint": ""}).encode())
    assert isinstance(failed, ConnectionError) and str(failed) == "BenchBot backend refused /robot/reset (500): broke"
    raw = _reply_refusal("config/", 502, b"<html>bad gateway</html>" + b"x" * 300)
    assert str(raw) == "BenchBot backend refused /config/ (502): <html>bad gateway</html>" + "x" * 176
    assert str(_reply_refusal("x", 400, b"[1, 2]")) == "BenchBot backend refused /x (400): [1, 2]"
    assert str(_refusal("x", 404, "unknown route")) == "BenchBot backend refused /x (404): unknown route"


def test_every_route_shares_one_kept_alive_connection_per_thread(backend):
    server = backend()
    seen: list = []
    transport = HttpTransport(server.address, token="t0k3n", shared_memory=False,
                              event_hooks={"request": [seen.append], "response": [seen.append]})
    assert transport.ping()
    assert transport.get("config/") == {"route": "config/"}
    assert transport.step(None, {}, None)["result"] == "SUCCESS"
    assert transport.get("robot/state", {"a": 1}) == {"route": "robot/state"}
    assert server.connections == 1, "ping, JSON routes and the native step on one connection"
    method, path, headers, body = server.requests[3]
    assert (method, path, json.loads(body)) == ("POST", "/robot/state", {"a": 1})
    assert headers["X-BenchBot-Token"] == "t0k3n" and headers["X-BenchBot-Client"] == transport.client_id
    assert server.requests[2][2]["content-type"] == wire.MSGPACK_TYPE
    requests = [s for s in seen if isinstance(s, HttpRequest)]
    responses = [s for s in seen if isinstance(s, HttpResponse)]
    assert [r.url for r in requests] == [server.address + r for r in ("", "config/", "native/step", "robot/state")]
    assert [r.status_code for r in responses] == [200] * 4 and responses[2].request is requests[2]
    other = threading.Thread(target=transport.get, args=("config/",))
    other.start()
    other.join()
    assert server.connections == 2, "another thread, its own connection"
    transport.headers["X-BenchBot-Client"] = "c" * 32  # what test_security_server does to name a client
    transport.get("config/")
    assert server.requests[-1][2]["X-BenchBot-Client"] == "c" * 32
    transport.close()
    assert server.requests[-1][:2] == ("POST", "/robot/release") and len(transport._connections) == 0
    with pytest.raises(ConnectionError, match="was closed"):
        transport.get("config/")


def test_errors_keep_their_types_and_messages(backend):
    server = backend()
    transport = HttpTransport(server.address, shared_memory=False)
    server.replies["native/step"] = (409, "application/json", b'{"error": "not an action", "hint": "see actions"}')
    with pytest.raises(ValueError, match=r"^not an action \(see actions\)$"):
        transport.step("fly", {}, None)
    server.replies["robot/reset"] = (500, "application/json", b'{"error": "the simulator failed", "hint": ""}')
    with pytest.raises(ConnectionError, match=r"^BenchBot backend refused /robot/reset \(500\): the simulator failed$"):
        transport.get("robot/reset")
    server.replies["config/"] = (200, "application/json", b"{not json")
    with pytest.raises(ConnectionError, match="sent a malformed /config/ reply"):
        transport.get("config/")
    server.replies["native/step"] = (200, wire.MSGPACK_TYPE, b"\xc1")
    with pytest.raises(ConnectionError, match="sent a malformed /native/step reply"):
        transport.step(None, {}, None)
    assert server.connections == 1, "a refusal keeps the connection"
    server.replies[""] = (503, "text/plain", b"busy")
    assert transport.ping() is False, "only a success is an answer"
    transport.close()
    assert HttpTransport("http://127.0.0.1:9/").ping() is False
    with pytest.raises(ConnectionError, match=r"failed on /native/step: ConnectionRefusedError"):
        HttpTransport("http://127.0.0.1:9/", shared_memory=False).step(None, {}, None)


def test_a_connection_closed_while_idle_is_replaced_and_the_request_sent_once(backend):
    server = backend(close_after_reply=True)
    transport = HttpTransport(server.address, shared_memory=False)
    for i in range(3):
        assert transport.step("move_next", {}, None)["state"]["step"] == i + 1
        time.sleep(0.05)  # the server has closed the connection by the next step
    assert server.connections == 3 and len(server.requests) == 3, "each request reached the backend once"
    transport.close()


def test_a_request_failing_on_a_fresh_connection_is_never_sent_again(backend):
    server = backend(drop_without_reply=True)
    transport = HttpTransport(server.address, shared_memory=False)
    with pytest.raises(ConnectionError, match=r"failed on /native/step: RemoteDisconnected"):
        transport.step("move_next", {}, None)
    assert len(server.requests) == 1, "an action cannot run twice"


def test_a_request_past_its_timeout_fails(backend):
    server = backend()
    transport = HttpTransport(server.address, timeout_s=0.3, shared_memory=False)
    assert transport.get("config/") == {"route": "config/"}
    server.delay_s = 1.0
    t0 = time.monotonic()
    with pytest.raises(ConnectionError, match="failed on /robot/state: TimeoutError"):
        transport.get("robot/state")
    assert time.monotonic() - t0 < 0.9
    server.delay_s = 0.0
    assert transport.get("config/") == {"route": "config/"}, "a new connection after the timed-out one"
    transport.close()


def test_close_closes_every_threads_connection(backend):
    server = backend()
    transport = HttpTransport(server.address, shared_memory=False)
    opened, done = threading.Event(), threading.Event()
    theirs = []

    def worker() -> None:
        transport.get("config/")
        theirs.append(transport._local.conn)
        opened.set()
        done.wait(10)

    other = threading.Thread(target=worker)
    other.start()
    assert opened.wait(10)
    transport.get("config/")
    assert server.connections == 2 and len(transport._connections) == 2
    transport.close()
    assert theirs[0].sock is None, "the living thread's connection is closed too"
    done.set()
    other.join()
