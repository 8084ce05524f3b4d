"""A warm sweep end to end: ``benchbot batch --example semslam_geometric --envs-batch bear_all --repeat 3 --workers N``
(30 episodes, 4,587 frames) as a user runs it, through the simulator service and without it, with where each
episode's time goes and how busy the GPUs were.

Each mode (``--modes service,no-service``) runs once to warm up (kernel and scene caches, the service and its warm
workers), then ``--runs`` times, timed. For every timed run it reports:

* the wall time of the whole ``benchbot batch`` process and the frames rendered (the episodes' steps);
* per stage, summed over the episodes and per episode, from the command's progress lines (``--no-tui``), each
  timestamped as it arrives: ``command start`` (interpreter, plugins, planning: until the first episode starts),
  per episode ``waiting`` (started, no backend stage yet), the backend's stages (``loading the scene``,
  ``starting Taichi``, ``loading the BVH…``, ``compiling kernels``…: what the warm service skips; the command prints
  the next line at the solution's first step, so the backend's last stage is reported with the solution's start as
  ``… + solution start``: serving the backend, the sandbox, the solution's interpreter and imports, its first
  request), ``solution steps`` (from its first step to its exit: every step's round trip, render and the solution's
  own work) and ``per frame`` (those seconds over the frames), and ``evaluation and writing`` (from the last
  episode's end to the command's exit);
* the GPUs' utilisation sampled by ``nvidia-smi`` every second (mean and peak per GPU; none without ``nvidia-smi``);
* whether every run's results, trajectories and scores files are byte-identical (across runs and modes), and if
  not, which files differ (``differing_files``; each run's ``files`` gives every file's digest);
* whether every episode of an environment, in every run, wrote the same results file
  (``distinct_results_per_environment``: 1 each when they did; ``--repeat`` runs each environment several times).

    python benchmarks/sweep.py [--workers 16] [--repeat 3] [--envs-batch bear_all | --envs ENV,...]
        [--example semslam_geometric] [--arch cuda|cpu] [--camera-size WxH] [--modes service,no-service] [--runs 1]
        [--warm-up MODES|none] [--batch-args ARGS] [--output-dir DIR] [--json] [--json-file PATH] [--smoke]

``--json-file PATH``: the JSON summary is also written there (atomically) after every run, so a sweep cut short
(a time limit) leaves the runs it finished.

``--smoke``: ``semslam_geometric`` on miniroom:1 twice at 64×48 with two workers, both modes, one timed run each.
The service it uses is its own (a socket folder of its own, stopped at the end).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import smoke  # this folder is on sys.path when a script here runs

#: A progress line of ``benchbot batch --no-tui``: ``[k/N] label  what it does …`` or
#: ``[k/N] label  ok  48 steps …``.
LINE = re.compile(r"^\[(\d+)/(\d+)\] (.+?)  (.+?)(?: …)?$")
ENDED = re.compile(r"^(ok|failed|error|timeout|no_results|bad_results|resource_limit)\b")


class GpuSampler:
    """``nvidia-smi`` sampling every GPU's utilisation once a second in the background (nothing without it)."""

    def __init__(self) -> None:
        self.samples: dict[int, list[int]] = {}
        self.proc = None
        if shutil.which("nvidia-smi"):
            self.proc = subprocess.Popen(["nvidia-smi", "--query-gpu=index,utilization.gpu",
                                          "--format=csv,noheader,nounits", "-l", "1"],
                                         stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
            threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            parts = [p.strip() for p in line.split(",")]
            if len(parts) == 2 and parts[0].isdigit() and parts[1].isdigit():
                self.samples.setdefault(int(parts[0]), []).append(int(parts[1]))

    def stop(self) -> dict:
        """``{gpu index: {"mean_pct", "peak_pct", "samples"}}``."""
        if self.proc is not None:
            self.proc.terminate()
            self.proc.wait()
        return {k: {"mean_pct": round(sum(v) / len(v), 1), "peak_pct": max(v), "samples": len(v)}
                for k, v in sorted(self.samples.items()) if v}


def stage_name(text: str) -> str:
    """A progress line's stage without its details: ``loading the scene (miniroom:1, from the cache)`` → ``loading
    the scene``; ``starting`` → ``waiting``."""
    text = re.sub(r"\s*\(.*$", "", text).strip()
    return "waiting" if text == "starting" else text


def profile(lines: list[tuple[float, str]], t0: float, t_exit: float, steps: int) -> dict:
    """Per-stage seconds from the timestamped progress lines of one run (module docstring)."""
    per_stage: dict[str, float] = {}
    last: dict[str, tuple[float, str]] = {}  # episode -> (since, stage)
    first = ended = None
    for t, line in lines:
        match = LINE.match(line)
        if not match:
            continue
        episode, text = match[1], match[4].strip()
        first = t if first is None else first
        now = "solution steps" if text.startswith("the backend is ready") else stage_name(text)
        if episode in last:
            since, stage = last.pop(episode)
            if now == "solution steps" and stage != "waiting":  # the line comes with the solution's first step
                stage = f"{stage} + solution start"
            per_stage[stage] = per_stage.get(stage, 0.0) + t - since
        if ENDED.match(text):
            ended = t
        else:
            last[episode] = (t, now)
    out = {"command start": round((first or t_exit) - t0, 3)}
    out.update({k: round(v, 3) for k, v in per_stage.items()})
    out["evaluation and writing"] = round(t_exit - (ended or t_exit), 3)
    if steps and "solution steps" in per_stage:
        out["solution per frame"] = round(per_stage["solution steps"] / steps, 5)
    return out


def file_digests(run_dir: Path) -> dict[str, str]:
    """``{path relative to run_dir: SHA-256 (16 hex digits)}`` of every results, trajectories and scores file of a
    run directory, in path order."""
    out = {}
    for name in ("results", "trajectories", "scores.json", "episode_scores.json"):
        path = run_dir / name
        for file in sorted(path.rglob("*")) if path.is_dir() else [path]:
            if file.is_file():
                out[str(file.relative_to(run_dir))] = hashlib.sha256(file.read_bytes()).hexdigest()[:16]
    return out


def digest(files: dict[str, str]) -> str:
    """One digest (16 hex digits) of :func:`file_digests`' names and digests."""
    return hashlib.sha256(json.dumps(files, sort_keys=True).encode()).hexdigest()[:16]


def results_per_environment(results: list[dict]) -> dict[str, int]:
    """``{environment: distinct results files}`` over every episode of every run (``results/NNN_<env>_r<k>.json``,
    the environment's name and variant joined by ``_``): 1 where every episode of an environment wrote the same
    bytes, as the same solution on the same simulator should."""
    seen: dict[str, set] = {}
    for r in results:
        for name, sha in r["files"].items():
            match = re.fullmatch(r"results/\d+_(.+?)(?:_r\d+)?\.json", name)
            if match:
                seen.setdefault(match[1], set()).add(sha)
    return {env: len(shas) for env, shas in sorted(seen.items())}


def differing_files(results: list[dict]) -> list[str]:
    """The files (paths relative to a run directory) whose bytes are not the same in every run, or that some run
    lacks."""
    names = set().union(*(r["files"] for r in results)) if results else set()
    return sorted(n for n in names if len({r["files"].get(n) for r in results}) > 1)


@dataclass
class StampedRun:
    """A finished command: its exit status, its standard output, its stderr lines each stamped with
    ``time.monotonic()`` as it arrived, and the monotonic seconds at its start and exit."""

    returncode: int
    stdout: str
    lines: list[tuple[float, str]]
    t0: float
    t_exit: float


def run_stamped(command: list[str], env: dict, cwd: Path | None = None) -> StampedRun:
    """Run ``command`` to its end with ``env`` in ``cwd`` (no standard input), stamping each of its stderr lines as
    it arrives (what :func:`profile` reads) while a thread collects its stdout.

    Raises:
        OSError: the command cannot be started."""
    lines: list[tuple[float, str]] = []
    stdout: list[str] = []
    t0 = time.monotonic()
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=cwd,
                            stdin=subprocess.DEVNULL)
    reader = threading.Thread(target=lambda: stdout.append(proc.stdout.read()), daemon=True)
    reader.start()
    for line in proc.stderr:
        lines.append((time.monotonic(), line.rstrip("\n")))
    proc.wait()
    reader.join()
    return StampedRun(proc.returncode, stdout[0] if stdout else "", lines, t0, time.monotonic())


