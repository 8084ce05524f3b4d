"""Cost of one step through the three client paths, side by side in one run.

The episode (Taichi simulator, ``--width``×``--height``, default 640×480) observes RGB, depth, segmentation,
laser and poses (``semantic_slam:active:ground_truth`` with ``image_segment`` added). ``--server process`` (the
default) serves an identical backend over HTTP from its own process, as ``benchbot run`` serves a submission: the
client and the backend then have a process, and a GIL, each, as in every real deployment (the renders are
deterministic, so both processes see the same images; they never render at the same time). ``--server thread``
serves it from a thread of the benchmark's process instead, so every path uses the very same simulator, but the
HTTP client and server then share one GIL, which no deployment does (docs/protocol.md compares the two modes).
Each round
resets the episode (untimed) and then times one step ``move_angle`` (``--angle`` degrees from the start pose, the
same motion and the same images for every path) through:

* ``inprocess``: :func:`benchbot.api.InProcessBenchBot` (no HTTP, no serialisation);
* ``native``: :class:`benchbot.api.BenchBot` over HTTP on 127.0.0.1 (``POST /native/step``, MessagePack), as a
  client gets it by default: on the same host, large arrays travel through a shared-memory file
  (:mod:`benchbot.protocol.shared_frames`);
* ``native_inline``: the same with the shared-memory path off (``BENCHBOT_SHARED_MEMORY=0``: every array in the
  HTTP reply, as for a client on another host or in a container);
* ``legacy``: the original client's request sequence (tests/legacy_client.py: ``requests`` GETs with JSON bodies,
  jsonpickle observations one by one) against the compatibility routes.

Then observe-only steps (``step(None)``: no motion) time the transport overhead alone (``*_observe_step_ms``).
Paths are interleaved round by round, so drift in the machine's load affects them alike; medians are reported,
and the ``*_minus_inprocess_ms`` figures are medians of the per-round differences (a paired comparison: each
round's native step against the same round's in-process step), each with a distribution-free 95% confidence
interval of that median (``*_ci95_ms``, from the order statistics of the differences: this machine's load drifts, and
the interval says how far the median may be off).
Requests are counted for real (an ``HttpTransport`` event hook; the legacy client's counter).

The episode belongs to one client at a time (docs/protocol.md, "One client at a time"): the two ``BenchBot`` paths and
the untimed resets are one client (``$BENCHBOT_CLIENT_ID``, as a solution of several connections names itself); the
legacy client, which sends no id, is the anonymous client of 127.0.0.1, so before its turn the benchmark's client
releases the episode (``/robot/release``) and after it the anonymous client does, all untimed.

    python benchmarks/api_step.py [--rounds 301] [--width 640 --height 480] [--env miniroom:1]
        [--server process|thread] [--json] [--smoke]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import multiprocessing
import os
import platform
import secrets
import statistics
import sys
import time
from pathlib import Path

import httpx

import smoke  # this folder is on sys.path when a script here runs


def start_backend(args: argparse.Namespace):
    """The benchmark's episode (RGB, depth, segmentation, laser, poses) as a BackendService in this process."""
    from benchbot.core.registry import get_registry
    from benchbot.core.session import resolve_run, start_service

    registry = get_registry()
    spec = resolve_run(registry, "semantic_slam:active:ground_truth", "carter", args.env)
    spec.task = dict(spec.task, observations=[*spec.task["observations"], "image_segment"])
    with contextlib.redirect_stdout(sys.stderr):
        return start_service(registry, spec, options={"arch": args.arch, "width": args.width, "height": args.height})


