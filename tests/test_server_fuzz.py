"""Robustness and security of the backend server on loopback: random requests never crash it, tokens, timeouts,
and no ground truth through the API."""

from __future__ import annotations

import json
import random
import socket
import string
import threading

import httpx
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from benchbot.api import BenchBot
from benchbot.protocol import wire
from benchbot.server import ServerThread, build_app

PASSIVE = "semantic_slam:passive:ground_truth"
ACTIVE = "semantic_slam:active:ground_truth"

PREFIXES = ["", "config/", "config/task/", "robot/", "connections/", "results_functions/", "results_functions//",
            "native/step", "native/", "robot/reset/", "connections/move_next", "connections/image_rgb"]
NAMES = ["", "is_collided", "state", "next", "reset", "restart", "stop", "is_running", "move_next", "move_angle",
         "create", "create_object", "validate", "laser", "poses", "task", "robot", "environments", "..", "%00", "%2F"]
JSONISH = st.recursive(
    st.none() | st.booleans() | st.integers(-(2**63), 2**63 - 1) | st.floats(allow_nan=False) | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner, max_size=4),
    max_leaves=12,
)


BODIES = st.one_of(
    st.just(b""),
    st.binary(max_size=64),
    JSONISH.map(lambda v: json.dumps(v).encode()),
    st.fixed_dictionaries({"args": JSONISH, "kwargs": JSONISH}).map(lambda v: json.dumps(v).encode()),
    st.fixed_dictionaries({"action": JSONISH, "args": JSONISH}).map(lambda v: __import__("msgpack").packb(v)),
    # the shared-memory offer: junk, and well-formed offers naming segments that do not exist or paths elsewhere
    st.fixed_dictionaries({"action": st.none() | JSONISH, "shm": JSONISH | st.fixed_dictionaries({
        "client": st.from_regex(r"[0-9a-f]{32}", fullmatch=True) | JSONISH,
        "segment": st.none() | st.from_regex(r"benchbot-[0-9a-f]{32}", fullmatch=True) | JSONISH
        | st.sampled_from(["../../etc/passwd", "benchbot-", "/dev/shm/x", "benchbot-" + "a" * 32 + "/"])},
        optional={"slot": st.integers(-3, 8) | JSONISH})})
    .map(lambda v: __import__("msgpack").packb(v)),
)


def test_random_requests_never_crash_the_server(served):
    _, server = served(ACTIVE, "miniroom:1")
    http = httpx.Client(base_url=server.address, timeout=60)

    @settings(max_examples=150, deadline=None, suppress_health_check=list(HealthCheck))
    @given(
        method=st.sampled_from(["GET", "POST", "PUT", "DELETE", "PATCH", "OPTIONS", "HEAD"]),
        prefix=st.sampled_from(PREFIXES),
        name=st.sampled_from(NAMES) | st.text(alphabet=string.ascii_letters + string.digits + "_-.~/", max_size=12),
        body=BODIES,
    )
    def check(method, prefix, name, body):
        reply = http.request(method, "/" + prefix + name, content=body)
        assert reply.status_code < 500, (method, prefix + name, body, reply.status_code, reply.text[:200])

    check()
    assert http.get("/").json() == "Hello, I am the BenchBot supervisor"
    assert "is_running" in http.get("/robot/state").json()
    http.close()


#: The hostile fuzz: how many requests, and how long one may take before it counts as a stalled server (a bound
#: for hangs, far above any load: how fast the server refuses is measured by benchmarks/hostile_inputs.py).
HOSTILE_REQUESTS = 300
HOSTILE_STALL_S = 30.0
HOSTILE_ROUTES = ["/", "/config/", "/config/task/observations", "/config/environments", "/robot/state",
                  "/robot/is_running", "/robot/reset", "/robot/next", "/robot/restart", "/robot/stop", "/robot/release",
                  "/robot/run_info", "/connections/move_distance", "/connections/move_angle", "/connections/move_next",
                  "/connections/image_rgb", "/connections/laser", "/connections/poses", "/results_functions/",
                  "/results_functions/create", "/results_functions/create_object", "/results_functions/validate",
                  "/native/step", "/native/", "/robot/" + "a" * 300, "/config/" + "x/" * 200, "/%ff%fe", "/..%2f.."]


