"""Shadow maps against shadow rays on one environment: how far the images differ, and what each costs.

Renders every ``--every``-th pose of the environment's trajectory (fast mode, one shadow sample) twice with the
same scene: once with the lights' shadows from shadow maps (``Renderer(shadow_maps=True)``: the lamps' cube maps
and the sun's orthographic map) and once with shadow rays (``shadow_maps=False``), and compares the RGB images.
``--lights`` keeps all the scene's lights, the sun alone or the lamps alone (ambient light is kept).

    python benchmarks/shadow_maps.py --env house:1 [--lights all|sun|lamps] [--width 320 --height 240]
        [--every 4] [--arch cpu|cuda] [--json] [--save-worst FILE.png]

JSON keys: ``views``; ``differ_gt2_mean`` / ``differ_gt2_max`` (fraction of pixels whose largest channel differs
by more than 2 levels of 255, mean and worst over the views); ``differ_max_levels`` (largest difference anywhere);
``setup_s_maps`` / ``setup_s_rays`` (``set_scene``, including the maps' tracing); ``fps_maps`` / ``fps_rays``
(the same views, images copied to NumPy); ``lamps_with_maps``, ``sun_map``. ``--save-worst`` writes the view that
differs most: maps | rays | 4 × |difference|.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

import smoke  # this folder is on sys.path when a script here runs


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--env", default="house:1")
    ap.add_argument("--lights", choices=("all", "sun", "lamps"), default="all")
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--every", type=int, default=4, help="render every N-th pose of the trajectory")
    ap.add_argument("--arch", default=os.environ.get("BENCHBOT_TAICHI_ARCH", "cpu"))
    ap.add_argument("--save-worst", help="PNG of the view that differs most: maps | rays | 4 × |difference|")
    ap.add_argument("--json", action="store_true")
    args = smoke.parse_args(ap, argv, env="miniroom:4", width=32, height=24, every=20)
    if min(args.width, args.height, args.every) < 1:
        ap.error("--width, --height and --every must be >= 1")

    from benchbot_worlds import bear
    from benchbot_sim_taichi.backend import trajectory_cameras
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene

    envs = {f"{e['name']}:{e['variant']}": e for e in bear.environment_specs()}
    if args.env not in envs:
        ap.error(f"unknown environment {args.env}; one of {sorted(envs)}")
    scene = build_scene(envs[args.env])
    scene = scene.with_lights(args.lights)
    W, H = args.width, args.height
    K = intrinsics(W, H, 90.0)
    cams = trajectory_cameras(scene)[::args.every]

    images, out = {}, {"env": args.env, "lights": args.lights, "width": W, "height": H, "views": len(cams)}
    for maps, name in ((True, "maps"), (False, "rays")):
        r = Renderer(args.arch, shadow_maps=maps)
        t = time.perf_counter()
        r.set_scene(scene)
        r.sync()
        out[f"setup_s_{name}"] = time.perf_counter() - t
        if maps:
            out.update(lamps_with_maps=r.lamps_with_maps, sun_map=r.sun_map, arch=r.arch)
        r.render(K, cams[0], W, H)  # compiled and warm
        t = time.perf_counter()
        images[name] = [r.render(K, T, W, H)["rgb"].astype(np.int16) for T in cams]
        out[f"fps_{name}"] = len(cams) / (time.perf_counter() - t)
        r.close()
    diffs = [np.abs(a - b).max(axis=2) for a, b in zip(images["maps"], images["rays"])]
    fractions = np.array([(d > 2).mean() for d in diffs])
    out.update(differ_gt2_mean=float(fractions.mean()), differ_gt2_max=float(fractions.max()),
               differ_max_levels=int(max(d.max() for d in diffs)))
    if args.save_worst:
        import cv2

        k = int(fractions.argmax())
        row = np.concatenate([images["maps"][k], images["rays"][k],
                              np.abs(images["maps"][k] - images["rays"][k]) * 4], axis=1)
        cv2.imwrite(args.save_worst, cv2.cvtColor(np.clip(row, 0, 255).astype(np.uint8), cv2.COLOR_RGB2BGR))
    if args.json:
        print(json.dumps(out))
    else:
        print(f"{args.env}, lights {args.lights} ({out['lamps_with_maps']} lamps and {int(out['sun_map'])} sun with "
              f"maps), {len(cams)} views {W}x{H} on {out['arch']}: pixels differing by > 2 levels "
              f"{100 * out['differ_gt2_mean']:.3f} % on average, {100 * out['differ_gt2_max']:.3f} % at worst "
              f"(largest difference {out['differ_max_levels']}); set-up {out['setup_s_maps']:.1f} s with maps, "
              f"{out['setup_s_rays']:.1f} s without; {out['fps_maps']:.1f} fps with maps, {out['fps_rays']:.1f} "
              f"with rays")
    return 0


if __name__ == "__main__":
    sys.exit(main())
