"""Where the simulator's cold start goes: a fresh process loads an environment as an episode's backend does
(``TaichiSimBackend.load_scene``: the scene, Taichi, the BVH, the shadow maps, the baked light, the kernels of its
first frame) with an empty Taichi kernel cache and an empty scene cache, and each kernel's compile is timed on its
own.

    uv run python benchmarks/cold_start.py [--env miniroom:1] [--arch cpu] [--runs 1] [--compare] [--cached]
        [--keep-kernels DIR] [--json]

Per kernel: its front end (Taichi turning its Python into IR, ``Kernel.materialize``) and its compile (Taichi's IR
passes and LLVM's, ``Program.compile_kernel``), each in wall seconds and in CPU seconds of the whole process (Taichi
compiles a kernel's tasks on worker threads too); per stage its wall seconds (:mod:`benchbot.core.stages`); the
process's wall and CPU seconds; the load average before and after (``/proc/loadavg``: on a shared machine the wall
seconds grow with it, the CPU seconds much less). The sensors' kernels are launched one at a time
(``Renderer.kernel_timer``), not through their compiled graph, so that each is timed alone: the graph compiles the
same kernels at its first run. ``--compare`` runs each case with quick compiles on and off
(``BENCHBOT_TAICHI_QUICK_COMPILE``, :mod:`benchbot_sim_taichi.render.compile_options`), alternating, and prints the
median of ``--runs`` runs of each; ``--cached`` follows each cold load with a second fresh process that loads the
environment with the kernels the first one compiled (an empty scene cache again): the case's ``kernels cached``
figures, what a later first command costs; ``--keep-kernels DIR`` copies the kernels that the last cold load with
quick compiles compiled into DIR (a Taichi offline cache: ``TI_OFFLINE_CACHE_FILE_PATH=DIR`` for later runs);
``--taichi-profile FILE`` writes Taichi's scoped profiler (seconds per IR pass) of
the last run to FILE. ``--smoke`` loads miniroom:1 in the primitives style with the usual kernel cache (its compile
seconds are then load times; with ``--cached`` too).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile

import smoke  # this folder is on sys.path when a script here runs

#: The child: one cold load, timed; prints one JSON line.
CHILD = r"""
import contextlib, json, os, re, sys, time
t0, cpu0 = time.perf_counter(), time.process_time()
env_name, arch, profile = sys.argv[1], sys.argv[2], sys.argv[3]
load_before = open("/proc/loadavg").read().split()[0]
from taichi._lib import core as ti_core
from taichi.lang import kernel_impl
kernels, names, stages_s, started = {}, {}, {}, {}

def entry(name):
    return kernels.setdefault(name, {"front_end_s": 0.0, "front_end_cpu_s": 0.0, "compile_s": 0.0,
                                     "compile_cpu_s": 0.0, "compiles": 0})

real_compile = ti_core.Program.compile_kernel
def compile_kernel(self, config, caps, kernel):
    name = names.get(id(kernel), "?")
    t, c = time.perf_counter(), time.process_time()
    try:
        return real_compile(self, config, caps, kernel)
    finally:
        if id(kernel) not in done:  # later calls find it compiled (in memory)
            done.add(id(kernel))
            e = entry(name)
            e["compile_s"] += time.perf_counter() - t
            e["compile_cpu_s"] += time.process_time() - c
            e["compiles"] += 1
done = set()
ti_core.Program.compile_kernel = compile_kernel

# patched before Taichi starts: the quick compiles (compile_options) wrap this one, so they are timed as compiles
real_materialize = kernel_impl.Kernel.materialize
def materialize(self, key=None, args=None, arg_features=None):
    before = set(map(id, self.compiled_kernels.values()))
    t, c = time.perf_counter(), time.process_time()
    real_materialize(self, key, args, arg_features)
    new = [k for k in self.compiled_kernels.values() if id(k) not in before]
    for k in new:
        names[id(k)] = self.func.__name__
    if new:
        e = entry(self.func.__name__)
        e["front_end_s"] += time.perf_counter() - t
        e["front_end_cpu_s"] += time.process_time() - c
kernel_impl.Kernel.materialize = materialize

import yaml
from benchbot.core import stages
from benchbot_sim_taichi import plugin
from benchbot_sim_taichi.backend import TaichiSimBackend
from benchbot_sim_taichi.render import renderer as R

real_init = R.Renderer.__init__
def init(self, *args, **kwargs):
    real_init(self, *args, **kwargs)
    self.kernel_timer = lambda name: contextlib.nullcontext()  # one launch per kernel, no graph