def serve(args: argparse.Namespace, pipe) -> None:
    """Backend process: serve the episode on 127.0.0.1, send the address, stop when told."""
    from benchbot.server import ServerThread, build_app

    service = start_backend(args)
    server = ServerThread(build_app(service)).start()
    pipe.send(server.address)
    pipe.recv()
    server.stop()
    service.close()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=301)
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--env", default="miniroom:1")
    ap.add_argument("--angle", type=float, default=10.0)
    ap.add_argument("--arch", default=os.environ.get("BENCHBOT_TAICHI_ARCH", "cpu"))
    ap.add_argument("--server", choices=["thread", "process"], default="process",
                    help="HTTP backend in its own process (default: as `benchbot run` serves a submission) or on a "
                         "thread of this process (the same simulator for every path; client and server share a GIL)")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = smoke.parse_args(ap, argv, rounds=2, width=32, height=24, server="thread")
    if args.rounds < 1:
        ap.error("--rounds must be at least 1")

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from legacy_client import LegacyBenchBot

    from benchbot.api import BenchBot, InProcessBenchBot
    from benchbot.api.benchbot import CLIENT_HEADER, HttpTransport
    from benchbot.server import ServerThread, build_app

    # one client for the BenchBot paths and the resets (HttpTransport reads the id when it is made)
    os.environ["BENCHBOT_CLIENT_ID"] = client_id = secrets.token_hex(16)

    service = start_backend(args)  # the in-process path's backend (and the thread server's)
    if args.server == "process":
        parent, child = multiprocessing.get_context("spawn").Pipe()
        backend = multiprocessing.get_context("spawn").Process(target=serve, args=(args, child), daemon=True)
        backend.start()
        address = parent.recv()
    else:
        server = ServerThread(build_app(service)).start()
        address = server.address
    reset_http = httpx.Client(base_url=address, timeout=60, headers={CLIENT_HEADER: client_id})
    anonymous_http = httpx.Client(base_url=address, timeout=60)  # the legacy client's identity: no id

    def hand_over(to_legacy: bool) -> None:
        """Release the episode to the other client (the legacy one, or back from it), as the protocol documents."""
        (reset_http if to_legacy else anonymous_http).post("robot/release").raise_for_status()
    native_count = [0]
    transport = HttpTransport(address, event_hooks={"request": [lambda request: native_count.__setitem__(0, native_count[0] + 1)]})
    clients = {
        "inprocess": InProcessBenchBot(service),
        "native": BenchBot(transport=transport),
        "native_inline": BenchBot(transport=HttpTransport(address, shared_memory=False)),
    }
    hand_over(to_legacy=True)  # the BenchBot clients' start (a reset) took the episode
    with contextlib.redirect_stdout(sys.stderr):
        legacy = LegacyBenchBot(supervisor_address=address, poll_s=0.1)  # so does its start handshake
    hand_over(to_legacy=False)
    times: dict[str, list[float]] = {"inprocess": [], "native": [], "native_inline": [], "legacy": []}
    native_requests, legacy_requests = [], []
    shapes = {}
    for i in range(args.rounds + 1):  # round 0 warms up (kernels, connections)
        for name in ("inprocess", "native", "native_inline", "legacy"):
            if name == "inprocess":
                service.call(service.episode.reset)
            else:
                reset_http.post("robot/reset").raise_for_status()
            if name == "legacy":
                hand_over(to_legacy=True)
            before_native, before_legacy = native_count[0], legacy.requests_made
            t0 = time.perf_counter()
            if name == "legacy":
                with contextlib.redirect_stdout(sys.stderr):
                    obs, _ = legacy.step("move_angle", angle=args.angle)
                dt = (time.perf_counter() - t0) * 1000.0
                hand_over(to_legacy=False)
            else:
                clients[name]._state = {"actions": ["move_angle"]}  # the client's view after a reset
                obs, _ = clients[name].step("move_angle", angle=args.angle)
                dt = (time.perf_counter() - t0) * 1000.0
            if i == 0:
                shapes[name] = sorted(k for k in obs)
                continue
            times[name].append(dt)
            if name == "native":
                native_requests.append(native_count[0] - before_native)
            if name == "legacy":
                legacy_requests.append(legacy.requests_made - before_legacy)
    # transport overhead alone: observe-only steps (no motion), interleaved the same way
    observe: dict[str, list[float]] = {"inprocess": [], "native": [], "native_inline": []}
    for i in range(args.rounds * 2 + 1):
        for name in observe:
            t0 = time.perf_counter()
            clients[name].step(None)
            if i:
                observe[name].append((time.perf_counter() - t0) * 1000.0)
    t0 = time.perf_counter()
    for _ in range(5):
        service.call(service.episode.observe, None)
    observe_ms = (time.perf_counter() - t0) * 200.0
    shared_memory = clients["native"].transport.shared_memory
    for client in clients.values():
        client.close()
    reset_http.close()
    anonymous_http.close()
    if args.server == "process":
        parent.send("stop")
        backend.join(timeout=30)
    else:
        server.stop()
    service.close()

    med = {k: statistics.median(v) for k, v in times.items()}

    def differences(name: str) -> list[float]:
        return sorted(a - b for a, b in zip(times[name], times["inprocess"]))

    def paired(name: str) -> float:
        return round(statistics.median(differences(name)), 2)

    def paired_ci95(name: str) -> list[float]:
        # ranks n/2 ∓ 0.98·√n bound the median with ~95% confidence (normal approximation of Binomial(n, 1/2))
        d = differences(name)
        low = max(int(math.floor(len(d) / 2 - 0.98 * math.sqrt(len(d)))), 0)
        high = min(int(math.ceil(len(d) / 2 + 0.98 * math.sqrt(len(d)))), len(d) - 1)
        return [round(d[low], 2), round(d[high], 2)]

    report = {
        "inprocess_step_ms": round(med["inprocess"], 2),
        "native_step_ms": round(med["native"], 2),
        "native_inline_step_ms": round(med["native_inline"], 2),
        "legacy_step_ms": round(med["legacy"], 2),
        "native_minus_inprocess_ms": paired("native"),
        "native_minus_inprocess_ci95_ms": paired_ci95("native"),
        "native_inline_minus_inprocess_ms": paired("native_inline"),
        "native_shared_memory": shared_memory,
        "native_requests_per_step": statistics.mean(native_requests),
        "legacy_requests_per_step": statistics.mean(legacy_requests),
        "inprocess_observe_step_ms": round(statistics.median(observe["inprocess"]), 2),
        "native_observe_step_ms": round(statistics.median(observe["native"]), 2),
        "native_inline_observe_step_ms": round(statistics.median(observe["native_inline"]), 2),
        "backend_observe_ms": round(observe_ms, 2),
        "observations": shapes["native"],
        "resolution": f"{args.width}x{args.height}",
        "rounds": args.rounds,
        "machine": f"{platform.machine()} {os.cpu_count()} cpu, {platform.python_implementation()} {platform.python_version()}",
        "arch": args.arch,
        "server": args.server,
    }
    print_report(report, args.json)
    return 0


def print_report(report: dict, as_json: bool) -> None:
    """``report`` as one JSON object, or as aligned ``key value`` lines."""
    if as_json:
        print(json.dumps(report))
    else:
        for key, value in report.items():
            print(f"{key:32s} {value}")


if __name__ == "__main__":
    raise SystemExit(main())
