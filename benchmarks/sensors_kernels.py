"""Where a fast-mode sensor frame's time goes: each all-sensors kernel of the Taichi simulator timed on its own.

    python benchmarks/sensors_kernels.py --env house:1 [--arch cpu|cuda] [--batch N] [--frames 30] [--tasks] [--json]

Renders full sensor frames (640×480 RGB + depth + class/instance segmentation + a 360-beam laser scan, fast mode)
along the environment's trajectory, as ``benchmarks/render.py`` does, but launches the kernels of
``benchbot_sim_taichi.render.sensors.sensors_kernels`` one by one (``Renderer.kernel_timer``) with a device synchronisation
before and after each, so each kernel's wall-clock time is its own (on CUDA the renderer otherwise launches them as
one compiled graph, which this script does not time: ``render.py`` does). On the CPU it also reports the CPU time
each kernel used over its wall-clock time (``cpu_util``: 2.0 on a 2-core machine when both cores work throughout).

``--tasks`` turns on Taichi's kernel profiler (``TI_KERNEL_PROFILER=1``, before Taichi starts) and lists the
offloaded tasks of each kernel: Taichi splits a kernel into its top-level loops (``range_for``, run in parallel) and
the serial code between them (``serial``), numbered in source order; each with its mean milliseconds per launch.
On the CPU a top-level loop is split into blocks of 512 iterations or more, one thread a block
(``codegen_cpu.cpp``'s adaptive block size in Taichi 1.7), so a loop of fewer than 1,024 iterations runs on one
thread.

JSON keys: ``env``, ``arch``, ``batch``, ``frames``, ``width``, ``height``, ``fps`` (frames per second with the
synchronisations), ``kernels`` ({name: {``ms_per_launch``, ``us_per_frame``, ``cpu_util`` (CPU only)}}), ``tasks``
({task: ms per launch}, with ``--tasks``), ``triangles``, ``shadow_rays`` (whether the frames are shaded with the code of
shadow rays, ``Renderer.shadow_rays``: not when every light has a shadow map), ``machine``, ``cpu_count``.
"""

from __future__ import annotations

import argparse
import collections
import contextlib
import json
import math
import os
import platform
import re
import resource
import sys
import time

import numpy as np

