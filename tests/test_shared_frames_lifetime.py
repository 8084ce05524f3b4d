"""Arrays a client holds from its shared-memory segment stay readable, and unchanged, after ``BenchBot.close()``,
after the backend evicts the segment (more clients than ``shared_frames.MAX_SEGMENTS``) and under many concurrent
clients.

The clients run in subprocesses against a real backend on 127.0.0.1, so that reading unmapped memory shows as a
failed test (return code -11, SIGSEGV) instead of killing pytest.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

from benchbot.protocol import shared_frames

pytestmark = pytest.mark.skipif(not shared_frames.available(), reason="no writable /dev/shm on this machine")

ACTIVE = "semantic_slam:active:ground_truth"
#: Large enough that the images pass shared_frames.MIN_BYTES (a 256×192 RGB image is 147,456 bytes).
CAMERA = {"width": 256, "height": 192}
#: Seconds a client subprocess may take (they take 1–3 s; the bound only keeps a hang from stalling the suite).
CLIENT_TIMEOUT_S = 90

#: Helpers every client script starts with: `held(bot_or_transport)` steps and keeps the arrays, `check` reads them.
PRELUDE = r"""
import gc, mmap, os, sys
os.environ["BENCHBOT_CLIENT_ID"] = "shared-frames-test"  # one solution of many connections: one episode owner
import numpy as np
from benchbot.api import BenchBot
from benchbot.api.benchbot import HttpTransport
from benchbot.protocol import shared_frames

ADDRESS = sys.argv[1]

def zero_copy(arr):
    base = arr
    while isinstance(base, np.ndarray):
        base = base.base
    return isinstance(base, mmap.mmap)

def step(transport, angle=7.0):
    return transport.step("move_angle", {"angle": angle}, None)["observations"]

def keep(obs, held):
    # the whole image, a view of part of it (a view outlives its parent array), and copies to compare with
    for name in ("image_rgb", "image_depth"):
        held.append((obs[name], np.array(obs[name])))
    held.append((obs["image_rgb"][10:20, 5:50], np.array(obs["image_rgb"][10:20, 5:50])))

def check(held, what):
    gc.collect()
    for reuse in (False, True):  # reading unmapped memory crashes (SIGSEGV), unless it was mapped again:
        junk = [np.full(1 << 20, 255, np.uint8) for _ in range(8 if reuse else 0)]  # as a busy client's would be
        for got, expected in held:
            if not np.array_equal(got, expected):
                print(f"{what}: a held array changed", file=sys.stderr)
                sys.exit(3)
        del junk

def mapped_segments():
    with open("/proc/self/maps") as maps:
        return {line.split()[-2].rsplit("/", 1)[-1] for line in maps if "/benchbot-" in line and "(deleted)" in line}
"""


@pytest.fixture(autouse=True)
def one_client_id(monkeypatch):
    """The in-process transports are one solution's connections (one owner of the episode)."""
    monkeypatch.setenv("BENCHBOT_CLIENT_ID", "shared-frames-test")


def _run_client(script: str, address: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", PRELUDE + script, address], capture_output=True, text=True,
                          timeout=CLIENT_TIMEOUT_S)


def _assert_clean_exit(proc: subprocess.CompletedProcess) -> None:
    assert proc.returncode != -11, f"the client died of SIGSEGV reading a held array\n{proc.stderr[-2000:]}"
    assert proc.returncode == 0, f"client exited {proc.returncode}\n{proc.stdout[-1000:]}\n{proc.stderr[-2000:]}"


def test_arrays_held_across_close_stay_readable_and_unchanged(served):
    _, server = served(ACTIVE, "miniroom:1", **CAMERA)
    proc = _run_client(r"""
bot = BenchBot(transport=HttpTransport(ADDRESS))
transport = bot.transport
held = []
bot.step(None)  # the handshake (inline)
for angle in (10.0, 20.0):
    obs, _ = bot.step("move_angle", angle=angle)
    keep(obs, held)
assert transport.shared_memory and all(zero_copy(got) for got, _ in held), "the arrays are views of the segment"
segment = transport._local.mapping.name
del obs
bot.close()
check(held, "after close")
assert segment in mapped_segments(), "the held arrays keep the segment mapped"
held.clear()
gc.collect()
assert segment not in mapped_segments(), "the last array gone, the segment is unmapped"
print("ok")
""", server.address)
    _assert_clean_exit(proc)


def test_arrays_held_from_an_evicted_segment_stay_readable_and_unchanged(served):
    """The backend evicts the least recently used segment beyond MAX_SEGMENTS clients; the evicted client's next
    step is inline and maps a new segment, and what it holds from the old one is neither unmapped nor overwritten."""
    _, server = served(ACTIVE, "miniroom:1", **CAMERA)
    proc = _run_client(r"""
first = HttpTransport(ADDRESS)
first.step(None, {}, None)  # the handshake
held = []
keep(step(first, 10.0), held)
assert all(zero_copy(got) for got, _ in held)
old = first._local.mapping.name
others = [HttpTransport(ADDRESS) for _ in range(shared_frames.MAX_SEGMENTS)]
for other in others:  # each makes a segment: the backend now holds MAX_SEGMENTS + 1 and evicts the first's
    other.step(None, {}, None)
reply = first.step("move_angle", {"angle": 15.0}, None)
assert "image_rgb" in reply["observations"] and first._local.mapping.name != old, "a new segment after eviction"
keep(reply["observations"], held)
for angle in (20.0, 25.0, 30.0):  # the new segment is used; other clients' steps go on too
    keep(step(first, angle), held)
    for other in others[:3]:
        step(other, angle)
check(held, "after eviction")
assert first.shared_memory, "eviction does not turn the shared-memory path off"
for t in [first, *others]:
    t.close()
check(held, "after eviction and close")
print("ok")
""", server.address)
    _assert_clean_exit(proc)


