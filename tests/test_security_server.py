"""Security of the backend server on 127.0.0.1 (server side): no ground truth through the API, one client
per episode, bounded requests, bounded motions, the camera-size flag, the loopback check."""

from __future__ import annotations

import math
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import httpx
import numpy as np
import pytest

from benchbot.api import ActionResult, BenchBot
from benchbot.api.benchbot import HttpTransport
from benchbot.core import limits
from benchbot.protocol import wire
from benchbot.core.episode import ActionArgumentError, served_environment
from benchbot.core.motion import PoseController
from benchbot.server import CLIENT_HEADER, EpisodeInUseError, EpisodeOwnership, ServerThread, build_app
from benchbot.protocol.shared_frames import is_loopback

PASSIVE = "semantic_slam:passive:ground_truth"
ACTIVE = "semantic_slam:active:ground_truth"


@pytest.fixture
def serve(make_service):
    """``serve(task, env, **build_app_kwargs)`` → (service, server) on 127.0.0.1; stopped after."""
    servers = []

    def start(task: str, env: str, **kwargs):
        service = make_service(task, env)
        server = ServerThread(build_app(service, **kwargs)).start()
        servers.append(server)
        return service, server

    yield start
    for server in servers:
        server.stop()


# ------------------------------------------------------------------------------------------------ 1. ground truth
class GroundTruth:
    """What must never be served for one environment: its ground-truth files, object ids, centroids and extents."""

    def __init__(self, registry, env_name: str, env_spec: dict):
        gt = registry.ground_truth(env_name)
        entry = registry.entries["ground_truths"][env_name]
        self.paths = {p for p in (env_spec.get("map_path"), env_spec.get("_file_path"), entry.path,
                                  entry.spec.get("_file_path")) if p}
        self.ids = {o["ID_name"] for o in gt["ground_truth"]["objects"]}
        self.numbers = {float(v) for o in gt["ground_truth"]["objects"] for k in ("centroid", "extent") for v in o[k]}
        self.synonyms = set(gt["ground_truth"].get("synonyms", {}))

    def check_text(self, where: str, text: str) -> None:
        for path in self.paths:
            assert str(path) not in text, f"{where} names the ground-truth file {path}"
        for ident in self.ids:
            assert ident not in text, f"{where} names ground-truth object {ident}"
        for number in self.numbers:
            assert repr(number) not in text, f"{where} holds ground-truth coordinate {number!r}"

    def check_value(self, where: str, value, granted: set[str]) -> None:
        """Walk a decoded reply: no ground-truth number, no file holding ground truth, class lists ⊆ granted."""
        stack = [value]
        while stack:
            node = stack.pop()
            if isinstance(node, dict):
                stack += list(node.keys()) + list(node.values())
            elif isinstance(node, (list, tuple)):
                strings = [v for v in node if isinstance(v, str)]
                if strings and set(strings) & granted:
                    assert set(strings) <= granted, f"{where} lists classes not granted: {set(strings) - granted}"
                stack += list(node)
            elif isinstance(node, np.ndarray):
                if node.size <= 64 and node.dtype.kind == "f":
                    assert not (set(node.ravel().tolist()) & self.numbers), f"{where} holds a ground-truth number"
            elif isinstance(node, float):
                assert node not in self.numbers, f"{where} holds ground-truth coordinate {node!r}"
            elif isinstance(node, str):
                assert node not in self.synonyms or node in granted, f"{where} serves ground-truth synonym {node!r}"
                if len(node) < 4096 and os.path.isfile(node):
                    content = Path(node).read_text(errors="replace")
                    assert not any(i in content for i in self.ids), f"{where} names {node}, which holds ground truth"


