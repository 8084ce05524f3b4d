"""Where one native step spends its time, stage by stage (same-host shared-memory path).

The backend is served over HTTP from a thread of this process (as ``api_step.py --server thread``), so one clock
times every stage: the request until the backend thread starts the step, the step itself, packing the reply on the
backend thread (writing the images into the client's slot), the reply's way to the client (waking the server's
event loop, sending, receiving), and decoding it. Stages are timed by wrapping ``BackendApi.step``,
``SegmentPool.pack`` and ``wire.unpack``; medians over ``--steps`` steps. Steps only observe, unless ``--angle``
turns the robot first (then the step renders a new view).

    python benchmarks/api_step_stages.py [--steps 80] [--width 640 --height 480] [--env miniroom:1] [--arch cpu] [--angle 0]
        [--json]
"""

from __future__ import annotations

import argparse
import collections
import os
import statistics
import time

import smoke  # this folder is on sys.path when a script here runs
from api_step import print_report, start_backend


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=80)
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--env", default="miniroom:1")
    ap.add_argument("--arch", default=os.environ.get("BENCHBOT_TAICHI_ARCH", "cpu"))
    ap.add_argument("--angle", type=float, default=0.0,
                    help="each step turns the robot by this many degrees first (0: observe-only steps)")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = smoke.parse_args(ap, argv, steps=3, width=32, height=24)
    if args.steps < 1:
        ap.error("--steps must be at least 1")

    from benchbot.api.benchbot import HttpTransport
    from benchbot import server as server_module
    from benchbot.protocol import shared_frames, wire

    service = start_backend(args)  # the same episode as api_step.py

    marks: dict[str, float] = {}

    def timed(owner, name: str, label: str) -> None:
        original = getattr(owner, name)

        def wrapper(*a, **k):
            marks[label + "_in"] = time.perf_counter()
            try:
                return original(*a, **k)
            finally:
                marks[label + "_out"] = time.perf_counter()

        setattr(owner, name, wrapper)

    timed(server_module.BackendApi, "step", "step")
    timed(shared_frames.SegmentPool, "pack", "pack")
    timed(wire, "unpack", "unpack")
    server = server_module.ServerThread(server_module.build_app(service)).start()
    transport = HttpTransport(server.address)
    stages = collections.defaultdict(list)
    for i in range(args.steps + 5):
        t0 = time.perf_counter()
        if args.angle:
            transport.step("move_angle", {"angle": args.angle}, None)
        else:
            transport.step(None, {}, None)
        t1 = time.perf_counter()
        if i < 5:  # warm-up, and the shared-memory handshake
            continue
        stages["request_to_backend_thread"].append(marks["step_in"] - t0)
        stages["step"].append(marks["step_out"] - marks["step_in"])
        stages["pack_into_slot"].append(marks["pack_out"] - marks["pack_in"])
        stages["reply_to_client"].append(marks["unpack_in"] - marks["pack_out"])
        stages["decode"].append(marks["unpack_out"] - marks["unpack_in"])
        stages["total"].append(t1 - t0)
    transport.close()
    server.stop()
    service.close()
    report = {f"{k}_ms": round(statistics.median(v) * 1000.0, 3) for k, v in stages.items()}
    report.update(shared_memory=transport.shared_memory, resolution=f"{args.width}x{args.height}", steps=args.steps)
    print_report(report, args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