import smoke  # this folder is on sys.path when a script here runs


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--env", default="house:1", help="environment NAME:VARIANT (default house:1)")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--arch", default=os.environ.get("BENCHBOT_TAICHI_ARCH", "cpu"), choices=("cpu", "cuda"))
    ap.add_argument("--batch", type=int, default=1, help="cameras (and laser scans) per launch")
    ap.add_argument("--frames", type=int, default=30, help="frames timed (rounded up to whole launches)")
    ap.add_argument("--warmup", type=int, default=3, help="launches before the timing (the first compiles)")
    ap.add_argument("--tasks", action="store_true", help="also time each kernel's offloaded tasks (Taichi's "
                                                          "kernel profiler)")
    ap.add_argument("--json", action="store_true")
    args = smoke.parse_args(ap, argv, env="miniroom:4", width=32, height=24, frames=2, warmup=1)
    if args.width < 1 or args.height < 1 or args.batch < 1 or args.frames < 1 or args.warmup < 1:
        ap.error("--width, --height, --batch, --frames and --warmup must be at least 1")
    if args.tasks:
        os.environ["TI_KERNEL_PROFILER"] = "1"  # read by ti.init, which the renderer calls

    from benchbot_worlds import bear
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics  # (imports Taichi, its banner sent to stderr)
    from benchbot_worlds.scene.build import build_scene
    from trajectory_views import trajectory_views  # this folder is on sys.path when a script here runs

    import taichi as ti

    envs = {f"{e['name']}:{e['variant']}": e for e in bear.environment_specs()}
    if args.env not in envs:
        ap.error(f"unknown environment {args.env}; one of {sorted(envs)}")
    scene = build_scene(envs[args.env])
    r = Renderer(args.arch)
    r.set_scene(scene)
    r.sync()
    W, H, B = args.width, args.height, args.batch
    K = intrinsics(W, H, 90.0)
    cams, lidars, angles = trajectory_views(scene)
    launches = max(1, math.ceil(args.frames / B))

    wall, cpu = collections.defaultdict(float), collections.defaultdict(float)
    timing = False

    @contextlib.contextmanager
    def timer(name):
        r.sync()
        t, used = time.perf_counter(), _cpu_seconds()
        yield
        r.sync()
        if timing:
            wall[name] += time.perf_counter() - t
            cpu[name] += _cpu_seconds() - used

    r.kernel_timer = timer

    def launch(i):
        idx = [(i * B + b) % len(cams) for b in range(B)]
        r.render_sensors(K, np.stack([cams[k] for k in idx]), W, H, np.stack([lidars[k] for k in idx]), angles,
                         to_host=False)

    for i in range(args.warmup):
        launch(i)
    r.sync()
    if args.tasks:
        ti.profiler.clear_kernel_profiler_info()
    timing = True
    t0 = time.perf_counter()
    for i in range(launches):
        launch(i)
    r.sync()
    seconds = time.perf_counter() - t0
    kernels = {}
    for name, s in wall.items():
        kernels[name] = {"ms_per_launch": 1e3 * s / launches, "us_per_frame": 1e6 * s / launches / B}
        if r.arch == "cpu":
            kernels[name]["cpu_util"] = cpu[name] / s
    out = {"env": args.env, "arch": r.arch, "batch": B, "frames": launches * B, "width": W, "height": H,
           "fps": launches * B / seconds, "kernels": kernels, "triangles": int(scene.tri_v.shape[0]),
           "shadow_rays": r.shadow_rays,
           "machine": platform.processor() or platform.machine(), "cpu_count": os.cpu_count()}
    if args.tasks:
        from benchbot_sim_taichi.render.sensors import sensors_kernels

        out["tasks"] = _task_times(launches, {k.__name__ for k in sensors_kernels(r.arch, r.shadow_rays)})
    if args.json:
        print(json.dumps(out, indent=1))
    else:
        print(f"{args.env} {W}x{H} all sensors, {r.arch}, {B} per launch: {out['fps']:.1f} fps with a "
              f"synchronisation around each kernel")
        for name, k in kernels.items():
            util = f"  cpu_util {k['cpu_util']:.2f}" if "cpu_util" in k else ""
            print(f"  {name:20s} {k['ms_per_launch']:9.3f} ms/launch {k['us_per_frame']:10.1f} us/frame{util}")
        for name, ms in out.get("tasks", {}).items():
            print(f"    {name:40s} {ms:9.3f} ms/launch")
    return 0


def _cpu_seconds() -> float:
    """User + system CPU seconds of this process so far."""
    u = resource.getrusage(resource.RUSAGE_SELF)
    return u.ru_utime + u.ru_stime


def _task_times(launches: int, kernels: set[str]) -> dict[str, float]:
    """{``kernel #i (range_for|serial)``: mean ms per launch} of the offloaded tasks of the named ``kernels`` that
    Taichi's kernel profiler recorded since it was last cleared, largest first."""
    from taichi.profiler.kernel_profiler import get_default_kernel_profiler

    profiler = get_default_kernel_profiler()
    profiler._update_records()  # Taichi 1.7 has no public call that lists the records by name
    totals: dict[str, float] = collections.defaultdict(float)
    for record in profiler._traced_records:
        m = re.fullmatch(r"(.+)_c\d+_\d+_kernel_(\d+)_(range_for|serial)", record.name)
        if m and m.group(1) in kernels:
            totals[f"{m.group(1)} #{m.group(2)} ({m.group(3)})"] += record.kernel_time
    return {k: v / launches for k, v in sorted(totals.items(), key=lambda kv: -kv[1])}


if __name__ == "__main__":
    sys.exit(main())
