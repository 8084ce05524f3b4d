"""Render throughput of the Taichi simulator (benchbot_sim_taichi) on one environment, with an Embree comparison.

Times full sensor frames (RGB + depth + class/instance segmentation + a 360-beam laser scan) along the
environment's trajectory poses (fast mode), and, in the same run, Embree (``embreex``, through trimesh) casting the
same primary camera rays at the exported triangle mesh of the same scene (``benchbot_sim_taichi.export``).

    python benchmarks/render.py --env house:1 --width 640 --height 480 [--arch cpu|cuda] [--batch N] [--frames 60]
        [--shadow-samples 1] [--lamp-maps auto|on|off] [--json]

Each kernel launch renders N cameras (``--batch N``, default 1) and their N laser scans
(``Renderer.render_sensors``). On CUDA the scene and the outputs stay in GPU memory
(``device_buffers``): ``fps`` counts frames finished in GPU memory (the timing ends with a device synchronisation),
``fps_with_host_copy`` the same frames copied into NumPy arrays; on the CPU both are the same figure. JSON keys:
``fps`` (sensor frames per second), ``fps_with_host_copy``, ``mrays_per_s`` (primary camera rays, millions per
second, counted from the same timing: W·H·fps), ``embree_mrays_per_s`` (primary rays only, closest hit),
``ms_per_frame``, ``prims``, ``bvh_nodes``, ``embree_triangles``, …
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--env", default="house:1")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--arch", default=os.environ.get("BENCHBOT_TAICHI_ARCH", "cpu"))
    ap.add_argument("--batch", type=int, default=1)
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--warmup", type=int, default=2)
    ap.add_argument("--shadow-samples", type=int, default=1)
    ap.add_argument("--lamp-maps", choices=("auto", "on", "off"), default="auto",
                    help="lamp shadows from cube shadow maps (auto: in furnished scenes) or shadow rays")
    ap.add_argument("--no-embree", action="store_true")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)

    from benchbot.core.geometry import se2_to_matrix
    from benchbot_sim_taichi import plugin
    from benchbot_sim_taichi.backend import DEFAULT_SENSORS, R_BODY_OPTICAL
    from benchbot_sim_taichi.renderer import Renderer, intrinsics
    from benchbot_sim_taichi.scene import build_scene

    envs = {f"{e['name']}:{e['variant']}": e for e in plugin.environment_specs()}
    if args.env not in envs:
        ap.error(f"unknown environment {args.env}; one of {sorted(envs)}")
    t0 = time.perf_counter()
    scene = build_scene(envs[args.env])  # the default style, or $BENCHBOT_SIM_STYLE (furnished | primitives)
    t_build = time.perf_counter() - t0
    W, H, B = args.width, args.height, max(1, args.batch)
    t0 = time.perf_counter()
    r = Renderer(args.arch, shadow_samples=args.shadow_samples,
                 lamp_maps={"auto": None, "on": True, "off": False}[args.lamp_maps])
    r.set_scene(scene)
    t_setup = time.perf_counter() - t0
    K = intrinsics(W, H, 90.0)
    Tc = np.eye(4)
    Tc[:3, :3] = R_BODY_OPTICAL
    Tc[:3, 3] = DEFAULT_SENSORS["camera"]["mount_xyz"]
    poses = scene.trajectory_se2 if len(scene.trajectory_se2) else scene.start_se2[None]
    cams = [se2_to_matrix(*p) @ Tc for p in poses]
    lidars = [se2_to_matrix(*p, z=0.3) for p in poses]
    angles = np.radians(np.arange(-180.0, 180.0, 1.0))
    n_batches = max(1, math.ceil(args.frames / B))

    def run(i, to_host):
        idx = [(i * B + b) % len(cams) for b in range(B)]
        return r.render_sensors(K, np.stack([cams[k] for k in idx]), W, H, np.stack([lidars[k] for k in idx]),
                                angles, to_host=to_host)

    def timed(to_host):
        for i in range(args.warmup):
            run(i, to_host)
        r.sync()
        t0 = time.perf_counter()
        for i in range(n_batches):
            run(i, to_host)
        r.sync()
        return n_batches * B / (time.perf_counter() - t0)

    fps = timed(to_host=not r.device_buffers)  # frames in the renderer's memory (GPU memory on CUDA)
    fps_host = timed(to_host=True) if r.device_buffers else fps  # and copied to NumPy arrays
    frames = n_batches * B
    out = {"env": args.env, "width": W, "height": H, "arch": r.arch, "batch": B, "frames": frames,
           "shadow_samples": args.shadow_samples, "fps": fps, "ms_per_frame": 1e3 / fps,
           "mrays_per_s": W * H * fps / 1e6, "prims": int(scene.prim_type.shape[0]),
           "bvh_nodes": int(r._packed["nodes_f"].shape[0]), "lights": int(scene.light_kind.shape[0]),
           "style": scene.style, "lamps_with_maps": r.lamps_with_maps,
           "triangles": int(scene.tri_v.shape[0]), "build_scene_s": t_build,
           "setup_s": t_setup, "fps_with_host_copy": fps_host, "device_buffers": r.device_buffers,
           "machine": platform.processor() or platform.machine(), "cpu_count": os.cpu_count(),
           "outputs": "rgb+depth+class+instance+laser(360)"}
    if not args.no_embree:
        try:
            from trimesh.ray.ray_pyembree import RayMeshIntersector

            from benchbot_sim_taichi.export import scene_mesh

            mesh = scene_mesh(scene)
            inter = RayMeshIntersector(mesh)
            v, u = np.mgrid[0:H, 0:W]
            xc = ((u.ravel() - K[0, 2]) / K[0, 0])
            yc = ((v.ravel() - K[1, 2]) / K[1, 1])
            dirs_cam = np.stack([xc, yc, np.ones_like(xc)], axis=1)
            inter.intersects_first(np.repeat(cams[0][:3, 3][None], 16, 0), dirs_cam[:16] @ cams[0][:3, :3].T)
            n = min(len(cams), max(3, args.frames // 10))
            t0 = time.perf_counter()
            for k in range(n):
                T = cams[k]
                d = dirs_cam @ T[:3, :3].T
                inter.intersects_first(np.repeat(T[:3, 3][None], len(d), 0), d)
            te = time.perf_counter() - t0
            out.update({"embree_mrays_per_s": W * H * n / te / 1e6, "embree_frames": n,
                        "embree_triangles": int(len(mesh.faces))})
        except ImportError as e:  # embreex missing
            out["embree_error"] = str(e)
    if args.json:
        print(json.dumps(out))
    else:
        print(f"{args.env} ({scene.style}, {out['triangles']} triangles, {out['lamps_with_maps']} of {out['lights']} lights with lamp maps) {W}x{H} arch={out['arch']} batch={B}: {fps:.1f} fps ({out['ms_per_frame']:.1f} ms/frame), "
              f"{out['mrays_per_s']:.2f} Mrays/s primary; {fps_host:.1f} fps with host copies; "
              f"embree {out.get('embree_mrays_per_s', float('nan')):.2f} "
              f"Mrays/s on {out.get('embree_triangles', 0)} triangles")
    return 0


if __name__ == "__main__":
    sys.exit(main())