R.Renderer.__init__ = init

def tell(event):
    if event.kind == "start":
        started[event.name] = time.perf_counter()
    elif event.kind == "end" and event.name in started:
        stages_s[event.name] = stages_s.get(event.name, 0.0) + time.perf_counter() - started.pop(event.name)

from benchbot.core.registry import get_registry
environment = get_registry().scenes(env_name)[0]
with open(plugin.ROBOTS_DIR / "carter.yaml", encoding="utf-8") as f:
    robot = yaml.safe_load(f)
with stages.listening(tell):
    backend = TaichiSimBackend(robot, {"arch": arch})
    backend.load_scene(environment)
quick = os.environ.get("BENCHBOT_TAICHI_QUICK_COMPILE", "1") == "1"
out = {"env": env_name, "arch": backend._renderer.arch, "quick_compile": quick,
       "wall_s": time.perf_counter() - t0, "cpu_s": time.process_time() - cpu0,
       "loadavg_before": float(load_before), "loadavg_after": float(open("/proc/loadavg").read().split()[0]),
       "stages": stages_s, "kernels": kernels}
if profile:  # Taichi's C++ prints it on file descriptor 1: pointed at the file meanwhile
    import ctypes
    import taichi as ti
    sys.stdout.flush()
    saved = os.dup(1)
    with open(profile, "wb") as f:
        os.dup2(f.fileno(), 1)
        try:
            ti.profiler.print_scoped_profiler_info()
            ctypes.CDLL(None).fflush(None)
        finally:
            os.dup2(saved, 1)
            os.close(saved)
    with open(profile, encoding="utf-8", errors="replace") as f:
        text = re.sub(r"\x1b\[[0-9;]*m", "", f.read())
    with open(profile, "w", encoding="utf-8") as f:
        f.write(text)