def run_once(args: argparse.Namespace, mode: str, out: Path, env: dict) -> dict:
    """One ``benchbot batch`` of the sweep in ``mode``; its figures (module docstring)."""
    envs = ["--envs", args.envs] if args.envs else ["--envs-batch", args.envs_batch]
    command = [sys.executable, "-m", "benchbot.cli", "batch", "--example", args.example, *envs, "--repeat",
               str(args.repeat), "--workers", str(args.workers), "--arch", args.arch, "--output-dir", str(out),
               "--json", "--no-tui"] + (["--camera-size", args.camera_size] if args.camera_size else []) + \
        (["--no-service"] if mode == "no-service" else []) + shlex.split(args.batch_args)
    sampler = GpuSampler()
    run = run_stamped(command, env)
    gpus = sampler.stop()
    lines, t0, t_exit = run.lines, run.t0, run.t_exit
    if run.returncode != 0:
        tail = "\n".join(line for _, line in lines[-20:])
        sys.exit(f"the {mode} sweep failed (exit {run.returncode}):\n{tail}")
    outcome = json.loads(run.stdout)
    files = file_digests(Path(outcome["run_dir"]))
    steps = sum(e["steps"] for e in outcome["episodes"])
    devices = sorted({e["node"]["gpu"]["index"] for e in outcome["episodes"] if e.get("node", {}).get("gpu")})
    return {"mode": mode, "wall_s": round(t_exit - t0, 2), "episodes": len(outcome["episodes"]), "frames": steps,
            "ok": sum(e["status"] == "ok" for e in outcome["episodes"]), "gpus_used": devices,
            "gpu_utilisation": gpus, "stages_s": profile(lines, t0, t_exit, steps),
            "digest": digest(files), "files": files}


