"""The native step's same-host shared-memory path (benchbot.protocol.shared_frames) against a real backend on loopback."""

from __future__ import annotations

import os

import msgpack
import numpy as np
import pytest
from starlette.testclient import TestClient

from benchbot.api import BenchBot, InProcessBenchBot
from benchbot.api.benchbot import HttpTransport
from benchbot.protocol import shared_frames, wire
from benchbot.core.errors import BenchbotError
from benchbot.server import build_app

pytestmark = pytest.mark.skipif(not shared_frames.available(), reason="no writable /dev/shm on this machine")

ACTIVE = "semantic_slam:active:ground_truth"
#: Large enough that the images pass shared_frames.MIN_BYTES (a 256×192 RGB image is 147,456 bytes).
CAMERA = {"width": 256, "height": 192}


@pytest.fixture
def reads(monkeypatch):
    """Counts the arrays that clients copy out of segments."""
    count = [0]
    original = shared_frames.ClientMapping.read

    def counted(self, *args):
        count[0] += 1
        return original(self, *args)

    monkeypatch.setattr(shared_frames.ClientMapping, "read", counted)
    return count


def _equal(a: dict, b: dict) -> bool:
    assert set(a) == set(b)
    for key in a:
        x, y = a[key], b[key]
        if isinstance(x, np.ndarray):
            if not (isinstance(y, np.ndarray) and x.dtype == y.dtype and np.array_equal(x, y)):
                return False
        elif isinstance(x, dict):
            if not _equal(x, y):
                return False
        elif isinstance(x, (list, tuple)):  # MessagePack has no tuples
            if list(x) != list(y):
                return False
        elif x != y:
            return False
    return True


def _segments() -> set[str]:
    return {n for n in os.listdir(shared_frames.SHM_DIR) if shared_frames.NAME_PATTERN.fullmatch(n)}


@pytest.fixture
def own_segments(monkeypatch):
    """``own_segments()`` → the names of the segments that this test's backends made and whose files are still in
    /dev/shm. Only this test's own segments count: another BenchBot on the host may make and remove its own at any
    time, so comparing all of /dev/shm before and after would fail for no fault of ours."""
    made: list[str] = []
    init = shared_frames.BackendSegment.__init__

    def recording(self, size):
        init(self, size)
        made.append(self.name)

    monkeypatch.setattr(shared_frames.BackendSegment, "__init__", recording)
    return lambda: [n for n in made if n in _segments()]


def test_shared_memory_steps_equal_the_inline_and_in_process_steps(served, reads, monkeypatch, own_segments):
    monkeypatch.setenv("BENCHBOT_CLIENT_ID", "one-solution-two-connections")  # one owner of the episode
    service, server = served(ACTIVE, "miniroom:1", **CAMERA)
    shared = BenchBot(transport=HttpTransport(server.address))
    assert shared.transport.shared_memory, "on by default for a loopback backend"
    inline = BenchBot(transport=HttpTransport(server.address, shared_memory=False))
    local = InProcessBenchBot(service)
    shared.step(None)  # the handshake step (inline): the client maps the segment the reply names
    for action, kwargs in ((None, {}), ("move_angle", {"angle": 20.0}), ("move_distance", {"distance": 0.2})):
        got = []
        for bot in (shared, inline, local):
            service.call(service.episode.reset)
            bot._state = {"actions": ["move_angle", "move_distance"]}
            got.append(bot.step(action, **kwargs))
        (a, ra), (b, rb), (c, rc) = got
        assert ra == rb == rc and _equal(a, b) and _equal(a, c)
        assert a["image_rgb"].shape == (192, 256, 3) and not a["image_rgb"].flags.writeable  # as inline arrays
    assert reads[0] >= 3 * 2, "RGB and depth of every shared step came through the segment"
    assert own_segments() == [], "the segment's file is removed once the client has mapped it"
    shared.close()
    inline.close()
    server.stop()
    assert own_segments() == [], "stopping the server removes its segments"