backend.close()
print("\nRESULT " + json.dumps(out), flush=True)
"""


def run_once(env_name: str, arch: str, quick: bool, kernel_cache: str | None, profile: str = "") -> dict:
    """One cold load in a fresh process with an empty scene cache and Taichi's kernel cache in the folder
    ``kernel_cache`` (empty: every kernel is compiled; ``None``: the usual cache): the child's result (see the module
    docstring), seconds rounded to milliseconds.

    Raises:
        RuntimeError: the child failed (the end of its stderr in the message).
    """
    with tempfile.TemporaryDirectory(prefix="benchbot-cold-start-") as tmp:
        env = dict(os.environ, BENCHBOT_CACHE_DIR=os.path.join(tmp, "cache"),
                   BENCHBOT_TAICHI_QUICK_COMPILE="1" if quick else "0")
        if kernel_cache is not None:
            env["TI_OFFLINE_CACHE_FILE_PATH"] = kernel_cache  # read by ti.init
        proc = subprocess.run([sys.executable, "-c", CHILD, env_name, arch, profile], env=env, capture_output=True,
                              text=True, stdin=subprocess.DEVNULL)
    lines = [line for line in proc.stdout.splitlines() if line.startswith("RESULT ")]
    if proc.returncode != 0 or not lines:
        said = proc.stderr[-3000:] if proc.returncode else f"no result; its output ends:\n{proc.stdout[-3000:]}"
        raise RuntimeError(f"the cold load of {env_name} exited {proc.returncode}:\n{said}")
    return _rounded(json.loads(lines[-1][7:]))


def _rounded(value):
    if isinstance(value, float):
        return round(value, 3)
    if isinstance(value, dict):
        return {k: _rounded(v) for k, v in value.items()}
    return value


def summary(runs: list[dict]) -> dict:
    """Medians over ``runs`` (of one case): wall and CPU seconds, each stage's seconds, each kernel's compile and
    front-end seconds (wall and CPU), and the summed compile and front-end CPU seconds."""
    def med(values):
        return round(statistics.median(values), 3)

    kernels = sorted({name for run in runs for name in run["kernels"]})
    stages = sorted({name for run in runs for name in run["stages"]})
    return {
        "runs": len(runs), "wall_s": med([r["wall_s"] for r in runs]), "cpu_s": med([r["cpu_s"] for r in runs]),
        "compile_cpu_s": med([sum(k["compile_cpu_s"] for k in r["kernels"].values()) for r in runs]),
        "front_end_cpu_s": med([sum(k["front_end_cpu_s"] for k in r["kernels"].values()) for r in runs]),
        "loadavg": [r["loadavg_before"] for r in runs],
        "stages": {s: med([r["stages"].get(s, 0.0) for r in runs]) for s in stages},
        "kernels": {k: {field: med([r["kernels"].get(k, {}).get(field, 0.0) for r in runs])
                        for field in ("front_end_s", "front_end_cpu_s", "compile_s", "compile_cpu_s")}
                    for k in kernels},
    }


def describe(label: str, s: dict) -> list[str]:
    """Lines for people: the case's medians, then its kernels by compile CPU seconds."""
    lines = [f"{label}: {s['wall_s']:.1f} s wall, {s['cpu_s']:.1f} s CPU (median of {s['runs']}; load "
             f"{', '.join(f'{x:.1f}' for x in s['loadavg'])}); compiles {s['compile_cpu_s']:.1f} s CPU, front ends "
             f"{s['front_end_cpu_s']:.1f} s CPU",
             "  stages: " + ", ".join(f"{name} {sec:.1f} s" for name, sec in s["stages"].items())]
    ranked = sorted(s["kernels"].items(), key=lambda kv: -kv[1]["compile_cpu_s"])
    lines += [f"  {name:<26} compile {k['compile_cpu_s']:6.2f} s CPU ({k['compile_s']:6.2f} s wall), front end "
              f"{k['front_end_cpu_s']:5.2f} s CPU" for name, k in ranked]
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--env", default="miniroom:1", help="environment (default: miniroom:1)")
    ap.add_argument("--arch", default="cpu", choices=("cpu", "cuda", "gpu"), help="Taichi arch (default: cpu)")
    ap.add_argument("--runs", type=int, default=1, help="runs of each case (default: 1)")
    ap.add_argument("--compare", action="store_true", help="quick compiles on and off, alternating")
    ap.add_argument("--cached", action="store_true",
                    help="after each cold load, load again in a fresh process with the kernels it compiled")
    ap.add_argument("--keep-kernels", default="", metavar="DIR",
                    help="copy the kernels the last cold load (quick compiles) compiled into DIR")
    ap.add_argument("--taichi-profile", default="", metavar="FILE", help="write Taichi's scoped profiler to FILE")
    ap.add_argument("--json", action="store_true", help="print one JSON object instead of lines")
    args = smoke.parse_args(ap, argv, cached=True)
    if args.smoke and args.keep_kernels:
        ap.error("--keep-kernels keeps what a cold load compiled: a smoke run compiles nothing")
    if args.smoke:
        smoke.left_out("the empty kernel cache", "compiling the kernels takes a minute or more on 2 cores; this run "
                       "loads them from the usual cache, so its compile seconds are load times")
    try:
        runs = measure(args)
    except RuntimeError as exc:
        raise SystemExit(str(exc)) from None
    out = {"env": args.env, "arch": runs[LABELS[True]][0]["arch"], "empty_kernel_cache": not args.smoke,
           "cpus": os.cpu_count(), "cases": {label: {"summary": summary(r), "runs": r} for label, r in runs.items()}}
    if args.json:
        print(json.dumps(out))
    else:
        for label, r in runs.items():
            print("\n".join(describe(label, summary(r))))
    return 0


#: Each case's label by whether its kernels compile quickly; ``CACHED`` is added to a cached load's label.
LABELS = {True: "quick compiles", False: "every kernel with Taichi's CFG pass"}
CACHED = ", kernels cached"


def measure(args: argparse.Namespace) -> dict[str, list[dict]]:
    """The runs of each case (label -> results of :func:`run_once`): ``args.runs`` cold loads of each, alternating,
    each with a kernel cache of its own (the usual one with ``args.smoke``), and with ``args.cached`` a load after
    each with the kernels it compiled.

    Raises:
        RuntimeError: a load failed (its message says how).
    """
    cases = [True, False] if args.compare else [True]
    runs: dict[str, list[dict]] = {}
    profile = os.path.abspath(args.taichi_profile) if args.taichi_profile else ""
    for _ in range(max(1, args.runs)):
        for quick in cases:
            with tempfile.TemporaryDirectory(prefix="benchbot-cold-kernels-") as kernels:
                cache = None if args.smoke else kernels
                runs.setdefault(LABELS[quick], []).append(run_once(args.env, args.arch, quick, cache, profile))
                if args.cached:
                    runs.setdefault(LABELS[quick] + CACHED, []).append(run_once(args.env, args.arch, quick, cache))
                if args.keep_kernels and quick:
                    shutil.copytree(kernels, args.keep_kernels, dirs_exist_ok=True)
    return runs


if __name__ == "__main__":
    sys.exit(main())