def show(r: dict) -> None:
    gpus = ", ".join(f"GPU {k} {v['mean_pct']:.1f} % mean, {v['peak_pct']} % peak" for k, v in
                     r["gpu_utilisation"].items()) or "no GPU sampled"
    print(f"{r['mode']:>10}: {r['wall_s']:7.2f} s wall, {r['episodes']} episodes ({r['ok']} ok), {r['frames']} frames; "
          f"{gpus}; episodes on GPUs {r['gpus_used'] or '-'}")
    n = max(1, r["episodes"])
    for stage, seconds in r["stages_s"].items():
        if stage in ("command start", "evaluation and writing"):
            print(f"{'':>12}{stage:<44} {seconds:8.2f} s")
        elif stage == "solution per frame":
            print(f"{'':>12}{stage:<44} {seconds * 1000:8.2f} ms")
        else:
            print(f"{'':>12}{stage:<44} {seconds:8.2f} s summed, {seconds / n:6.2f} s per episode")


def summary(args: argparse.Namespace, results: list[dict]) -> dict:
    """The JSON summary of the runs so far: the settings, the machine's cores, GPUs asked for and load, every run,
    and whether their results are byte-identical."""
    return {"example": args.example, "envs": args.envs or args.envs_batch, "repeat": args.repeat,
            "workers": args.workers, "arch": args.arch, "cpu_count": os.cpu_count(),
            "cuda_visible_devices": os.environ.get("CUDA_VISIBLE_DEVICES"), "load_average": os.getloadavg(),
            "runs": results, "byte_identical": len({r["digest"] for r in results}) == 1,
            "differing_files": differing_files(results),
            "distinct_results_per_environment": results_per_environment(results)}