def test_a_segment_too_small_is_replaced_without_losing_a_step(served, reads, monkeypatch):
    service, server = served(ACTIVE, "miniroom:1", **CAMERA)
    transport = HttpTransport(server.address)
    first = transport.step(None, {}, None)  # the handshake step: inline, and the segment to map
    assert reads[0] == 0 and transport._local.mapping is not None
    small = transport._local.mapping.size
    service.call(service.episode.backend.close)  # the next observations are larger: a new camera size
    service.episode.backend.width, service.episode.backend.height = 512, 384
    service.call(service.episode.reset)
    bigger = transport.step(None, {}, None)
    assert bigger["observations"]["image_rgb"].shape == (384, 512, 3), "inline while the segment grew"
    assert transport._local.mapping.size > small and transport.shared_memory
    again = transport.step(None, {}, None)
    assert reads[0] >= 2 and _equal(bigger["observations"], again["observations"])
    assert first["observations"]["image_rgb"].shape == (192, 256, 3)
    transport.close()


def test_a_segment_the_client_cannot_map_turns_the_path_off(served, reads, monkeypatch, own_segments):
    _, server = served(ACTIVE, "miniroom:1", **CAMERA)
    transport = HttpTransport(server.address)
    transport.step(None, {}, None)
    made = own_segments()  # offered, not yet mapped: the file is there, for the backend's user only
    assert len(made) == 1 and oct(os.stat(os.path.join(shared_frames.SHM_DIR, made[0])).st_mode & 0o777) == "0o600"
    transport.close()
    transport = HttpTransport(server.address)

    def elsewhere(*args):  # as if this client's /dev/shm were not the backend's (another container)
        raise FileNotFoundError(2, "No such file or directory")

    monkeypatch.setattr(shared_frames, "ClientMapping", elsewhere)
    for _ in range(3):
        reply = transport.step(None, {}, None)
        assert reply["observations"]["image_rgb"].shape == (192, 256, 3)
    assert reads[0] == 0 and not transport.shared_memory and "cannot map" in transport.shared_memory_error
    transport.close()


def test_only_loopback_clients_get_shared_memory_and_bad_offers_are_refused(make_service):
    service = make_service(ACTIVE, "miniroom:1", **CAMERA)
    offer = {"client": "0" * 32, "segment": None}
    with TestClient(build_app(service)) as http:  # its client address is "testclient", not loopback
        reply = http.post("/native/step", content=wire.pack({"action": None, "shm": offer}))
        assert reply.status_code == 200
        body = wire.unpack(reply.content)
        assert "loopback" in body["shm_error"] and body["observations"]["image_depth"].shape == (192, 256)
        for bad in ("../etc/passwd", 7, {"client": "x"}, {"client": "0" * 32, "segment": "../../etc/passwd"},
                    {"client": "0" * 32, "segment": 3}):
            refused = http.post("/native/step", content=msgpack.packb({"action": None, "shm": bad}))
            assert refused.status_code == 400 and "shm" in refused.json()["error"]


def test_the_backend_keeps_a_bounded_number_of_segments(own_segments):
    pool = shared_frames.SegmentPool(capacity=2)
    reply = {"observations": {"depth": np.ones((300, 300), np.float32)}}
    for client in ("a" * 32, "b" * 32, "c" * 32):
        body = wire.unpack(pool.pack(reply, shared_frames.check_offer({"client": client, "segment": None})))
        assert "shm_segment" in body and np.array_equal(body["observations"]["depth"], reply["observations"]["depth"])
    assert len(own_segments()) == 2
    pool.close()
    assert own_segments() == []


def test_mapped_reads_check_their_descriptor():
    segment = shared_frames.BackendSegment(1 << 20)
    segment.write(np.arange(4, dtype=np.float32), 64)
    mapping = shared_frames.ClientMapping(segment.name, segment.size)
    assert mapping.read("<f4", [4], 64).tolist() == [0.0, 1.0, 2.0, 3.0]
    with pytest.raises(BenchbotError, match="malformed shm_segment"):
        shared_frames.ClientMapping(segment.name, segment.size, slots=0)
    with pytest.raises(BenchbotError, match="outside"):
        mapping.read("<f4", [1 << 20], 0)
    with pytest.raises(BenchbotError, match="malformed"):
        mapping.read("|O", [1], 0)
    with pytest.raises(BenchbotError, match="outside"):
        mapping.read("u1", [1], -1)
    with pytest.raises(BenchbotError, match="malformed"):
        mapping.read("u1", [-1, 2], 0)
    with pytest.raises(BenchbotError, match="malformed shm_segment"):
        shared_frames.ClientMapping("../x", 10)
    mapping.close()
    segment.close()
    with pytest.raises(BenchbotError, match="no segment"):
        wire.unpack(msgpack.packb({"a": {wire.SHM: "<f4", "shape": [1], "offset": 0}}))


