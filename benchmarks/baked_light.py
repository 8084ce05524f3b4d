"""Baked direct light against the lights summed at every pixel (fast mode, ``benchbot_sim_taichi.render.lightmap``), on one
environment: how far apart the frames are, and what each costs.

    python benchmarks/baked_light.py --env house:1 [--width 640 --height 480] [--every 8] [--arch cpu] [--json]

Renders the default camera at every ``--every``-th pose of the environment's trajectory twice, with
``Renderer(baked_light=True)`` and ``baked_light=False`` (both with shadow maps and one shadow sample), and reports
per view and on average: the share of pixels whose RGB differs by more than 2 and by more than 8 levels, the mean
absolute difference (levels), the PSNR (dB) of the baked frames against the per-pixel ones, and each renderer's
frames per second over the same views; also the lattice points and the seconds ``set_scene`` took with and without
baking.
"""

import argparse
import json
import math
import os
import sys
import time

import numpy as np

import smoke  # this folder is on sys.path when a script here runs


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--env", default="house:1")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--every", type=int, default=8, help="every N-th pose of the trajectory (default 8)")
    ap.add_argument("--arch", default=os.environ.get("BENCHBOT_TAICHI_ARCH", "cpu"))
    ap.add_argument("--json", action="store_true")
    args = smoke.parse_args(ap, argv, env="miniroom:4", width=32, height=24, every=20,
                             style="furnished", force_style=True)  # baked light needs a furnished home
    if min(args.width, args.height, args.every) < 1:
        ap.error("--width, --height and --every must be at least 1")

    from benchbot_worlds import bear
    from benchbot_sim_taichi.backend import trajectory_cameras
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene

    envs = {f"{e['name']}:{e['variant']}": e for e in bear.environment_specs()}
    if args.env not in envs:
        ap.error(f"unknown environment {args.env}; one of {sorted(envs)}")
    scene = build_scene(envs[args.env])
    W, H = args.width, args.height
    K = intrinsics(W, H, 90.0)
    poses = trajectory_cameras(scene)[::args.every]
    frames, info = {}, {}
    for baked in (True, False):
        r = Renderer(args.arch, shadow_maps=True, baked_light=baked)
        t0 = time.perf_counter()
        r.set_scene(scene)
        r.sync()
        setup = time.perf_counter() - t0
        r.render_sensors(K, poses[0][None], W, H)  # compiles the kernels
        t0 = time.perf_counter()
        frames[baked] = [r.render_sensors(K, T[None], W, H)["rgb"][0].astype(np.int16) for T in poses]
        info[baked] = {"fps": len(poses) / (time.perf_counter() - t0), "setup_s": setup,
                       "baked_points": r.baked_points}
    views = []
    for a, b in zip(frames[True], frames[False]):
        d = np.abs(a - b)
        worst = d.max(axis=2)
        mse = float((d.astype(np.float64) ** 2).mean())
        views.append({"over_2": float((worst > 2).mean()), "over_8": float((worst > 8).mean()),
                      "mean_abs": float(d.mean()), "psnr_db": 10 * math.log10(255.0**2 / mse) if mse else math.inf})
    out = {"env": args.env, "width": W, "height": H, "views": len(views), "arch": args.arch,
           "fps_baked": info[True]["fps"], "fps_per_pixel": info[False]["fps"],
           "setup_s_baked": info[True]["setup_s"], "setup_s_per_pixel": info[False]["setup_s"],
           "baked_points": info[True]["baked_points"],
           **{f"mean_{k}": float(np.mean([v[k] for v in views])) for k in ("over_2", "over_8", "mean_abs", "psnr_db")},
           "worst_over_2": max(v["over_2"] for v in views), "per_view": views}
    if args.json:
        print(json.dumps(out))
    else:
        print(f"{args.env} {W}x{H}, {len(views)} views: baked vs per-pixel light: "
              f"{100 * out['mean_over_2']:.2f} % of pixels > 2 levels apart ({100 * out['worst_over_2']:.2f} % in the "
              f"worst view), {100 * out['mean_over_8']:.2f} % > 8, mean {out['mean_mean_abs']:.3f} levels, PSNR "
              f"{out['mean_psnr_db']:.1f} dB; {out['fps_baked']:.1f} fps baked vs {out['fps_per_pixel']:.1f}; "
              f"{out['baked_points']} points, set_scene {out['setup_s_baked']:.1f} s vs {out['setup_s_per_pixel']:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
