"""Robustness and security of the backend server on loopback: random requests never crash it, tokens, timeouts,
and no ground truth through the API."""

from __future__ import annotations

import json
import string
import threading
import time

import httpx
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from benchbot.api import BenchBot
from benchbot.core.server import ServerThread, build_app

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
        started = time.monotonic()
        reply = http.post("/connections/move_angle", json={"angle": 10})
        assert reply.status_code == 504 and "did not finish within 0.3 s" in reply.json()["error"]
        assert time.monotonic() - started < 3.0
        release.set()
        assert http.get("/robot/state").json()["step"] == 1  # queued behind the finished motion
        backend.move_to = original
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