def test_a_segment_evicted_before_its_client_mapped_it_is_replaced(served, monkeypatch):
    """Between the reply that announces a segment and the client's mapping of it, other clients' steps can make the
    backend evict it (its file is gone): the client asks for a new one instead of turning the path off."""
    import mmap

    from benchbot.api.benchbot import HttpTransport

    _, server = served(ACTIVE, "miniroom:1", **CAMERA)
    real = shared_frames.ClientMapping
    others = [HttpTransport(server.address) for _ in range(shared_frames.MAX_SEGMENTS)]
    raced = []

    def late(*args):  # the other clients' steps land before this client maps its announced segment
        if not raced:
            raced.append(args[0])
            for other in others:
                other.step(None, {}, None)
        return real(*args)

    monkeypatch.setattr(shared_frames, "ClientMapping", late)
    transport = HttpTransport(server.address)
    transport.step(None, {}, None)  # the handshake: its segment is evicted before it is mapped
    assert raced and transport._local.mapping is None
    assert transport.shared_memory and transport.shared_memory_error is None, "an evicted segment is not fatal"
    transport.step(None, {}, None)  # a new segment, mapped this time
    depth = transport.step(None, {}, None)["observations"]["image_depth"]
    assert isinstance(depth.base, mmap.mmap), "the path is on again"
    for t in [transport, *others]:
        t.close()
    with pytest.raises(ConnectionError, match="was closed"):
        transport.step(None, {}, None)


@pytest.mark.slow
def test_more_concurrent_clients_than_segments_all_exit_cleanly(served, tmp_path):
    """12 clients (3 processes of 4 threads, each thread its own BenchBot), more than the backend keeps segments,
    step at once and keep every observation; in between, one client per process steps alone, so that it surely
    holds arrays viewing its segment when the crowd's steps evict it. Then they close and compare what they kept:
    none crashes, none sees an array change."""
    _, server = served(ACTIVE, "miniroom:1", **CAMERA)
    processes, threads = 3, 4
    assert processes * threads > shared_frames.MAX_SEGMENTS
    script = r"""
import os, threading, time
THREADS, PROCESSES, BARRIER = int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
STEPS = 2
failures = []

def barrier(name):  # every process waits here until all have arrived
    open(os.path.join(BARRIER, f"{name}-{os.getpid()}"), "w").close()
    deadline = time.monotonic() + 60
    while sum(f.startswith(name + "-") for f in os.listdir(BARRIER)) < PROCESSES:
        if time.monotonic() > deadline:
            sys.exit(5)
        time.sleep(0.02)

def crowd(bot, k, held, first_angle):
    try:
        for i in range(STEPS):
            obs, _ = bot.step("move_angle", angle=first_angle + k + i)
            keep(obs, held)
            check(held[-12:], "while stepping")
    except BaseException as exc:
        failures.append(repr(exc))

def in_threads(fn, *args):
    running = [threading.Thread(target=fn, args=(bots[k], k, helds[k], *args)) for k in range(THREADS)]
    for t in running:
        t.start()
    for t in running:
        t.join()
    if failures:
        print(failures, file=sys.stderr)
        sys.exit(4)

bots = [BenchBot(transport=HttpTransport(ADDRESS, timeout_s=60)) for _ in range(THREADS)]
helds = [[] for _ in range(THREADS)]
in_threads(crowd, 3.0)  # more clients than segments: most steps are handshakes
barrier("alone")
alone = []
for i in range(3):  # at most PROCESSES clients step now: the segment is kept, its arrays are views
    obs, _ = bots[0].step("move_angle", angle=-5.0 - i)
    keep(obs, alone)
if not any(zero_copy(got) for got, _ in alone):
    print("no array came through the segment", file=sys.stderr)
    sys.exit(6)
barrier("crowd")
helds[0] += alone
in_threads(crowd, 40.0)  # the crowd again: the segment behind `alone` is evicted, the client maps new ones
for bot in bots:
    bot.close()
for held in helds:
    check(held, "after eviction and close")
print("ok")
"""
    procs = [subprocess.Popen([sys.executable, "-c", PRELUDE + script, server.address, str(threads),
                               str(processes), str(tmp_path)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for _ in range(processes)]
    results = []
    try:
        for proc in procs:
            out, err = proc.communicate(timeout=CLIENT_TIMEOUT_S)
            results.append(subprocess.CompletedProcess(proc.args, proc.returncode, out, err))
    finally:
        for proc in procs:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    for result in results:
        _assert_clean_exit(result)