def test_arrays_are_never_overwritten_while_anything_refers_to_them(served):
    """Views of a slot keep it busy; once every view slot is held the scratch slot copies; a freed slot is reused."""
    import mmap as mmap_module

    service, server = served(ACTIVE, "miniroom:1", **CAMERA)
    transport = HttpTransport(server.address)
    transport.step(None, {}, None)  # handshake
    views_slots = shared_frames.SLOTS - 1

    def turn() -> dict:
        return transport.step("move_angle", {"angle": 15.0}, None)["observations"]

    held, expected = [], []
    for _ in range(views_slots + 2):
        obs = turn()
        held.append(obs["image_rgb"][8:40])  # only a view of part of the image is kept
        expected.append(np.array(obs["image_rgb"][8:40]))
        del obs
    zero_copy = [isinstance(h.base.base, mmap_module.mmap) for h in held]
    assert zero_copy == [True] * views_slots + [False, False], "views while a slot is free, then copies"
    for _ in range(3):
        turn()
    assert all(np.array_equal(h, e) for h, e in zip(held, expected)), "no held array was overwritten"
    mapping = transport._local.mapping
    assert mapping.free_slot() == views_slots  # every view slot is held: the scratch slot is next
    held.clear()
    assert mapping.free_slot() == 0, "dropping the last views frees their slots"
    assert isinstance(turn()["image_depth"].base, mmap_module.mmap)
    transport.close()



@pytest.mark.parametrize("shared_memory", [True, False], ids=["shared-memory", "inline"])
def test_native_steps_copy_borrowed_observations_before_the_backend_reuses_them(served, shared_memory):
    """The native step observes with ``observe_borrowed`` and copies each array at once: a backend that lends one
    reused buffer for every observation still gives each step its own image."""
    service, server = served(ACTIVE, "miniroom:1", **CAMERA)
    backend = service.episode.backend
    lent = np.zeros((CAMERA["height"], CAMERA["width"], 3), np.uint8)
    lent_values = []

    def observe_borrowed(names):
        obs = backend.observe(names)
        if "image_rgb" in obs:
            lent[...] = obs["image_rgb"]  # the same buffer every time, overwritten by the next observation
            obs["image_rgb"] = lent
            lent_values.append(lent.copy())
        return obs

    backend.observe_borrowed = observe_borrowed  # this backend only
    transport = HttpTransport(server.address, shared_memory=shared_memory)
    held = [transport.step("move_angle", {"angle": 25.0}, None)["observations"]["image_rgb"] for _ in range(4)]
    assert len(lent_values) == 4, "every native step observed through observe_borrowed"
    assert not np.array_equal(lent_values[0], lent_values[1]), "the robot turned: the images differ"
    for got, lent_then in zip(held, lent_values):
        assert np.array_equal(got, lent_then), "each step kept the image of its own instant"
    assert not any(np.shares_memory(got, lent) for got in held)
    transport.close()


@pytest.mark.slow
def test_a_terminated_benchbot_run_removes_its_segments():
    """SIGTERM stops `benchbot run` as Ctrl-C does: a segment its client never mapped (so never unlinked) is removed
    too."""
    import re
    import secrets
    import signal
    import subprocess
    import sys
    import threading

    import httpx

    made = None
    proc = subprocess.Popen([sys.executable, "-m", "benchbot.cli", "run", "--env", "miniroom:1", "--port", "0",
                             "--camera-size", "256x192"], stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                            env=dict(os.environ, COLUMNS="300"))
    watchdog = threading.Timer(120, proc.kill)  # a backend that never comes up ends the wait for its output
    watchdog.start()
    try:
        address = None
        for line in proc.stderr:
            found = re.search(r"backend ready at (http://127\.0\.0\.1:\d+/)", line)
            if found:
                address = found[1]
                break
        assert address, "benchbot run did not come up"
        offer = {"client": secrets.token_hex(16), "segment": None, "slot": 0}
        reply = httpx.post(address + "native/step", content=wire.pack({"action": None, "args": {}, "shm": offer}),
                           headers={"content-type": wire.MSGPACK_TYPE}, timeout=60)
        made = wire.unpack(reply.content)["shm_segment"]["name"]
        assert made in _segments(), "the segment waits for its client to map it"
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=60) == 130 and "interrupted" in proc.stderr.read()
    finally:
        watchdog.cancel()
        if proc.poll() is None:
            proc.kill()
    assert made not in _segments(), "the segment of the terminated backend is removed"
