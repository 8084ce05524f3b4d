"""Render frames per second of the Taichi simulator (benchbot_sim_taichi) at 640×480.

For each environment (default miniroom:1 and house:1) the robot is placed at the environment's trajectory poses in
turn (after a warm-up that compiles the kernels) and one RGB + depth + segmentation render is timed per pose;
``--frames`` frames (≥ 50, but for ``--smoke``) are averaged, cycling through the trajectory.

    python benchmarks/render_fps.py [--arch cpu|gpu] [--frames 60] [--width 640 --height 480] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

import numpy as np

import smoke  # this folder is on sys.path when a script here runs


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--arch", default=os.environ.get("BENCHBOT_TAICHI_ARCH", "cpu"), help="cpu (default), gpu or cuda")
    ap.add_argument("--frames", type=int, default=60, help="timed frames per environment (at least 50)")
    ap.add_argument("--warmup", type=int, default=3)
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--envs", default="miniroom:1,house:1")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = smoke.parse_args(ap, argv, frames=2, warmup=1, width=32, height=24, envs="miniroom:4")
    frames = args.frames if args.smoke else max(50, args.frames)

    import yaml

    from benchbot.core.geometry import pose7_to_se2
    from benchbot_worlds import bear
    from benchbot_sim_taichi import plugin
    from benchbot_sim_taichi.backend import TaichiSimBackend

    with open(plugin.ROBOTS_DIR / "carter.yaml", encoding="utf-8") as f:
        spec = yaml.safe_load(f)
    envs = {f"{e['name']}:{e['variant']}": e for e in bear.environment_specs()}
    backend = TaichiSimBackend(spec, {"arch": args.arch, "width": args.width, "height": args.height})
    names = ["image_rgb", "image_depth", "image_segment"]
    result: dict = {"width": args.width, "height": args.height, "frames": frames, "outputs": names,
                    "machine": platform.processor() or platform.machine(), "cpu_count": os.cpu_count(), "envs": {}}
    for key in args.envs.split(","):
        env = envs[key]
        backend.load_scene(env)
        poses = [pose7_to_se2(p) for p in env["trajectory_poses"]]
        for i in range(args.warmup):
            backend._pose = poses[i % len(poses)]
            backend._cache = {}
            backend.observe(names)
        times = []
        for i in range(frames):
            backend._pose = np.asarray(poses[i % len(poses)], dtype=np.float64)  # teleport: time rendering only
            backend._cache = {}
            t0 = time.perf_counter()
            backend.observe(names)
            times.append(time.perf_counter() - t0)
        t = np.asarray(times)
        result["envs"][key] = {"fps": float(1.0 / t.mean()), "ms_mean": float(1e3 * t.mean()),
                               "ms_median": float(1e3 * np.median(t)), "ms_max": float(1e3 * t.max()),
                               "boxes": backend.scene.n_boxes, "lighting": backend.scene.lighting,
                               "lights": int(backend.scene.light_kind.shape[0])}
    result["arch"] = backend._renderer.arch
    if args.json:
        print(json.dumps(result))
    else:
        print(f"render fps, {args.width}x{args.height}, RGB+depth+segmentation, arch={result['arch']}, "
              f"{frames} frames along the trajectory")
        for key, r in result["envs"].items():
            print(f"  {key:12s} {r['fps']:7.2f} fps  (mean {r['ms_mean']:.1f} ms, median {r['ms_median']:.1f} ms, "
                  f"max {r['ms_max']:.1f} ms; {r['boxes']} boxes, {r['lights']} lights, {r['lighting']})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
