"""Where a command's CPU goes: run a command and report the CPU seconds that every process on the machine used while it
ran (the command, its solution, the simulator service and its workers), grouped by kind, with the most threads each
kind had. Linux only: it samples ``/proc/PID/task/TID/stat`` (user + system time) every ``--interval`` seconds, so a
thread that lives shorter than that is missed, and any other work on the machine is counted too (run it on a quiet
machine).

What it found (2 × H100 host, 32 cores): `benchbot eval` of one results file used 4.3–4.8 s of CPU in 0.6–1.0 s wall,
with 32 threads: NumPy's OpenBLAS, one thread per core, spinning after each product (the command now loads NumPy
with one OpenBLAS thread: ``benchbot.cli.main.import_numpy_with_one_blas_thread``).

    python benchmarks/cpu_by_process.py [--interval 0.05] [--json] [-- COMMAND ...]

Without a command it runs README command 1 (``python -m benchbot.cli batch --example semslam_geometric --envs
miniroom:1``). ``--smoke`` runs ``python -m benchbot.cli eval`` of an empty results file (its one-line error is the
point: the command starts, loads NumPy and exits).
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import subprocess
import sys
import tempfile
import time

import smoke  # this folder is on sys.path when a script here runs

#: Kinds of process, by a word of their command line (the first that matches), in the order they are tried.
KINDS = ("benchbot.service.worker", "benchbot.service.daemon", "socket_relay", "bwrap", "benchbot.cli",
         "benchbot", "python")
README_COMMAND_1 = [sys.executable, "-m", "benchbot.cli", "batch", "--example", "semslam_geometric", "--envs",
                    "miniroom:1"]


def snapshot() -> dict[tuple[int, int], tuple[str, float]]:
    """Every thread's ``(pid, tid) → (command line (first 200 characters), CPU seconds so far)``; processes that end
    while they are read are left out."""
    hz = os.sysconf("SC_CLK_TCK")
    threads = {}
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                cmd = f.read().replace(b"\0", b" ").decode(errors="replace")[:200]
            for tid in os.listdir(f"/proc/{pid}/task"):
                with open(f"/proc/{pid}/task/{tid}/stat") as f:
                    fields = f.read().rsplit(")", 1)[1].split()
                threads[(int(pid), int(tid))] = (cmd, (int(fields[11]) + int(fields[12])) / hz)
        except (OSError, ValueError, IndexError):
            continue
    return threads


def kind_of(cmd: str) -> str:
    """The kind of a process from its command line: the first of :data:`KINDS` in it, the example's name for a
    solution, else the program's name."""
    if "semslam_geometric.py" in cmd or "semslam_detector.py" in cmd:
        return "the solution"
    for word in KINDS:
        if word in cmd:
            return word
    return os.path.basename(cmd.split(" ", 1)[0]) or "(ended)"


def measure(argv: list[str], interval: float) -> dict:
    """Run ``argv`` (its output discarded) and return ``{wall_s, returncode, kinds: {kind: {cpu_s, processes,
    max_threads}}}``: CPU seconds each kind of process used while it ran.

    Raises:
        OSError: ``argv`` cannot be started (no such program, not executable)."""
    before = snapshot()
    last: dict[tuple[int, int], tuple[str, float]] = {}
    peak_threads: collections.Counter = collections.Counter()
    t0 = time.perf_counter()
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL)
    while True:
        done = proc.poll() is not None
        now = snapshot()
        for pid, n in collections.Counter(pid for pid, _ in now).items():
            peak_threads[pid] = max(peak_threads[pid], n)
        for key, (cmd, cpu) in now.items():
            seen_cmd = last[key][0] if key in last else ""
            last[key] = (seen_cmd or cmd, cpu)  # an ended process's command line is empty: keep the one seen
        if done:
            break
        time.sleep(interval)
    wall = time.perf_counter() - t0
    kinds: dict[str, dict] = {}
    for (pid, tid), (cmd, cpu) in last.items():
        used = cpu - before.get((pid, tid), ("", 0.0))[1]
        if used <= 0:
            continue
        k = kinds.setdefault(kind_of(cmd), {"cpu_s": 0.0, "processes": set(), "max_threads": 0})
        k["cpu_s"] += used
        k["processes"].add(pid)
        k["max_threads"] = max(k["max_threads"], peak_threads[pid])
    out = {name: {"cpu_s": round(k["cpu_s"], 3), "processes": len(k["processes"]), "max_threads": k["max_threads"]}
           for name, k in sorted(kinds.items(), key=lambda item: -item[1]["cpu_s"])}
    return {"wall_s": round(wall, 3), "returncode": proc.returncode, "kinds": out}


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    split = argv.index("--") if "--" in argv else len(argv)
    own, command = argv[:split], argv[split + 1:]
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--interval", type=float, default=0.05, help="seconds between two samples of /proc")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = smoke.parse_args(ap, own, style=None)
    if not sys.platform.startswith("linux"):
        ap.error("it reads /proc: Linux only")
    if args.interval <= 0:
        ap.error("--interval must be more than 0 s")
    with tempfile.TemporaryDirectory(prefix="benchbot-cpu-") as tmp:
        if args.smoke and not command:
            empty = os.path.join(tmp, "empty.json")
            open(empty, "w").close()
            command = [sys.executable, "-m", "benchbot.cli", "eval", empty, "-o", os.path.join(tmp, "scores.json")]
        try:
            figures = measure(command or README_COMMAND_1, args.interval)
        except OSError as exc:
            ap.error(f"cannot start {' '.join(command or README_COMMAND_1)}: {exc.strerror or exc}")
    figures["command"] = command or README_COMMAND_1
    if args.json:
        print(json.dumps(figures))
        return 0
    total = sum(k["cpu_s"] for k in figures["kinds"].values())
    print(f"CPU of the command and every process started meanwhile: {total:.2f} s in {figures['wall_s']:.2f} s wall "
          f"(exit {figures['returncode']})")
    for name, k in figures["kinds"].items():
        print(f"  {k['cpu_s']:8.2f} s  {k['processes']:3d} processes  at most {k['max_threads']:3d} threads  {name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