#: The large hostile bodies, made once: past the size limit, deep nesting, long lists, observation lists past the limit.
LARGE_BODIES = [
    b" " * (1024 * 1024 + 1), b"[" * 100_000 + b"]" * 100_000, b'{"a":' * 50_000 + b"1" + b"}" * 50_000,
    json.dumps({"args": [[0.5] * 50_000]}).encode(),
    wire.pack({"action": None, "observations": ["laser"] * 60_000}),
]


def hostile_body(rng: random.Random) -> bytes:
    """A body an attacker would try: huge and non-finite numbers, deep nesting, long lists, counts past every
    limit, bodies past the size limit, junk."""
    huge_int = "9" * rng.choice([20, 400, 4000])
    number = rng.choice([huge_int, "-" + huge_int, "1e308", "-1e308", "1e9", "NaN", "Infinity", "1e-320", "0",
                         str(rng.uniform(-200, 200)), "1e400"])
    makers = [
        lambda: rng.choice([b"", b"null", b"[]", b"{}", b"\xff\xfe\x00"]),
        lambda: rng.randbytes(rng.randint(1, 200)),
        lambda: f'{{"distance": {number}}}'.encode(), lambda: f'{{"angle": {number}}}'.encode(),
        lambda: f'{{"args": [{number}]}}'.encode(), lambda: f'{{"kwargs": {{"num_classes": {number}}}}}'.encode(),
        lambda: f'{{"args": ["{huge_int}"]}}'.encode(),
        lambda: rng.choice(LARGE_BODIES),
        lambda: wire.pack({"action": rng.choice([None, "move_distance", "move_angle", "move_next", "fly", 7]),
                           "args": {"distance": rng.choice([1e308, -1e308, 1e9, 2**64 - 1, -(2**63), float("nan"),
                                                            0.1, "x", None]),
                                    "angle": rng.choice([1e300, float("inf"), 720, 10, [], None])}}),
        lambda: wire.pack({"action": None, "observations": ["laser"] * rng.choice([65, 1000])}),
        lambda: wire.pack({"action": None, "observations": [rng.randbytes(8).hex() for _ in range(3)]}),
        lambda: wire.pack({"action": None, "shm": {"client": "0" * 32, "segment": "../../etc/passwd",
                                                   "slot": 2**64 - 1}}),
        lambda: wire.pack(rng.choice([[1, 2, 3], {"action": "move_angle", "args": [1, 2]}])),
    ]
    return rng.choice(makers)()


def test_hostile_requests_never_crash_or_stall_the_server(served):
    """A bounded, seeded fuzz (:data:`HOSTILE_REQUESTS` requests) of hostile requests on every route: no 5xx, no
    request stalls (:data:`HOSTILE_STALL_S`: the client's timeout), and the server still answers after."""
    _, server = served(ACTIVE, "miniroom:1")
    rng = random.Random(14)
    http = httpx.Client(base_url=server.address, timeout=HOSTILE_STALL_S)
    statuses: dict[int, int] = {}
    for i in range(HOSTILE_REQUESTS):
        method = rng.choice(["GET", "POST", "POST", "PUT", "DELETE"])
        path = rng.choice(HOSTILE_ROUTES)
        body = hostile_body(rng)
        headers = {"content-type": rng.choice(["application/json", wire.MSGPACK_TYPE, "text/plain"])}
        if rng.random() < 0.2:
            headers["X-BenchBot-Client"] = rng.choice(["", "x", "a" * 500, "ok-client-" + str(i % 3) * 8,
                                                       "\xe9".encode("latin-1") * 10])
        try:
            reply = http.request(method, path, content=body, headers=headers)
        except httpx.RemoteProtocolError:  # the server closed a connection it refused (a 413 before the body)
            http.close()
            http = httpx.Client(base_url=server.address, timeout=HOSTILE_STALL_S)
            continue
        statuses[reply.status_code] = statuses.get(reply.status_code, 0) + 1
        assert reply.status_code < 500, (method, path, body[:80], reply.status_code, reply.text[:300])
    # raw HTTP an ordinary client would never send: lying lengths, endless chunks, junk request lines
    for raw in (b"POST /native/step HTTP/1.1\r\nHost: x\r\nContent-Length: 99999999999\r\n\r\n{",
                b"POST /robot/reset HTTP/1.1\r\nHost: x\r\nContent-Length: -5\r\n\r\n",
                b"POST /results_functions/create HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n"
                + b"100000\r\n" + b"a" * 0x100000 + b"\r\n" + b"10\r\n" + b"a" * 16 + b"\r\n",
                b"GET /" + b"a" * 70_000 + b" HTTP/1.1\r\nHost: x\r\n\r\n",
                b"\x16\x03\x01\x00\x05hello\r\n\r\n"):
        with socket.create_connection(("127.0.0.1", server.port), timeout=5) as sock:
            try:
                sock.sendall(raw)
                head = sock.recv(64)
            except (ConnectionResetError, BrokenPipeError, socket.timeout):
                head = b""
        assert not head.startswith(b"HTTP/1.1 5"), (raw[:60], head)
    assert http.get("/").json() == "Hello, I am the BenchBot supervisor"
    assert http.post("/robot/reset").json() == {"reset_success": True}
    assert statuses.get(413, 0) > 0 and statuses.get(400, 0) > 0, statuses
    http.close()


