"""Batch throughput: the ten BEAR environments with ``semslam_geometric`` on the passive task, with 1 worker and with
N workers in the same run, on each executor asked for.

Prints wall time and episodes per minute for each, the speed-up and the parallel efficiency (speed-up / N). The wall
time is that of the whole ``benchbot batch`` process (interpreter start, plugin loading, simulator start-up and the
OMQ evaluation included), not of the episodes alone. ``--executor local`` (the default): N worker processes, each
with its own simulator; ``--executor batched``: N episodes at a time in one process on one simulator (episodes of one
environment sharing its scene); give ``--executor`` twice to compare both in one run. The 1-worker baseline runs
``local`` (``--no-baseline``: skip it, and the speed-up).

    python benchmarks/batch.py [--workers N] [--executor local|batched ...] [--no-baseline]
        [--envs-batch bear_all | --envs ENV,...] [--example semslam_geometric] [--repeat 1] [--camera-size 640x480]
        [--arch cpu|cuda] [--json] [--smoke]

``--smoke``: ``hello_passive`` on miniroom:4 (33 poses) at 32×24, with one worker and with two on both executors.

The speed-up is bounded by the longest episode: in bear_all the longest (house:5, 286 poses) is 19% of the
1,529 poses of the ten, so no number of workers can pass about 5.3× on one repetition; ``--repeat 3`` gives the
pool enough work to show how it scales.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import smoke  # this folder is on sys.path when a script here runs


def run(workers: int, args: argparse.Namespace, out: Path, executor: str = "local") -> dict:
    envs = ["--envs", args.envs] if args.envs else ["--envs-batch", args.envs_batch]
    command = [sys.executable, "-m", "benchbot.cli", "batch", "--example", args.example, *envs,
               "--workers", str(workers), "--executor", executor, "--output-dir", str(out), "--json",
               "--arch", args.arch, "--no-service"]  # executors compared alike: each with its own simulator
    if args.camera_size:
        command += ["--camera-size", args.camera_size]
    if args.repeat > 1:
        command += ["--repeat", str(args.repeat)]
    t0 = time.monotonic()
    proc = subprocess.run(command, capture_output=True, text=True)
    wall = time.monotonic() - t0
    if proc.returncode != 0:
        sys.exit(f"batch with {workers} worker(s) ({executor}) failed:\n{proc.stderr[-2000:]}")
    outcome = json.loads(proc.stdout)
    episodes = len(outcome["episodes"])
    return {"workers": workers, "executor": executor, "wall_s": round(wall, 2), "episodes": episodes,
            "episodes_per_min": round(60.0 * episodes / wall, 3),
            "omq": outcome["scores"]["scores"]["OMQ"] if outcome.get("scores") else None}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1, help="N (default: the number of CPUs)")
    ap.add_argument("--envs-batch", default="bear_all")
    ap.add_argument("--envs", default=None, help="a comma list of environments instead of --envs-batch")
    ap.add_argument("--example", default="semslam_geometric")
    ap.add_argument("--camera-size", default=None, help="WIDTHxHEIGHT (default: the robot's 640x480)")
    ap.add_argument("--arch", default="cpu")
    ap.add_argument("--repeat", type=int, default=1, help="run each environment N times (more, shorter-tailed work)")
    ap.add_argument("--executor", action="append", choices=("local", "batched"), default=None,
                    help="executor of the N-worker run (give it twice for both; default local)")
    ap.add_argument("--no-baseline", action="store_true", help="skip the 1-worker run (and the speed-up)")
    ap.add_argument("--json", action="store_true")
    args = smoke.parse_args(ap, argv, envs="miniroom:4", example="hello_passive", camera_size="32x24", workers=2,
                            executor=["local", "batched"])
    if args.workers < 1 or args.repeat < 1:
        ap.error("--workers and --repeat must be at least 1")
    executors = args.executor or ["local"]
    runs = []
    with tempfile.TemporaryDirectory(prefix="benchbot-bench-") as tmp:
        one = None if args.no_baseline else run(1, args, Path(tmp) / "one")
        for executor in executors:
            many = one if (args.workers == 1 and executor == "local" and one) else \
                run(args.workers, args, Path(tmp) / f"many_{executor}", executor)
            if one is not None:
                many = {**many, "speedup": round(one["wall_s"] / many["wall_s"], 3),
                        "parallel_efficiency": round(one["wall_s"] / many["wall_s"] / args.workers, 3)}
            runs.append(many)
    result = {"envs_batch": args.envs or args.envs_batch, "example": args.example, "repeat": args.repeat,
              "arch": args.arch, "cpu_count": os.cpu_count(), "one_worker": one, "n_workers": runs}
    if args.json:
        print(json.dumps(result))
    else:
        for r in ([one] if one else []) + runs:
            print(f"{r['workers']:>3} worker(s): {r['wall_s']:8.1f} s, {r['episodes_per_min']:.2f} episodes/min, "
                  f"OMQ {r['omq']}  [{r['executor']}]")
        for r in runs:
            if "speedup" in r:
                print(f"speed-up {r['speedup']:.2f}x [{r['executor']}], parallel efficiency "
                      f"{r['parallel_efficiency']:.2f}")
    return 0

if __name__ == "__main__":
    sys.exit(main())
