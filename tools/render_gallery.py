"""Regenerate the simulator gallery of ``docs/simulator.md``: every BEAR environment in the default (furnished) style,
one view in ``fast`` and one in ``quality`` mode, and a top-down floor plan of each; or, with ``--sheet``, the
before/after contact sheets of ``docs/realism.md``.

    uv run python tools/render_gallery.py [--out docs/gallery] [--envs miniroom:1,house:1] [--width 480 --height 360]
    uv run python tools/render_gallery.py --sheet --styles furnished,primitives --modes fast --views 2 \\
        --robot-camera --width 400 --height 300

The views of an environment are trajectory poses (every ``--every``-th, start included; ``--views N``: the poses
split into N runs along the trajectory, one view from each) whose segmentation shows the most ground-truth objects
(ties broken by their pixels), in the world an episode with ``--seed 0`` sees (``benchbot.core.seeding.environment_world_seed``), seen
through the robot's default camera (``benchbot_sim_taichi.backend.DEFAULT_SENSORS``' field of view, and
``backend.camera_model()``: exposure, tone curve, vignetting): from ``--camera-z`` m high, looking along the robot's
heading, or with ``--robot-camera`` from the robot's own camera mount (the views ``benchmarks/realism.py`` judges).
The poses are chosen in the first of ``--styles`` and kept for the others, so the styles are seen from the same
places.

Writes ``<env>_<mode>.png`` (``house_1_fast.png`` for ``house:1``; ``<env>_<mode>_<view>.png`` for more than one
view, ``<env>_<style>_<mode>...`` for each style that ``--styles`` names, furnished too) and ``<env>_plan.png`` (when
the first style is furnished: primitives have no plan); with ``--sheet`` instead one JPEG per environment,
``<env>_sheet.jpg`` (rows: style and mode, columns: views, each labelled), and no plan. Prints a line per
environment and style: the poses, triangles, scene build (or scene cache load) and render seconds.

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

from benchbot.core import atomic
from benchbot.core.errors import BenchbotError
from benchbot.core.geometry import se2_to_matrix
from benchbot.core.registry import get_registry
from benchbot.core.seeding import environment_world_seed
from benchbot_sim_taichi.backend import DEFAULT_SENSORS, camera_at, camera_model, camera_mount
from benchbot_worlds.homes.floorplan_plot import save_plan_figure
from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
from benchbot_sim_taichi import scene_cache
from benchbot_worlds.scene.build import STYLES, build_scene

ENVIRONMENTS = [f"{home}:{v}" for home in ("miniroom", "house") for v in range(1, 6)]
#: The robot's default camera's horizontal field of view (degrees).
FOV_DEG = float(DEFAULT_SENSORS["camera"]["horizontal_fov_deg"])
#: Pixels of a 160×120 view for an object to count as seen when views are chosen: 400 at 640×480, as a visible
#: object of ``benchmarks/realism.py``.
MIN_OBJECT_PIXELS = 25
#: JPEG quality of a contact sheet (``--sheet``).
SHEET_JPEG_QUALITY = 85


def view_camera(pose, z: float | None) -> np.ndarray:
    """(4, 4) ``T_map_camera`` at a trajectory ``pose`` (x, y, yaw): the robot's default camera mount when ``z`` is
    None, else a level camera ``z`` metres high (``backend.camera_at``)."""
    x, y, yaw = (float(v) for v in pose)
    return se2_to_matrix(x, y, yaw) @ camera_mount() if z is None else camera_at(x, y, yaw, z)


def objects_seen(instance: np.ndarray, min_pixels: int = MIN_OBJECT_PIXELS) -> tuple[int, int]:
    """(objects with at least ``min_pixels`` pixels, pixels of objects) of an (H, W) int instance image (0: none)."""
    ids, counts = np.unique(instance[instance > 0], return_counts=True)
    return int((counts >= min_pixels).sum()), int(counts.sum())


def best_poses(renderer: Renderer, scene, every: int, z: float | None, views: int = 1) -> list[np.ndarray]:
    """``views`` (x, y, yaw) poses: every ``every``-th trajectory pose (start included) split into ``views`` runs in
    trajectory order, and from each the pose whose 160×120 segmentation shows the most ground-truth objects (of at
    least :data:`MIN_OBJECT_PIXELS` pixels), ties broken by their pixels."""
    poses = np.concatenate([scene.start_se2[None], scene.trajectory_se2[::every]])
    K = intrinsics(160, 120, FOV_DEG)
    seen = [objects_seen(renderer.render(K, view_camera(p, z), 160, 120)["instance"]) for p in poses]
    runs = np.array_split(np.arange(len(poses)), min(views, len(poses)))
    return [poses[max(run, key=lambda i: seen[i])] for run in runs]


def load_world(renderer: Renderer, environment: dict, style: str | None):
    """The scene of ``environment`` (``style`` set when given) in the world an episode with ``--seed 0`` sees, set
    on ``renderer`` (scene and renderer arrays through the scene cache, as ``benchbot sim render``)."""
    environment = dict(environment, **({"style": style} if style else {}))
    world = environment_world_seed(0, environment)
    scene, key = scene_cache.scene_for(environment, world, build=build_scene)
    renderer.seed = world
    scene_cache.set_scene(renderer, scene, key)
    return scene


def contact_sheet(rows: list[list[np.ndarray]], labels: list[list[str]]) -> np.ndarray:
    """(H·rows, W·columns, 3) uint8 RGB of equal-sized (H, W, 3) uint8 RGB images, each labelled at its top left."""
    out = []
    for row, row_labels in zip(rows, labels):
        tiles = []
        for img, label in zip(row, row_labels):
            tile = np.ascontiguousarray(img).copy()
            (w, h), base = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, 0.45, 1)
            tile[: h + base + 8, : w + 10] //= 3  # a dark band under white text
            cv2.putText(tile, label, (5, h + 4), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (255, 255, 255), 1, cv2.LINE_AA)
            tiles.append(tile)
        out.append(np.concatenate(tiles, axis=1))
    return np.concatenate(out, axis=0)


def main(argv: list[str] | None = None) -> int:
    """Render the gallery (see the module docstring); 0 when done. A bad flag, an unknown environment or style:
    one line on stderr and ``SystemExit(2)``, before anything is rendered."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=Path("docs/gallery"))
    ap.add_argument("--envs", default=",".join(ENVIRONMENTS), help="comma-separated name:variant")
    ap.add_argument("--styles", default="", help="comma-separated styles (furnished, primitives; default: the "
                                                 "environment's own)")
    ap.add_argument("--modes", default="fast,quality", help="comma-separated render modes")
    ap.add_argument("--views", type=int, default=1, help="views per environment, spread along the trajectory")
    ap.add_argument("--sheet", action="store_true", help="one JPEG contact sheet per environment, no plan")
    ap.add_argument("--width", type=int, default=480)
    ap.add_argument("--height", type=int, default=360)
    ap.add_argument("--every", type=int, default=3, help="consider every K-th trajectory pose")
    ap.add_argument("--camera-z", type=float, default=1.1, help="camera height, metres")
    ap.add_argument("--robot-camera", action="store_true", help="the robot's own camera mount instead of --camera-z")
    ap.add_argument("--shadow-samples", type=int, default=8)
    ap.add_argument("--spp", type=int, default=32, help="quality mode samples per pixel")
    args = ap.parse_args(argv)
    modes = [m for m in args.modes.split(",") if m]
    styles = [s for s in args.styles.split(",") if s] or [None]
    if args.views < 1 or not modes or set(modes) - {"fast", "quality"}:
        ap.error("--views must be 1 or more and --modes a comma-separated list of fast, quality")
    for flag in ("width", "height", "every", "shadow_samples", "spp"):
        if getattr(args, flag) < 1:
            ap.error(f"--{flag.replace('_', '-')} must be 1 or more")
    if set(styles) - {None, *STYLES}:
        ap.error(f"--styles must be a comma-separated list of {', '.join(STYLES)}")
    registry = get_registry()
    try:  # every name checked before the first home is rendered
        environments = {env: registry.scenes(env)[0] for env in args.envs.split(",")}
    except BenchbotError as exc:
        ap.error(f"--envs: {exc.message}" + (f" ({exc.hint})" if exc.hint else ""))
    z = None if args.robot_camera else args.camera_z
    args.out.mkdir(parents=True, exist_ok=True)
    # the robot's default camera model (exposure, tone curve, vignetting): the gallery shows what a robot sees
    renderer = Renderer(None, shadow_samples=args.shadow_samples, seed=0, camera=camera_model())
    K = intrinsics(args.width, args.height, FOV_DEG)
    for env, environment in environments.items():
        stem = env.replace(":", "_")
        rows, labels, poses = [], [], None
        for style in styles:
            t0 = time.perf_counter()
            scene = load_world(renderer, environment, style)
            t_build = time.perf_counter() - t0
            poses = poses or best_poses(renderer, scene, args.every, z, args.views)
            times = {}
            for mode in modes:
                t = time.perf_counter()
                images = [renderer.render(K, view_camera(p, z), args.width, args.height, mode=mode,
                                          spp=args.spp)["rgb"] for p in poses]
                times[mode] = (time.perf_counter() - t) / len(poses)
                if args.sheet:
                    rows.append(images)
                    labels.append([f"{env} {scene.style} {mode} ({x:.1f}, {y:.1f}, {math.degrees(yaw):.0f} deg)"
                                   for x, y, yaw in poses])
                    continue
                prefix = stem if style is None else f"{stem}_{style}"
                for n, img in enumerate(images):
                    name = f"{prefix}_{mode}.png" if len(images) == 1 else f"{prefix}_{mode}_{n + 1}.png"
                    ok, data = cv2.imencode(".png", img[:, :, ::-1])
                    atomic.write_bytes(args.out / name, data.tobytes())
            if scene.plan is not None and not args.sheet and style in (None, styles[0]):
                objects = [{"class": scene.class_list[int(c)], "centroid": ((lo + hi) / 2).tolist(),
                            "extent": (hi - lo).tolist()}
                           for c, lo, hi in zip(scene.box_class, scene.box_min, scene.box_max)]
                path = np.concatenate([scene.start_se2[None, :2], scene.trajectory_se2[:, :2]])
                save_plan_figure(scene.plan, objects, [path], args.out / f"{stem}_plan.png",
                                 title=f"{env}: {len(objects)} ground-truth objects")
            where = "; ".join(f"x={x:.2f} y={y:.2f} yaw={math.degrees(yaw):.0f}°" for x, y, yaw in poses)
            print(f"{env}: style {scene.style}, pose {where}, {len(scene.tri_v)} triangles, build {t_build:.1f} s, "
                  + ", ".join(f"{m} {s:.2f} s a view" for m, s in times.items())
                  + (f" (quality {args.spp} spp)" if "quality" in times else ""), flush=True)
        if args.sheet:
            ok, data = cv2.imencode(".jpg", contact_sheet(rows, labels)[:, :, ::-1],
                                    [cv2.IMWRITE_JPEG_QUALITY, SHEET_JPEG_QUALITY])
            atomic.write_bytes(args.out / f"{stem}_sheet.jpg", data.tobytes())
    return 0


if __name__ == "__main__":
    sys.exit(main())