def test_nothing_served_names_or_holds_ground_truth(serve, registry):
    service, server = serve(PASSIVE, "miniroom:1")
    env = service.episode.environments[0]
    gt = GroundTruth(registry, "miniroom:1", env)
    assert any(Path(p).is_file() for p in gt.paths)  # the check has something to find
    # a content pack's environment may hold its objects (mesh paths and poses) and its file's path: served while
    # the config is walked (a copy: the registry's spec stays as it is)
    service.episode.environments[0] = dict(env, _file_path=env["map_path"], objects=[
        {"mesh": env["map_path"], "class": "clock", "pose": [2.10723343, -0.7452272000000001, 0.9, 0]}])
    seen: list[str] = []
    http = httpx.Client(base_url=server.address, timeout=60)

    def get(path: str, method: str = "GET", **kwargs) -> httpx.Response:
        reply = http.request(method, path, **kwargs)
        seen.append(path)
        gt.check_text(f"{method} {path} ({reply.status_code})", reply.text if "msgpack" not in
                      reply.headers.get("content-type", "") else "")
        return reply

    granted = set(get("/results_functions/create", "POST", json={}).json()["class_list"])
    assert "chair" in granted

    def walk_config(prefix: str, node) -> None:
        reply = get(f"/config/{prefix}")
        assert reply.status_code == 200
        gt.check_value(f"/config/{prefix}", reply.json(), granted)
        if isinstance(node, dict):
            for key, value in node.items():
                walk_config(f"{prefix}{key}/", value)

    config = get("/config/").json()
    walk_config("", config)
    assert len(seen) > 40
    served_env = config["environments"][0]
    assert "objects" not in served_env and "_file_path" not in served_env
    assert served_env["map_path"] == "miniroom:1" and served_env["object_labels"]
    assert served_env["trajectory_poses"] == env["trajectory_poses"]  # what the original served is still served

    service.episode.environments[0] = env
    for name in ("create", "create_object", "validate"):
        body = {"args": [{"objects": [], "class_list": sorted(granted)}]} if name == "validate" else {}
        gt.check_value(name, get(f"/results_functions/{name}", "POST", json=body).json(), granted)
    gt.check_value("names", get("/results_functions/").json(), granted)
    for connection in config["robot"]["connections"]:
        reply = get(f"/connections/{connection}", "POST", json={})
        assert reply.status_code in (200, 404, 409), (connection, reply.text)
    for command in ("", "is_collided", "is_dirty", "is_finished", "is_running", "selected_environment", "state",
                    "run_info", "next", "restart", "reset", "stop", "release"):
        gt.check_value(command, get(f"/robot/{command}").json(), granted)
    get("/robot/reset")
    step = http.post("/native/step", content=wire.pack({"action": "move_next", "args": {}}),
                     headers={"content-type": wire.MSGPACK_TYPE})
    assert step.status_code == 200
    gt.check_value("native step", wire.unpack(step.content), granted)
    # error bodies: unknown key/command/connection, bad body, refused action, too large, and a backend failure
    # whose message holds the ground-truth file's path
    for path, method, kwargs in [("/config/environments/nope", "GET", {}), ("/robot/nope", "GET", {}),
                                 ("/connections/nope", "GET", {}), ("/connections/move_next", "POST",
                                                                    {"content": b"{bad"}),
                                 ("/connections/move_angle", "POST", {"json": {"angle": 3}}),
                                 ("/results_functions/validate", "POST", {"json": {"args": [{"objects": 3}]}}),
                                 ("/native/step", "POST", {"content": b"\xc1"}),
                                 ("/native/step", "POST", {"content": b"x" * (1 << 20) + b"x"})]:
        assert 400 <= get(path, method, **kwargs).status_code < 500
    backend = service.episode.backend
    original = backend.move_to

    def failing_move(goal):
        raise OSError(f"cannot read {env['map_path']}")

    backend.move_to = failing_move
    try:
        failed = get("/connections/move_next", "POST", json={})
    finally:
        backend.move_to = original
    assert failed.status_code == 500 and "<hidden>" in failed.json()["error"]
    http.close()


def test_served_environment_keeps_only_the_originals_fields():
    env = {"name": "room", "variant": 2, "type": "sim_taichi", "map_path": "/data/room_2.json",
           "start_pose": [1, 0, 0, 0, 0, 0, 0], "objects": [{"mesh": "chair.obj"}], "_file_path": "/packs/e.yaml",
           "secret_field_of_a_plugin": 1, "object_labels": ["chair"]}
    assert served_environment(env) == {"name": "room", "variant": 2, "type": "sim_taichi", "map_path": "room:2",
                                       "start_pose": [1, 0, 0, 0, 0, 0, 0], "object_labels": ["chair"]}


# ------------------------------------------------------------------------------------------------ 2. one client
def _client(address: str, client_id: str | None) -> BenchBot:
    """The real client, naming itself with ``X-BenchBot-Client`` when ``client_id`` is given."""
    transport = HttpTransport(address, 60.0)
    if client_id is not None:
        transport.headers["X-BenchBot-Client"] = client_id
    return BenchBot(transport=transport)