def write_partial(path: str | None, args: argparse.Namespace, results: list[dict]) -> None:
    """Write :func:`summary` of the runs so far to ``path`` (atomically: a temporary file renamed); nothing
    without a path."""
    if path:
        tmp = Path(f"{path}.tmp")
        tmp.write_text(json.dumps(summary(args, results)))
        tmp.replace(path)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=16)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--envs-batch", default="bear_all")
    ap.add_argument("--envs", default=None, help="a comma list of environments instead of --envs-batch")
    ap.add_argument("--example", default="semslam_geometric")
    ap.add_argument("--arch", default="auto")
    ap.add_argument("--camera-size", default=None, help="WIDTHxHEIGHT (default: the robot's 640x480)")
    ap.add_argument("--modes", default="service,no-service", help="comma list of service, no-service")
    ap.add_argument("--runs", type=int, default=1, help="timed runs per mode, after one warm-up run")
    ap.add_argument("--warm-up", default=None, help="comma list of the modes that get a warm-up run (default: all; "
                    "'none' where the caches are warm already, e.g. after benchbot sim prepare)")
    ap.add_argument("--batch-args", default="", help="more arguments for benchbot batch, e.g. '--no-sandbox'")
    ap.add_argument("--output-dir", default=None, help="keep the run directories here (default: a temporary one)")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--json-file", default=None, help="also write the JSON summary here after every run")
    args = smoke.parse_args(ap, argv, envs="miniroom:1", repeat=2, workers=2, camera_size="64x48", arch="cpu")
    modes = [m.strip() for m in args.modes.split(",") if m.strip()]
    if not modes or set(modes) - {"service", "no-service"} or args.runs < 1:
        ap.error("--modes takes service and/or no-service; --runs at least 1")
    with tempfile.TemporaryDirectory(prefix="benchbot-sweep-") as tmp:
        folder = Path(args.output_dir) if args.output_dir else Path(tmp)
        runtime = Path(tmp) / "runtime"
        runtime.mkdir(mode=0o700)
        env = dict(os.environ, XDG_RUNTIME_DIR=str(runtime), BENCHBOT_SERVICE="auto")  # a service of our own
        results = []
        try:
            for mode in modes:
                if args.warm_up is None or mode in args.warm_up.split(","):
                    warm = run_once(args, mode, folder / f"{mode}-warm-up", env)
                    print(f"warm-up {mode}: {warm['wall_s']:.2f} s", file=sys.stderr, flush=True)
                    results.append({**warm, "warm_up": True})
                    write_partial(args.json_file, args, results)
                for k in range(args.runs):
                    results.append(run_once(args, mode, folder / f"{mode}-{k}", env))
                    write_partial(args.json_file, args, results)
                    print(f"{mode}: {results[-1]['wall_s']:.2f} s", file=sys.stderr, flush=True)
        finally:
            subprocess.run([sys.executable, "-m", "benchbot.cli", "service", "stop"], env=env, capture_output=True,
                           timeout=120)
    figures = summary(args, results)
    same = figures["byte_identical"]
    if args.json:
        print(json.dumps(figures))
    else:
        for r in results:
            if not r.get("warm_up"):
                show(r)
        print(f"byte-identical: {'yes' if same else 'NO'}")
        varied = {env: n for env, n in figures["distinct_results_per_environment"].items() if n > 1}
        print("every episode of an environment wrote the same results: "
              + ("yes" if not varied else "NO (" + ", ".join(f"{env}: {n} different" for env, n in varied.items()) + ")"))
        for name in figures["differing_files"]:
            print(f"  differs: {name} ({', '.join(r['files'].get(name, 'missing') for r in results)})")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
