"""README command 1 (``benchbot batch --example semslam_geometric --envs miniroom:1``) timed the first time on a
machine and again: once cold, with an empty scene cache and an empty Taichi kernel cache (both in a temporary
folder: ``BENCHBOT_CACHE_DIR``, ``TI_OFFLINE_CACHE_FILE_PATH``), then ``--warm`` more times with the caches that run
filled. Prints each run's wall time and where its start-up went (the seconds of each stage the simulator marks,
:mod:`benchbot.core.stages`: building or loading the scene, starting Taichi, BVH, shadow maps, baked light, compiling
kernels), what follows the last stage (the episode: the solution's start, its steps, scoring, exit), and the bytes
the scene cache holds after the run (``scene_cache_bytes``: the environment's entry), with the CPU seconds of the
run's processes (``cpu_s``: the command and its children, the solution's included) and the load average before it
(``loadavg``, ``/proc/loadavg``: on a shared machine the wall seconds grow with it, the CPU seconds much less).
``--prepare`` runs ``benchbot sim prepare ENV`` into the empty caches first (timed as ``prepare``), so that the first
run of the command is the one a user has after preparing.

    uv run python benchmarks/first_run.py [--env miniroom:1] [--example semslam_geometric] [--warm 2] [--prepare]
                                          [--json]

Each run is a fresh process running BenchBot's command-line entry point (what the ``benchbot`` script runs; ``uv
run``'s own start, about 0.1 s, is not in it), in a new run directory under the temporary folder, which is removed
at the end. ``--smoke`` runs ``hello_passive`` on miniroom:1 in the primitives style and keeps the usual Taichi
kernel cache (compiling into an empty one takes minutes): its cold run is cold for the scene cache only.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

import smoke  # this folder is on sys.path when a script here runs

#: The child: BenchBot's CLI with a listener that writes each stage's start and end (seconds since the child began).
CHILD = """
import json, sys, time
t0 = time.monotonic()
from benchbot.core import stages
def tell(event):
    if event.kind in ("start", "end"):
        sys.stderr.write("STAGE " + json.dumps([event.kind, event.name, round(time.monotonic() - t0, 4)]) + "\\n")
        sys.stderr.flush()
from benchbot.cli.main import main
sys.argv = ["benchbot"] + sys.argv[1:]
try:
    with stages.listening(tell):
        main()
finally:
    sys.stderr.write("STAGE " + json.dumps(["exit", "", round(time.monotonic() - t0, 4)]) + "\\n")