def test_a_second_client_is_refused_and_never_resets_the_first(serve):
    service, server = serve(PASSIVE, "miniroom:1")
    first = _client(server.address, "a" * 32)
    first.step("move_next")
    first.step("move_next")
    with pytest.raises(ValueError, match="the episode belongs to another client"):
        _client(server.address, "b" * 32)  # its start (robot/reset) is refused
    raw = httpx.post(server.address + "native/step", content=wire.pack({"action": "move_next", "args": {}}),
                     headers={"content-type": wire.MSGPACK_TYPE, CLIENT_HEADER: "c" * 32})
    assert raw.status_code == 409 and "another client" in raw.json()["error"] and "\n" not in raw.json()["error"]
    for path in ("robot/reset", "robot/is_running", "connections/move_next", "connections/image_rgb"):
        assert httpx.post(server.address + path, json={}, headers={CLIENT_HEADER: "c" * 32}).status_code == 409
    # reading the state and the config stays open to anyone
    state = httpx.get(server.address + "robot/state", headers={CLIENT_HEADER: "c" * 32}).json()
    assert state["step"] == 2 and httpx.get(server.address + "config/task/name").status_code == 200
    # the first client's episode went on where it was: pose 3 of the trajectory, step 3
    _, result = first.step("move_next")
    assert service.episode.trajectory_next == 3 and first._state["step"] == 3 and first._state["is_dirty"]
    # once it releases the episode, the next client starts a fresh one
    assert httpx.post(server.address + "robot/release", headers={CLIENT_HEADER: "a" * 32}).json() == \
        {"release_success": True}
    second = _client(server.address, "b" * 32)
    assert second._state["step"] == 3 and service.episode.trajectory_next is None
    # and the first now gets the refusal, not someone else's episode
    with pytest.raises(ValueError, match="belongs to another client"):
        first.step("move_next")
    first.close()
    second.close()
    # a malformed client name is a 400
    assert httpx.get(server.address + "robot/state", headers={CLIENT_HEADER: "x"}).status_code == 400


def test_an_idle_owner_loses_the_episode_and_is_told_so(serve):
    service, server = serve(PASSIVE, "miniroom:1", lease_s=1.0)
    first = _client(server.address, "a" * 32)
    first.step("move_next")
    time.sleep(1.2)
    second = _client(server.address, "b" * 32)  # the lease ran out: it takes the episode (and resets it)
    second.step("move_next")
    with pytest.raises(ValueError, match="handed to another client after yours sent no request for 1 s"):
        first.step("move_next")
    first.close()
    second.close()


def test_ownership_rules_with_a_clock():
    now = [0.0]
    owner = EpisodeOwnership(10.0, clock=lambda: now[0])
    owner.acquire("a")
    with pytest.raises(EpisodeInUseError, match="a request of it is running"):
        owner.acquire("b")  # a's request is still in flight
    owner.done("a")
    now[0] = 9.0
    with pytest.raises(EpisodeInUseError, match="at most 1 s"):
        owner.acquire("b")
    owner.touch("a")  # any request of the owner renews its lease
    now[0] = 18.0
    with pytest.raises(EpisodeInUseError):
        owner.acquire("b")
    now[0] = 19.5
    owner.acquire("b")
    owner.done("b")
    with pytest.raises(EpisodeInUseError, match="handed to another client"):
        owner.acquire("a")
    assert not owner.release("a") and owner.release("b") and owner.owner is None
    owner.acquire("a")  # free again: the next client takes it


# ------------------------------------------------------------------------------------------------ 3. bounded requests
def _raw_request(port: int, head: bytes, body: bytes = b"", wait_s: float = 5.0) -> tuple[bytes, float]:
    """Send ``head`` and ``body`` on a fresh socket; the reply's first bytes and the seconds it took."""
    started = time.monotonic()
    with socket.create_connection(("127.0.0.1", port), timeout=wait_s) as sock:
        sock.sendall(head + body)
        reply = b""
        try:
            while b"\r\n\r\n" not in reply:
                chunk = sock.recv(65536)
                if not chunk:
                    break
                reply += chunk
        except socket.timeout:
            pass
    return reply, time.monotonic() - started


def test_large_bodies_are_refused_before_they_are_read(serve, monkeypatch):
    monkeypatch.setenv("BENCHBOT_MAX_REQUEST_BYTES", "100000")
    _, server = serve(PASSIVE, "miniroom:1")
    head = (b"POST /results_functions/create HTTP/1.1\r\nHost: x\r\ncontent-type: application/json\r\n"
            b"Content-Length: 50000000\r\n\r\n")
    # 50 MB announced, 1 kB sent and the socket kept open: a reply at all means the server did not wait for the body
    reply, took = _raw_request(server.port, head, b"{" * 1000, wait_s=30.0)
    assert reply.startswith(b"HTTP/1.1 413"), (reply[:100], took)
    chunked = b"POST /native/step HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n"
    chunk = b"%x\r\n%s\r\n" % (32 * 1024, b"a" * 32 * 1024)
    reply, took = _raw_request(server.port, chunked, chunk * 5, wait_s=30.0)  # 160 kB, no length, never finished
    assert reply.startswith(b"HTTP/1.1 413"), (reply[:100], took)
    big = httpx.post(server.address + "robot/state", content=b" " * (limits.MAX_REQUEST_BYTES.value() + 1))
    assert big.status_code == 413 and "BENCHBOT_MAX_REQUEST_BYTES" in big.json()["hint"]
    assert httpx.post(server.address + "results_functions/create", content=b" " * 1000).status_code == 200


