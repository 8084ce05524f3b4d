"""README command 1 (``benchbot batch --example semslam_geometric --envs miniroom:1``) warm, with and without the
resident simulator service (docs/service.md): the median wall time of ``--runs`` runs of each, taken in turns (so a
busy machine slows both alike), after one run of each that fills the caches and starts the service. Also the CPU
seconds of the command and its children (the sandboxed solution), and of the service while it served the command
(the work the command left to it): on a machine busy with other work, CPU seconds change far less than wall times.
And whether every run's results and scores files are byte-identical.

Where each mode's time goes, median per stage, from the command's progress lines on stderr, each timestamped as it
arrives (``sweep.profile``): ``command start`` (the interpreter, the command's imports, the registry, planning and
the run directory, the service's connection: until the episode starts), ``waiting`` (until the backend's first
stage), the backend's stages (through the service, ``warming up kernels``: the kept scene and kernels; the command
prints the next line at the solution's first step, so this stage ends with the solution's start: the sandbox, the
solution's interpreter and imports, its first request), ``solution steps`` (from its first step to its exit: every
step's round trip and the solution's own work, its results, the sandbox's end; a slow episode's ``step K of N`` lines
count there), ``evaluation and writing`` (from the episode's end to the command's exit: scoring, the run directory's
files, the table, the process's exit).

    uv run python benchmarks/service_warm.py [--env miniroom:1] [--example semslam_geometric] [--runs 5]
        [--modes in-process,service] [--json]

Each run is a fresh process running BenchBot's command-line entry point (what the ``benchbot`` script runs; ``uv
run``'s own start, about 0.1 s, is not in it), in a run directory under a temporary folder. The service is one of
this script's own: its socket folder is in a temporary ``XDG_RUNTIME_DIR``, and it is stopped at the end.
``--modes service`` runs only the service's (where the in-process runs would cost a GPU host's time to no purpose);
the results are then compared among its runs.
``--smoke`` runs ``hello_passive`` once each, in the primitives style.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import smoke  # this folder is on sys.path when a script here runs
from sweep import profile, run_stamped

#: The stage of a slow episode's progress line ``step 28 of 48 (the solution runs), 0:11``: its solution's steps.
STEP_LINE = re.compile(r"^step \d+ of \d+$")
#: The files of a run directory that must not depend on where the simulator ran.
COMPARED = ("results", "scores.json", "episode_scores.json")


def run_once(argv: list[str], env: dict, cwd: Path) -> dict:
    """One ``benchbot ARGV`` in a child process: ``{wall_s, cpu_s, run_dir, stages_s}`` (``cpu_s``: user + system
    seconds of the child and what it waited for; ``stages_s``: seconds per stage, from its progress lines (module
    docstring)).

    Raises:
        RuntimeError: the command failed (its stderr's end in the message)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    run = run_stamped([sys.executable, "-m", "benchbot.cli", *argv, "--json"], env, cwd)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if run.returncode != 0:
        tail = "\n".join(line for _, line in run.lines)[-3000:]
        raise RuntimeError(f"benchbot {' '.join(argv)} exited {run.returncode}:\n{tail}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    outcome = json.loads(run.stdout)
    steps = sum(e.get("steps", 0) for e in outcome.get("episodes", []))
    return {"wall_s": round(run.t_exit - run.t0, 3), "cpu_s": round(cpu, 3), "run_dir": outcome["run_dir"],
            "stages_s": steps_as_one(profile(run.lines, run.t0, run.t_exit, steps), steps)}


def steps_as_one(stages: dict[str, float], steps: int) -> dict[str, float]:
    """``stages`` with the stages of the lines ``step K of N`` (a slow episode's progress) added to ``solution
    steps``, whose per-frame figure is computed again over ``steps`` frames."""
    out = {name: seconds for name, seconds in stages.items() if not STEP_LINE.match(name)}
    if "solution steps" in out:
        out["solution steps"] = round(sum(v for k, v in stages.items() if k == "solution steps" or STEP_LINE.match(k)),
                                      3)
        if steps:
            out["solution per frame"] = round(out["solution steps"] / steps, 5)
    return out


def median_stages(runs: list[dict]) -> dict[str, float]:
    """The median of each stage's seconds over ``runs`` (a stage missing from a run counts 0 there), in the order
    the stages first came."""
    names: dict[str, None] = {}
    for run in runs:
        names.update(dict.fromkeys(run["stages_s"]))
    return {name: round(statistics.median(run["stages_s"].get(name, 0.0) for run in runs), 4) for name in names}


def process_cpu_s(pid: int) -> float:
    """User + system CPU seconds process ``pid`` has used (``/proc/PID/stat``); 0.0 when it is gone."""
    try:
        with open(f"/proc/{pid}/stat") as stat:
            fields = stat.read().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def service_pid(env: dict, cwd: Path) -> int:
    """The pid of the running service (``benchbot service status --json``).

    Raises:
        RuntimeError: none runs."""
    proc = subprocess.run([sys.executable, "-m", "benchbot.cli", "service", "status", "--json"], env=env, cwd=cwd,
                          capture_output=True, text=True, stdin=subprocess.DEVNULL)
    status = json.loads(proc.stdout) if proc.returncode == 0 else {}
    if not status.get("running"):
        raise RuntimeError(f"no simulator service runs after a command that uses it:\n{proc.stderr[-2000:]}")
    return int(status["pid"])


def run_files(run_dir: str) -> dict[str, bytes]:
    """``{path relative to the run directory: bytes}`` of the :data:`COMPARED` files."""
    root = Path(run_dir)
    files: dict[str, bytes] = {}
    for name in COMPARED:
        path = root / name
        for file in sorted(path.rglob("*")) if path.is_dir() else [path]:
            if file.is_file():
                files[str(file.relative_to(root))] = file.read_bytes()
    return files


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--env", default="miniroom:1")
    ap.add_argument("--example", default="semslam_geometric")
    ap.add_argument("--runs", type=int, default=5, help="timed runs of each mode (after one untimed run of each)")
    ap.add_argument("--modes", default="in-process,service",
                    help="comma list of the modes to run: in-process (--no-service), service (both by default)")
    ap.add_argument("--json", action="store_true")
    args = smoke.parse_args(ap, argv, example="hello_passive", runs=1)
    wanted = [mode for mode in args.modes.split(",") if mode]
    if not wanted or set(wanted) - {"in-process", "service"}:
        ap.error(f"--modes {args.modes!r}: a comma list of in-process and service")
    with tempfile.TemporaryDirectory(prefix="service-warm-") as tmp:
        runtime = Path(tmp, "runtime")
        runtime.mkdir(mode=0o700)
        env = {**os.environ, "XDG_RUNTIME_DIR": str(runtime)}
        env.pop("BENCHBOT_SERVICE", None)
        command = ["batch", "--example", args.example, "--envs", args.env, "--output-dir", str(Path(tmp, "runs"))]
        modes = {mode: words for mode, words in (("in-process", command + ["--no-service"]), ("service", command))
                 if mode in wanted}
        times: dict[str, list[dict]] = {mode: [] for mode in modes}
        pid = None
        try:
            for k in range(args.runs + 1):
                for mode, words in modes.items():
                    before = process_cpu_s(pid) if pid and mode == "service" else 0.0
                    run = run_once(words, env, Path(tmp))
                    run["service_cpu_s"] = round(process_cpu_s(pid) - before, 3) if pid and mode == "service" else 0.0
                    if mode == "service" and pid is None:
                        pid = service_pid(env, Path(tmp))
                    if k:  # the first of each fills the caches and starts the service
                        times[mode].append(run)
                    print(f"{mode:10} run {k}: {run['wall_s']:.2f} s{'' if k else ' (untimed)'}", file=sys.stderr,
                          flush=True)
        finally:
            subprocess.run([sys.executable, "-m", "benchbot.cli", "service", "stop"], env=env, cwd=tmp,
                           capture_output=True, stdin=subprocess.DEVNULL)
        reference = run_files(next(iter(times.values()))[0]["run_dir"])
        identical = all(run_files(run["run_dir"]) == reference for runs in times.values() for run in runs)
    figures = {mode: {"median_wall_s": round(statistics.median(r["wall_s"] for r in runs), 2),
                      "median_cpu_s": round(statistics.median(r["cpu_s"] for r in runs), 2),
                      "median_service_cpu_s": round(statistics.median(r["service_cpu_s"] for r in runs), 2),
                      "wall_s": [r["wall_s"] for r in runs],
                      "median_stages_s": median_stages(runs)} for mode, runs in times.items()}
    figures["identical"] = identical
    if args.json:
        print(json.dumps(figures, indent=1))
    else:
        print(f"benchbot batch --example {args.example} --envs {args.env}, warm, median of {args.runs}:")
        for mode in modes:
            f = figures[mode]
            walls = ", ".join(f"{w:.2f}" for w in f["wall_s"])
            print(f"  {mode:10} {f['median_wall_s']:6.2f} s wall, {f['median_cpu_s']:5.2f} s CPU of the command, "
                  f"{f['median_service_cpu_s']:5.2f} s of the service (runs: {walls})")
            for stage, seconds in f["median_stages_s"].items():
                shown = f"{seconds * 1000:8.2f} ms" if stage == "solution per frame" else f"{seconds:8.3f} s"
                print(f"      {stage:<44} {shown}")
        print(f"  results and scores byte-identical: {'yes' if identical else 'NO'}")
    return figures


if __name__ == "__main__":
    main()
