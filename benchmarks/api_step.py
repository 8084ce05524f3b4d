"""Cost of one step through the three client paths, side by side in one run.

One backend (Taichi simulator, ``--width``×``--height``, default 640×480) serves a task that observes RGB, depth,
segmentation, laser and poses (``semantic_slam:active:ground_truth`` with ``image_segment`` added). Each round
resets the episode (untimed) and then times one step ``move_angle`` (``--angle`` degrees from the start pose, the
same motion and the same images for every path) through:

* ``inprocess``: :func:`benchbot.api.InProcessBenchBot` (no HTTP, no serialisation);
* ``native``: :class:`benchbot.api.BenchBot` over HTTP on 127.0.0.1 (``POST /native/step``, MessagePack);
* ``legacy``: the original client's request sequence (tests/legacy_client.py: ``requests`` GETs with JSON bodies,
  jsonpickle observations one by one) against the compatibility routes.

Then observe-only steps (``step(None)``: no motion) time the transport overhead alone (``*_observe_step_ms``).
Paths are interleaved round by round, so drift in the machine's load affects them alike; medians are reported.
Requests are counted for real (an httpx event hook; the legacy client's counter).

    python benchmarks/api_step.py [--rounds 15] [--width 640 --height 480] [--env miniroom:1] [--json]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--env", default="miniroom:1")
    ap.add_argument("--angle", type=float, default=10.0)
    ap.add_argument("--arch", default=os.environ.get("BENCHBOT_TAICHI_ARCH", "cpu"))
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from legacy_client import LegacyBenchBot

    from benchbot.api import BenchBot, InProcessBenchBot
    from benchbot.api.benchbot import HttpTransport
    from benchbot.core.registry import get_registry
    from benchbot.core.server import ServerThread, build_app
    from benchbot.core.session import resolve_run, start_service

    registry = get_registry()
    spec = resolve_run(registry, "semantic_slam:active:ground_truth", "carter", args.env)
    spec.task = dict(spec.task, observations=[*spec.task["observations"], "image_segment"])
    with contextlib.redirect_stdout(sys.stderr):
        service = start_service(registry, spec, options={"arch": args.arch, "width": args.width, "height": args.height})
    server = ServerThread(build_app(service)).start()
    native_count = [0]
    transport = HttpTransport(server.address, event_hooks={"request": [lambda request: native_count.__setitem__(0, native_count[0] + 1)]})
    clients = {
        "inprocess": InProcessBenchBot(service),
        "native": BenchBot(transport=transport),
    }
    with contextlib.redirect_stdout(sys.stderr):
        legacy = LegacyBenchBot(supervisor_address=server.address, poll_s=0.1)
    times: dict[str, list[float]] = {"inprocess": [], "native": [], "legacy": []}
    native_requests, legacy_requests = [], []
    shapes = {}
    for i in range(args.rounds + 1):  # round 0 warms up (kernels, connections)
        for name in ("inprocess", "native", "legacy"):
            service.call(service.episode.reset)
            before_native, before_legacy = native_count[0], legacy.requests_made
            t0 = time.perf_counter()
            if name == "legacy":
                with contextlib.redirect_stdout(sys.stderr):
                    obs, _ = legacy.step("move_angle", angle=args.angle)
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
    observe: dict[str, list[float]] = {"inprocess": [], "native": []}
    for i in range(args.rounds * 2 + 1):
        for name in ("inprocess", "native"):
            t0 = time.perf_counter()
            clients[name].step(None)
            if i:
                observe[name].append((time.perf_counter() - t0) * 1000.0)
    t0 = time.perf_counter()
    for _ in range(5):
        service.call(service.episode.observe, None)
    observe_ms = (time.perf_counter() - t0) * 200.0
    server.stop()
    service.close()

    med = {k: statistics.median(v) for k, v in times.items()}
    report = {
        "inprocess_step_ms": round(med["inprocess"], 2),
        "native_step_ms": round(med["native"], 2),
        "legacy_step_ms": round(med["legacy"], 2),
        "native_minus_inprocess_ms": round(med["native"] - med["inprocess"], 2),
        "native_requests_per_step": statistics.mean(native_requests),
        "legacy_requests_per_step": statistics.mean(legacy_requests),
        "inprocess_observe_step_ms": round(statistics.median(observe["inprocess"]), 2),
        "native_observe_step_ms": round(statistics.median(observe["native"]), 2),
        "backend_observe_ms": round(observe_ms, 2),
        "observations": shapes["native"],
        "resolution": f"{args.width}x{args.height}",
        "rounds": args.rounds,
        "machine": f"{platform.machine()} {os.cpu_count()} cpu, {platform.python_implementation()} {platform.python_version()}",
        "arch": args.arch,
    }
    if args.json:
        print(json.dumps(report))
    else:
        for key, value in report.items():
            print(f"{key:28s} {value}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