def test_counts_a_request_asks_for_are_bounded(serve):
    _, server = serve(PASSIVE, "miniroom:1")
    http = httpx.Client(base_url=server.address, timeout=30)
    reply = http.post("/results_functions/create_object", content=b'{"args": [100000000]}')  # 21 bytes of body
    assert reply.status_code == 400 and "past the limit of ±100000" in reply.json()["error"]
    for args in ([1e8], ["100000000"], [{"n": [10**400]}], ["9" * 5000]):
        assert http.post("/results_functions/create_object", json={"args": args}).status_code == 400
    assert http.post("/results_functions/create_object", json={"kwargs": {"num_classes": 1e8}}).status_code == 400
    assert len(http.post("/results_functions/create_object", json={"args": [40]}).json()["label_probs"]) == 40
    names = ["laser"] * (limits.MAX_OBSERVATION_NAMES.value() + 1)
    step = http.post("/native/step", content=wire.pack({"action": None, "observations": names}),
                     headers={"content-type": wire.MSGPACK_TYPE})
    assert step.status_code == 400 and "past the limit of 64" in step.json()["error"]
    ok = http.post("/native/step", content=wire.pack({"action": None, "observations": ["laser"] * 64}),
                   headers={"content-type": wire.MSGPACK_TYPE})
    assert ok.status_code == 200
    http.close()


@pytest.mark.slow
def test_results_functions_never_block_the_event_loop(serve, monkeypatch):
    monkeypatch.setenv("BENCHBOT_RESULTS_FUNCTION_TIMEOUT_S", "4")
    monkeypatch.setenv("BENCHBOT_MAX_RESULTS_REPLY_BYTES", "1000")
    service, server = serve(PASSIVE, "miniroom:1")
    release = threading.Event()
    service.results_functions["slow"] = lambda: release.wait(10) and None
    replies: dict = {}

    def call_slow() -> None:
        replies["slow"] = httpx.post(server.address + "results_functions/slow", json={}, timeout=30)

    caller = threading.Thread(target=call_slow)
    caller.start()
    time.sleep(0.2)
    # the server answers while the function runs: both replies come before the slow call's (no wall-clock bound,
    # which a loaded machine could break; the function holds its request for the whole 4 s timeout)
    assert httpx.get(server.address, timeout=5).status_code == 200
    assert httpx.get(server.address + "robot/state", timeout=5).status_code == 200
    assert "slow" not in replies
    caller.join(15)
    assert replies["slow"].status_code == 504 and "did not finish within 4 s" in replies["slow"].json()["error"]
    release.set()
    large = httpx.post(server.address + "results_functions/create_object", json={"args": [1000]}, timeout=10)
    assert large.status_code == 400 and "past the limit of 1000 bytes" in large.json()["error"]


