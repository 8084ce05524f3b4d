"""``benchbot run``'s warm start, with and without the resident simulator service (docs/service.md): the seconds
from starting the command until it says ``backend ready`` (it then serves the original client and ``benchbot
submit``), median of ``--runs`` starts of each mode taken in turns (so a busy machine slows both alike), after one
start of each that fills the caches and starts the service. Each start is then ended with Ctrl-C (SIGINT), as a user
ends it; the seconds from Ctrl-C to the command's exit are printed too.

    uv run python benchmarks/run_warm_start.py [--env miniroom:1] [--runs 5] [--camera-size 640x480] [--json]

Each start is a fresh process running BenchBot's command-line entry point (what the ``benchbot`` script runs; ``uv
run``'s own start, about 0.1 s, is not in it) on a free port, without the live view. The service is this script's
own: its socket folder is in a temporary ``XDG_RUNTIME_DIR``, and it is stopped at the end. ``--smoke``: one start of
each at 64x48.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import smoke  # this folder is on sys.path when a script here runs

READY = "backend ready at "
#: What a command says when it started the service, or replaced it (other code: an edited checkout).
STARTED = ("started the simulator service", "replaced the simulator service")
#: The flags of each mode.
MODES = {"in-process": ["--no-service"], "service": []}
#: Seconds a run may take to exit after Ctrl-C before it is killed (and the benchmark fails, saying so).
STOP_TIMEOUT_S = 60.0


def start_once(argv: list[str], env: dict) -> dict:
    """One ``benchbot run ARGV``: ``{ready_s, stop_s, started}`` (seconds until it said ``backend ready``; from
    SIGINT to its exit; whether it started or replaced the service: a checkout edited meanwhile has another key).

    Raises:
        RuntimeError: it ended before serving, did not exit 130 on Ctrl-C (its stderr's end in the message), or
            did not exit within :data:`STOP_TIMEOUT_S` of it (then it is killed)."""
    t = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-m", "benchbot.cli", "run", *argv], env=env, stdin=subprocess.DEVNULL,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    lines = []
    for line in proc.stderr:
        lines.append(line.rstrip("\n"))
        if READY in line:
            break
    ready = time.monotonic() - t
    if not lines or READY not in lines[-1]:
        proc.wait()
        raise RuntimeError(f"benchbot run {' '.join(argv)} ended before serving:\n" + "\n".join(lines)[-3000:])
    t_stop = time.monotonic()
    proc.send_signal(signal.SIGINT)
    try:
        rest = proc.communicate(timeout=STOP_TIMEOUT_S)[1]
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        raise RuntimeError(f"benchbot run did not exit within {STOP_TIMEOUT_S:.0f} s of Ctrl-C (SIGINT); killed it "
                           "(a command started with SIGINT ignored, as by `nohup` or `&` in a script, never sees "
                           "Ctrl-C)") from None
    code = proc.returncode
    if code != 130:
        raise RuntimeError(f"benchbot run exited {code} on Ctrl-C:\n{rest[-3000:]}")
    started = any(said in line for line in lines for said in STARTED)
    return {"ready_s": round(ready, 3), "stop_s": round(time.monotonic() - t_stop, 3), "started": started}


def summary(runs: list[dict], key: str) -> dict:
    values = [run[key] for run in runs]
    return {"median": round(statistics.median(values), 3), "min": min(values), "max": max(values)}


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--env", default="miniroom:1")
    ap.add_argument("--camera-size", default="640x480")
    ap.add_argument("--runs", type=int, default=5, help="timed starts of each mode (after one untimed start of each)")
    ap.add_argument("--json", action="store_true")
    args = smoke.parse_args(ap, argv, runs=1, camera_size="64x48")
    with tempfile.TemporaryDirectory(prefix="run-warm-start-") as tmp:
        runtime = Path(tmp, "runtime")
        runtime.mkdir(mode=0o700)
        env = {**os.environ, "XDG_RUNTIME_DIR": str(runtime), "COLUMNS": "400"}
        env.pop("BENCHBOT_SERVICE", None)
        base = ["-e", args.env, "--port", "0", "--no-tui", "--camera-size", args.camera_size]
        try:
            for flags in MODES.values():  # fills the caches; starts the service
                start_once([*base, *flags], env)
            timed: dict[str, list[dict]] = {mode: [] for mode in MODES}
            for _ in range(args.runs):
                for mode, flags in MODES.items():
                    timed[mode].append(start_once([*base, *flags], env))
                    print(f"{mode}: {timed[mode][-1]}", file=sys.stderr, flush=True)
        finally:
            subprocess.run([sys.executable, "-m", "benchbot.cli", "service", "stop"], env=env,
                           capture_output=True, stdin=subprocess.DEVNULL)
    result = {"env": args.env, "camera_size": args.camera_size, "runs": args.runs,
              "load_average": [round(x, 2) for x in os.getloadavg()]}
    for mode, runs in timed.items():
        cold = sum(run["started"] for run in runs)  # (re)started the service: not a warm start, left out
        warm = [run for run in runs if not run["started"]] or runs
        result[mode] = {"ready_s": summary(warm, "ready_s"), "stop_s": summary(warm, "stop_s"), "starts": runs,
                        "starts_that_started_the_service": cold}
        ready, stop = result[mode]["ready_s"], result[mode]["stop_s"]
        print(f"{mode:<11} {ready['median']:.2f} s to ready ({ready['min']:.2f}-{ready['max']:.2f}), "
              f"Ctrl-C to exit {stop['median']:.2f} s" + (f"; left out: {cold} of {len(runs)} starts that "
                                                            "(re)started the service (an edited checkout has "
                                                            "another key)" if cold else ""))
    if args.json:
        print(json.dumps(result, indent=2))
    return result


if __name__ == "__main__":
    main()