"""


def run_once(argv: list[str], env: dict) -> dict:
    """One run of ``benchbot ARGV`` in a child process: ``{wall_s, cpu_s, loadavg, stages: {name: seconds},
    scene_from_cache, last_stage_end_s, after_stages_s}`` (seconds; ``cpu_s``: of the child and its children;
    ``loadavg``: the 1-minute load average before it; ``scene_from_cache``: no stage built a scene).

    Raises:
        RuntimeError: the command failed (its stderr's end in the message).
    """
    with open("/proc/loadavg", encoding="ascii") as f:
        load = float(f.read().split()[0])
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", CHILD, *argv], env=env, capture_output=True, text=True,
                          stdin=subprocess.DEVNULL)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    if proc.returncode != 0:
        said = "\n".join(line for line in proc.stderr.splitlines() if not line.startswith("STAGE "))
        raise RuntimeError(f"benchbot {' '.join(argv)} exited {proc.returncode}:\n{said[-3000:]}")
    seconds: dict[str, float] = {}
    started: dict[str, float] = {}
    last_end, exit_at = 0.0, None
    for line in proc.stderr.splitlines():
        if not line.startswith("STAGE "):
            continue
        kind, name, at = json.loads(line[6:])
        if kind == "start":
            started[name] = at
        elif kind == "end" and name in started:
            seconds[name] = round(seconds.get(name, 0.0) + at - started.pop(name), 3)
            last_end = max(last_end, at)
        elif kind == "exit":
            exit_at = at
    return {"wall_s": round(wall, 3), "cpu_s": round(cpu, 3), "loadavg": load, "stages": seconds,
            "scene_from_cache": "building the scene" not in seconds,
            "last_stage_end_s": round(last_end, 3),
            "after_stages_s": round((exit_at if exit_at is not None else wall) - last_end, 3)}


def folder_bytes(folder: str) -> int:
    """Bytes of the regular files under ``folder`` (0 when it does not exist)."""
    total = 0
    for root, _, names in os.walk(folder):
        total += sum(os.path.getsize(os.path.join(root, name)) for name in names
                     if os.path.isfile(os.path.join(root, name)))
    return total


def describe(label: str, run: dict) -> str:
    """One line of a run for people: its wall time, the seconds of each stage, what came after them, the scene
    cache's size, the CPU seconds and the load average before it."""
    parts = ", ".join(f"{name} {s:.2f} s" for name, s in run["stages"].items())
    source = "from the scene cache" if run["scene_from_cache"] else "built"
    return (f"{label:<8} {run['wall_s']:6.1f} s  (scene {source}; ready after {run['last_stage_end_s']:.1f} s: "
            f"{parts}; then {run['after_stages_s']:.1f} s to the end; scene cache "
            f"{run['scene_cache_bytes'] / 1e6:.1f} MB; {run['cpu_s']:.1f} s CPU; load {run['loadavg']:.1f})")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--env", default="miniroom:1", help="environment (default: miniroom:1)")
    ap.add_argument("--example", default="semslam_geometric", help="example solution (default: semslam_geometric)")
    ap.add_argument("--warm", type=int, default=2, help="warm runs after the cold one (default: 2)")
    ap.add_argument("--prepare", action="store_true", help="run benchbot sim prepare ENV into the empty caches first")
    ap.add_argument("--json", action="store_true", help="print one JSON object instead of lines")
    args = smoke.parse_args(ap, argv, example="hello_passive", warm=1)
    if args.smoke:
        smoke.left_out("the empty kernel cache", "compiling the kernels takes minutes on 2 cores; this run keeps "
                       "Taichi's usual cache, so only the scene cache starts empty")
    command = ["batch", "--example", args.example, "--envs", args.env]
    runs, prepared = [], None
    with tempfile.TemporaryDirectory(prefix="benchbot-first-run-") as tmp:
        # in the command's own process, every run: the simulator service (benchmarks/service_warm.py) would keep
        # the first run's Taichi and kernels for the next
        env = dict(os.environ, BENCHBOT_CACHE_DIR=os.path.join(tmp, "cache"), BENCHBOT_SERVICE="off")
        if not args.smoke:
            env["TI_OFFLINE_CACHE_FILE_PATH"] = os.path.join(tmp, "taichi")  # read by ti.init: an empty cache
        if args.prepare:
            try:
                prepared = run_once(["sim", "prepare", args.env], env)
            except RuntimeError as exc:
                raise SystemExit(str(exc)) from None
            prepared["label"] = "prepare"
            prepared["scene_cache_bytes"] = folder_bytes(env["BENCHBOT_CACHE_DIR"])
            if not args.json:
                print(describe("prepare", prepared), flush=True)
        for i in range(1 + max(0, args.warm)):
            try:
                run = run_once([*command, "--output-dir", os.path.join(tmp, "runs")], env)
            except RuntimeError as exc:  # the command failed (a bad --env or --example): its own message
                raise SystemExit(str(exc)) from None
            run["label"] = ("first" if args.prepare else "cold") if i == 0 else f"warm {i}"
            run["scene_cache_bytes"] = folder_bytes(env["BENCHBOT_CACHE_DIR"])  # what the cache holds after it
            runs.append(run)
            if not args.json:
                print(describe(run["label"], run), flush=True)
    out = {"command": "benchbot " + " ".join(command), "style": os.environ.get("BENCHBOT_SIM_STYLE", "furnished"),
           "empty_kernel_cache": not args.smoke, "cpus": os.cpu_count(), "prepare": prepared, "runs": runs}
    if args.json:
        print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
