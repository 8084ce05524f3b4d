"""Regenerate the simulator gallery of ``docs/simulator.md``: every BEAR environment in the default (furnished) style,
one view in ``fast`` and one in ``quality`` mode, and a top-down floor plan of each.

    uv run python tools/render_gallery.py [--out docs/gallery] [--envs miniroom:1,house:1] [--width 480 --height 360]

The view of an environment is the pose of its trajectory (every ``--every``-th pose, camera ``--camera-z`` m high,
looking along the robot's heading) whose segmentation shows the most ground-truth object pixels, in the world an
episode with ``--seed 0`` sees (``benchbot.core.seeding.environment_world_seed``), seen through the robot's default
camera model (``benchbot_sim_taichi.backend.camera_model``: exposure, tone curve, vignetting). Writes
``<env>_fast.png``, ``<env>_quality.png`` and ``<env>_plan.png`` (``house_1_fast.png`` for ``house:1``) and prints a
line per environment: the pose, triangles, scene build (or scene cache load) and render seconds.

Ground truth: BEAR (QUT Centre for Robotic Vision, https://github.com/qcr/benchbot_envs; see the BEAR data manifest
shipped with sim_taichi).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import cv2
import numpy as np

from benchbot.core.registry import get_registry
from benchbot.core.seeding import environment_world_seed
from benchbot_sim_taichi.backend import camera_at, camera_model
from benchbot_sim_taichi.homes.floorplan_plot import save_plan_figure
from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
from benchbot_sim_taichi.scene import cache as scene_cache
from benchbot_sim_taichi.scene.build import build_scene

ENVIRONMENTS = [f"{home}:{v}" for home in ("miniroom", "house") for v in range(1, 6)]


camera_pose = camera_at  # (4, 4) T_map_camera of a camera z metres high at (x, y) looking along yaw (rad)


def best_pose(renderer: Renderer, scene, every: int, z: float) -> np.ndarray:
    """The (x, y, yaw) of every ``every``-th trajectory pose (start included) whose 160×120 segmentation has the
    most pixels of ground-truth objects."""
    poses = np.concatenate([scene.start_se2[None], scene.trajectory_se2[::every]])
    K = intrinsics(160, 120, 90.0)
    counts = []
    for x, y, yaw in poses:
        out = renderer.render(K, camera_pose(x, y, yaw, z), 160, 120)
        counts.append(int((out["instance"] > 0).sum()))
    return poses[int(np.argmax(counts))]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=Path("docs/gallery"))
    ap.add_argument("--envs", default=",".join(ENVIRONMENTS), help="comma-separated name:variant")
    ap.add_argument("--width", type=int, default=480)
    ap.add_argument("--height", type=int, default=360)
    ap.add_argument("--every", type=int, default=3, help="consider every K-th trajectory pose")
    ap.add_argument("--camera-z", type=float, default=1.1, help="camera height, metres")
    ap.add_argument("--shadow-samples", type=int, default=8)
    ap.add_argument("--spp", type=int, default=32, help="quality mode samples per pixel")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    registry = get_registry()
    # the robot's default camera model (exposure, tone curve, vignetting): the gallery shows what a robot sees
    renderer = Renderer(None, shadow_samples=args.shadow_samples, seed=0, camera=camera_model())
    K = intrinsics(args.width, args.height, 90.0)
    for env in args.envs.split(","):
        stem = env.replace(":", "_")
        t0 = time.perf_counter()
        environment = registry.scenes(env)[0]
        world = environment_world_seed(0, environment)  # the world an episode with --seed 0 sees, as sim render
        scene, key = scene_cache.scene_for(environment, world, build=build_scene)
        renderer.seed = world
        scene_cache.set_scene(renderer, scene, key)  # from the scene cache when it has them, as sim render
        t_build = time.perf_counter() - t0
        x, y, yaw = best_pose(renderer, scene, args.every, args.camera_z)
        T = camera_pose(x, y, yaw, args.camera_z)
        times = {}
        for mode in ("fast", "quality"):
            t = time.perf_counter()
            out = renderer.render(K, T, args.width, args.height, mode=mode, spp=args.spp)
            times[mode] = time.perf_counter() - t
            cv2.imwrite(str(args.out / f"{stem}_{mode}.png"), out["rgb"][:, :, ::-1])
        if scene.plan is not None:
            objects = [{"class": scene.class_list[int(c)], "centroid": ((lo + hi) / 2).tolist(),
                        "extent": (hi - lo).tolist()}
                       for c, lo, hi in zip(scene.box_class, scene.box_min, scene.box_max)]
            path = np.concatenate([scene.start_se2[None, :2], scene.trajectory_se2[:, :2]])
            save_plan_figure(scene.plan, objects, [path], args.out / f"{stem}_plan.png",
                             title=f"{env}: {len(objects)} ground-truth objects")
        print(f"{env}: style {scene.style}, pose x={x:.2f} y={y:.2f} yaw={math.degrees(yaw):.0f}°, "
              f"{len(scene.tri_v)} triangles, build {t_build:.1f} s, fast {times['fast']:.2f} s, "
              f"quality ({args.spp} spp) {times['quality']:.1f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
