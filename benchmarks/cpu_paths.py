"""The Taichi simulator's two ways of launching the all-sensors kernels on the CPU, timed in one process, alternating.

    python benchmarks/cpu_paths.py --env house:1 [--width 640 --height 480] [--rounds 8] [--frames 15] [--json]

Two renderers of the same scene: ``graph`` (the default: device buffers, every kernel's arguments set in C++ by the
compiled ``ti.graph``, frames copied to new NumPy arrays from the ndarrays' memory) and ``numpy``
(``Renderer(device_buffers=False)``: NumPy arrays passed to each kernel by Python, as before 23 Nov 2026). Each
renders full sensor frames (RGB + depth + class/instance segmentation + a 360-beam laser scan, fast mode, frames
delivered as new NumPy arrays) along the environment's trajectory, in bursts of ``--frames`` frames, the two paths
taking turns for ``--rounds`` rounds. A 2-core virtual machine's speed drifts by tens of per cent from minute to
minute (other guests), which makes separate runs of ``render.py`` hard to compare; bursts that alternate within a
second or two see the same drift, so the ratio of each round's two rates is steadier than either rate.

JSON keys: ``env``, ``width``, ``height``, ``rounds``, ``frames_per_burst``, ``fps`` ({path: [fps of each burst]}),
``median_fps`` ({path: median}), ``ratio_graph_over_numpy`` (median of the rounds' ratios) and its ``min``/``max``,
``shadow_rays``, ``machine``, ``cpu_count``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time

import smoke  # this folder is on sys.path when a script here runs


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--env", default="house:1", help="environment NAME:VARIANT (default house:1)")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--rounds", type=int, default=8, help="rounds of one burst of each path")
    ap.add_argument("--frames", type=int, default=15, help="frames in a burst")
    ap.add_argument("--json", action="store_true")
    args = smoke.parse_args(ap, argv, env="miniroom:4", width=32, height=24, rounds=1, frames=2)
    if min(args.width, args.height, args.rounds, args.frames) < 1:
        ap.error("--width, --height, --rounds and --frames must be at least 1")

    from benchbot_worlds import bear
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics  # (imports Taichi, its banner sent to stderr)
    from benchbot_worlds.scene.build import build_scene
    from trajectory_views import trajectory_views  # this folder is on sys.path when a script here runs

    envs = {f"{e['name']}:{e['variant']}": e for e in bear.environment_specs()}
    if args.env not in envs:
        ap.error(f"unknown environment {args.env}; one of {sorted(envs)}")
    scene = build_scene(envs[args.env])
    renderers = {"graph": Renderer("cpu"), "numpy": Renderer("cpu", device_buffers=False)}
    for r in renderers.values():
        r.set_scene(scene)
    W, H = args.width, args.height
    K = intrinsics(W, H, 90.0)
    cams, lidars, angles = trajectory_views(scene)

    def burst(r, start: int) -> float:
        t0 = time.perf_counter()
        for i in range(start, start + args.frames):
            k = i % len(cams)
            r.render_sensors(K, cams[k][None], W, H, lidars[k][None], angles)  # new NumPy arrays
        return args.frames / (time.perf_counter() - t0)

    for r in renderers.values():  # compile (or load the cached kernels) and warm up
        burst(r, 0)
    fps = {name: [] for name in renderers}
    for rnd in range(args.rounds):
        for name, r in renderers.items():
            fps[name].append(burst(r, rnd * args.frames))
    ratios = [g / n for g, n in zip(fps["graph"], fps["numpy"])]
    out = {"env": args.env, "width": W, "height": H, "rounds": args.rounds, "frames_per_burst": args.frames,
           "fps": fps, "median_fps": {name: statistics.median(v) for name, v in fps.items()},
           "ratio_graph_over_numpy": statistics.median(ratios), "ratio_min": min(ratios), "ratio_max": max(ratios),
           "shadow_rays": renderers["graph"].shadow_rays, "machine": platform.processor() or platform.machine(),
           "cpu_count": os.cpu_count()}
    if args.json:
        print(json.dumps(out))
    else:
        print(f"{args.env} {W}x{H}, all sensors, {args.rounds} rounds of {args.frames} frames: graph "
              f"{out['median_fps']['graph']:.1f} fps, numpy {out['median_fps']['numpy']:.1f} fps (medians); "
              f"graph / numpy {out['ratio_graph_over_numpy']:.3f} (rounds {out['ratio_min']:.3f} .. "
              f"{out['ratio_max']:.3f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