# ------------------------------------------------------------------------------------------------ 4. camera size
@pytest.mark.slow
def test_an_absurd_camera_size_is_a_usage_error():
    proc = subprocess.run([sys.executable, "-m", "benchbot.cli", "run", "--env", "miniroom:1", "--port", "0",
                           "--no-tui", "--camera-size", "99999999x99999999"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    first = proc.stderr.strip().splitlines()
    assert "error: --camera-size '99999999x99999999': each side must be at most 8192 pixels" in first
    assert "Traceback" not in proc.stderr and "MemoryError" not in proc.stderr


# ------------------------------------------------------------------------------------------------ 5. motions
def test_non_finite_and_absurd_motions_are_400(serve):
    service, server = serve(ACTIVE, "miniroom:1")
    http = httpx.Client(base_url=server.address, timeout=60)
    huge = b'{"distance": ' + b"9" * 400 + b"}"
    for path, body in [("/connections/move_distance", huge),
                       ("/connections/move_distance", b'{"distance": 1e308}'),
                       ("/connections/move_distance", b'{"distance": -1e308}'),
                       ("/connections/move_distance", b'{"distance": 1e9}'),
                       ("/connections/move_distance", b'{"distance": 100.5}'),
                       ("/connections/move_distance", b'{"distance": "1"}'),
                       ("/connections/move_angle", b'{"angle": 361}'),
                       ("/connections/move_angle", b'{"angle": -1e300}')]:
        reply = http.post(path, content=body)
        assert reply.status_code == 400, (body, reply.status_code, reply.text)
        error = reply.json()["error"]
        assert "must be a finite number within ±" in error and "\n" not in error and len(error) < 160
    assert service.episode.step_count == 0
    native = http.post("/native/step", content=wire.pack({"action": "move_distance", "args": {"distance": 1e9}}),
                       headers={"content-type": wire.MSGPACK_TYPE})
    assert native.status_code == 400 and "BENCHBOT_MAX_MOVE_DISTANCE_M" in native.json()["hint"]
    assert http.post("/connections/move_angle", json={"angle": 360}).status_code == 200
    assert http.post("/connections/move_distance", json={"distance": 0.1}).status_code == 200
    http.close()


def test_motion_bounds_in_the_episode_and_controller(make_service, monkeypatch):
    service = make_service(ACTIVE, "miniroom:1")
    episode = service.episode
    monkeypatch.setenv("BENCHBOT_MAX_MOVE_ANGLE_DEG", "10")
    with pytest.raises(ActionArgumentError, match=r"within ±10 degrees"):
        service.call(episode.act, "move_angle", {"angle": 11})
    assert service.call(episode.act, "move_angle", {"angle": 10}) == "SUCCESS"
    for goal in ([math.nan, 0, 0], [0, math.inf, 0], [0, 0]):
        with pytest.raises(ValueError, match="3 finite numbers"):
            PoseController(np.array(goal, dtype=float))


# ------------------------------------------------------------------------------------------------ 6. loopback
@pytest.mark.parametrize("host, expected", [
    ("127.0.0.1", True), ("127.8.9.10", True), ("::1", True), ("[::1]", True), ("::ffff:127.0.0.1", True),
    ("localhost", True), ("LocalHost", True),
    ("127.evil.example", False), ("127.0.0.1.nip.io", False), ("localhost.evil.example", False),
    ("evil.localhost", False), ("0.0.0.0", False), ("::", False), ("10.1.2.3", False), ("128.0.0.1", False),
    ("", False), ("127.1", False),
])
def test_loopback_is_decided_by_the_address(host, expected):
    assert is_loopback(host) is expected


def test_localhost_must_resolve_to_loopback_only(monkeypatch):
    import benchbot.protocol.shared_frames as sf

    def resolve(addresses):
        return lambda name, port: [(socket.AF_INET, socket.SOCK_STREAM, 6, "", (a, 0)) for a in addresses]

    monkeypatch.setattr(sf.socket, "getaddrinfo", resolve(["127.0.0.1", "10.0.0.5"]))
    assert not is_loopback("localhost")
    monkeypatch.setattr(sf.socket, "getaddrinfo", resolve(["127.0.0.1", "::1"]))
    assert is_loopback("localhost")
    monkeypatch.setattr(sf.socket, "getaddrinfo", resolve([]))
    assert not is_loopback("localhost")


def test_our_clients_name_themselves_and_release_on_close(serve):
    service, server = serve(PASSIVE, "miniroom:1")
    first = BenchBot(supervisor_address=server.address)  # a random X-BenchBot-Client of its own
    first.step("move_next")
    with pytest.raises(ValueError, match="the episode belongs to another client"):
        BenchBot(supervisor_address=server.address)
    first.close()  # releases the episode: the next client need not wait for the idle lease
    second = BenchBot(supervisor_address=server.address)
    assert second.step("move_next")[1] is ActionResult.SUCCESS
    second.close()


def test_a_solution_that_exits_on_ctrl_c_frees_its_episode(serve, tmp_path):
    _, server = serve(PASSIVE, "miniroom:1")
    script = tmp_path / "solution.py"
    script.write_text("import sys\nfrom benchbot.api import BenchBot\n"
                      "bot = BenchBot(supervisor_address=sys.argv[1])\nbot.step('move_next')\n"
                      "raise KeyboardInterrupt\n")  # never closes: the exit releases it
    proc = subprocess.run([sys.executable, str(script), server.address], capture_output=True, text=True, timeout=120)
    assert "KeyboardInterrupt" in proc.stderr
    bot = BenchBot(supervisor_address=server.address)
    assert bot.step("move_next")[1] is ActionResult.SUCCESS
    bot.close()