def test_token_required_when_set(make_service):
    service = make_service(PASSIVE, "miniroom:1")
    server = ServerThread(build_app(service, token="s3cret")).start()
    try:
        anonymous = httpx.get(server.address + "config/")
        assert anonymous.status_code == 401 and "token" in anonymous.json()["error"]
        assert httpx.get(server.address, headers={"X-BenchBot-Token": "wrong"}).status_code == 401
        assert httpx.get(server.address, headers={"X-BenchBot-Token": "s3cret"}).status_code == 200
        assert httpx.get(server.address, headers={"Authorization": "Bearer s3cret"}).status_code == 200
        import os
        os.environ["BENCHBOT_TOKEN"] = "s3cret"
        try:
            bot = BenchBot(supervisor_address=server.address)
            assert bot.step("move_next")[0]["image_rgb"].shape == (48, 64, 3)
            bot.close()
        finally:
            del os.environ["BENCHBOT_TOKEN"]
    finally:
        server.stop()


def test_slow_action_answers_504_and_the_episode_stays_usable(make_service):
    service = make_service(ACTIVE, "miniroom:1")
    backend = service.episode.backend
    original = backend.move_to
    release = threading.Event()

    def slow_move(goal):
        release.wait(5.0)
        return original(goal)

    backend.move_to = slow_move
    server = ServerThread(build_app(service, action_timeout_s=0.3)).start()
    try:
        http = httpx.Client(base_url=server.address, timeout=30)
        reply = http.post("/connections/move_angle", json={"angle": 10})
        # the motion blocks until release is set below, so a 504 now shows the server did not wait for it
        assert reply.status_code == 504 and "did not finish within 0.3 s" in reply.json()["error"]
        release.set()
        assert http.get("/robot/state").json()["step"] == 1  # queued behind the finished motion
        backend.move_to = original
        http.post("/robot/release")  # the anonymous client lets the next one have the episode
        bot = BenchBot(supervisor_address=server.address)
        assert bot.step("move_angle", angle=5)[1].name == "SUCCESS"
        bot.close()
        http.close()
    finally:
        release.set()
        server.stop()


def test_ground_truth_is_never_served(served, registry):
    _, server = served(PASSIVE, "miniroom:1")
    gt = registry.ground_truth("miniroom:1")["ground_truth"]["objects"]
    centroids = {json.dumps(o["centroid"], separators=(",", ":")) for o in gt} | {json.dumps(o["centroid"]) for o in gt}
    http = httpx.Client(base_url=server.address, timeout=30)
    texts = [http.get("/config/").text, http.get("/results_functions/").text, http.post("/results_functions/create").text]
    texts += [http.get(f"/robot/{c}").text for c in ("state", "selected_environment", "is_finished")]
    texts += [http.get(f"/connections/{o}").text for o in ("poses", "image_rgb_info", "laser")]
    for text in texts:
        assert '"ground_truth":{' not in text.replace(" ", "") and '"objects":[{' not in text.replace(" ", "")
        assert not any(c in text for c in centroids)

    def keys(node):
        if isinstance(node, dict):
            for k, v in node.items():
                yield k
                yield from keys(v)
        elif isinstance(node, list):
            for v in node:
                yield from keys(v)

    assert not {"objects", "ground_truth"} & set(keys(http.get("/config/").json()))
    http.close()
