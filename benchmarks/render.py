"""Render throughput of the Taichi simulator (benchbot_sim_taichi) on one environment, with an Embree comparison.

Times full sensor frames (RGB + depth + class/instance segmentation + a 360-beam laser scan) along the
environment's trajectory poses (fast mode), and, in the same run, Embree (``embreex``, through trimesh) casting the
same primary camera rays at the exported triangle mesh of the same scene (``benchbot_worlds.scene.export``).

    python benchmarks/render.py --env house:1 --width 640 --height 480 [--arch cpu|cuda] [--batch N] [--frames 60]
        [--shadow-samples 1] [--shadow-maps auto|on|off] [--lights on|off|sun|lamps]
        [--host-copy taichi[,reused,pinned]|none] [--numpy-buffers] [--json]

Each kernel launch renders N cameras (``--batch N``, default 1) and their N laser scans
(``Renderer.render_sensors``). On CUDA the scene and the outputs stay in GPU memory
(``device_buffers``): ``fps`` counts frames finished in GPU memory (the timing ends with a device synchronisation),
``fps_with_host_copy`` the same frames copied into new NumPy arrays by the renderer (``to_host=True``: through its
page-locked arrays, then a host copy; Taichi's ``Ndarray.to_numpy`` before 22 Nov 2026's ``_fetch``); on the CPU
both are the same figure: frames delivered as new NumPy arrays (the renderer's ``to_host=True``; since the night
of 23 Nov 2026 through its compiled graph and Taichi ndarrays, copied from their memory; ``--numpy-buffers``: the
kernels launched one by one on NumPy arrays, as before, ``device_buffers`` false in the JSON). On CUDA,
``--host-copy`` adds copies into NumPy arrays made once and reused
(``benchbot_sim_taichi.render.host_copy.HostCopier``: one ``cuMemcpyDtoHAsync`` per output); every copy is checked equal
to Taichi's ``to_numpy`` of the same outputs. ``pinned``, the renderer's
``to_host="pinned"`` (page-locked memory) → ``fps_host_pinned``; ``reused``, the copier driven by the benchmark with
ordinary memory → ``fps_host_reused``. JSON keys: ``fps`` (sensor frames per second), ``fps_with_host_copy``,
``mrays_per_s`` (primary camera rays, millions per second, counted from the same timing: W·H·fps),
``primary_mrays_per_s`` (Taichi's primary rays alone: the unlit launch of camera rays, closest hit, depth,
segmentation and the textured albedo under ambient light, no lights or laser; the figure to set beside Embree's), ``embree_mrays_per_s`` (primary rays only, closest hit), ``ms_per_frame``, ``prims``, ``triangles``, ``bvh_nodes``,
``lights`` (how many, after ``--lights sun|lamps``), ``lights_on`` (false with ``--lights off``: ambient light only,
the renderer's unlit launch), ``lights_kept`` (``--lights``),
``bvh_build_s`` (``bvh.build_bvh`` inside ``set_scene``, on the host CPU), ``setup_s`` (renderer start and
``set_scene``: BVH, packing, upload, shadow maps), ``lamps_with_maps`` / ``sun_map`` (which lights take their
shadows from shadow maps), ``scene_mb`` (the packed scene arrays the kernels read: on CUDA
what ``set_scene`` uploads), ``bvh_mb`` (its nodes), ``peak_rss_mb`` (host), on CUDA ``gpu``, ``gpu_mem_used_mb``
(device memory in use after the timings, the whole device), ``embree_triangles``, …
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import resource
import sys
import time

import numpy as np

import smoke  # this folder is on sys.path when a script here runs


def time_bvh_builds() -> list[float]:
    """Time every ``bvh.build_bvh`` from now on (``pack_scene`` imports it when called, so the BVH built inside
    ``Renderer.set_scene`` is timed): returns the list that each build's seconds are appended to."""
    from benchbot_sim_taichi.render import bvh

    build_bvh, seconds = bvh.build_bvh, []

    def timed_build_bvh(*a, **k):
        t = time.perf_counter()
        try:
            return build_bvh(*a, **k)
        finally:
            seconds.append(time.perf_counter() - t)

    bvh.build_bvh = timed_build_bvh
    return seconds


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
    ap.add_argument("--shadow-maps", choices=("auto", "on", "off"), default="auto",
                    help="the lamps' and the sun's shadows from shadow maps (auto: in furnished scenes) or shadow "
                         "rays (named --lamp-maps before 23 Nov 2026, when the sun had no map)")
    ap.add_argument("--lights", choices=("on", "off", "sun", "lamps"), default="on",
                    help="off: ambient light only (no shadow rays, no shadow maps): what primary rays, shading and "
                         "the laser cost without the lights; sun, lamps: the scene keeps only those lights")
    ap.add_argument("--host-copy", default="taichi",
                    help="comma list of host-copy timings on CUDA: taichi (the renderer's to_host=True), reused, "
                         "pinned; none")
    ap.add_argument("--numpy-buffers", action="store_true",
                    help="the renderer without device buffers (Renderer(device_buffers=False), CPU only): NumPy "
                         "arrays passed to each kernel, no compiled graph")
    ap.add_argument("--samples-per-pixel", type=int, default=1, choices=(1, 4, 9, 16),
                    help="the camera's pixel integration (sensors.camera.samples_per_pixel); above 1 each frame is\n"
                         "one Renderer.render call, as an episode's (--batch 1 only), sub-pixel RGB included")
    ap.add_argument("--no-embree", action="store_true")
    ap.add_argument("--json", action="store_true")
    args = smoke.parse_args(ap, argv, env="miniroom:4", width=32, height=24, frames=2, warmup=1)

    from benchbot_worlds import bear
    from benchbot_sim_taichi.render.renderer import _IN_PACKED, Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene
    from trajectory_views import trajectory_views  # this folder is on sys.path when a script here runs

    bvh_s = time_bvh_builds()

    envs = {f"{e['name']}:{e['variant']}": e for e in bear.environment_specs()}
    if args.env not in envs:
        ap.error(f"unknown environment {args.env}; one of {sorted(envs)}")
    t0 = time.perf_counter()
    scene = build_scene(envs[args.env])  # the default style, or $BENCHBOT_SIM_STYLE (furnished | primitives)
    if args.lights in ("sun", "lamps"):
        scene = scene.with_lights(args.lights)
    t_build = time.perf_counter() - t0
    W, H, B = args.width, args.height, max(1, args.batch)
    bvh_s.clear()
    t0 = time.perf_counter()
    r = Renderer(args.arch, shadow_samples=args.shadow_samples,
                 shadow_maps={"auto": None, "on": True, "off": False}[args.shadow_maps],
                 device_buffers=False if args.numpy_buffers else None)
    if args.numpy_buffers and r.arch == "cuda":
        ap.error("--numpy-buffers: CPU only (on CUDA the kernels read the scene from GPU memory)")
    r.set_scene(scene)
    r.sync()  # the shadow maps' kernels
    t_setup = time.perf_counter() - t0
    K = intrinsics(W, H, 90.0)
    cams, lidars, angles = trajectory_views(scene)
    n_batches = max(1, math.ceil(args.frames / B))

    if args.samples_per_pixel > 1 and (B != 1 or args.lights == "off"):
        ap.error("--samples-per-pixel above 1: --batch 1 with the lights on (it times the episodes' render call)")

    def run(i, to_host):
        idx = [(i * B + b) % len(cams) for b in range(B)]
        Ts, Tl = np.stack([cams[k] for k in idx]), np.stack([lidars[k] for k in idx])
        if args.samples_per_pixel > 1:  # an episode's frame: the pixel centres, then the sub-pixels' RGB
            return r.render(K, Ts[0], W, H, T_map_lidar=Tl[0], angles=angles,
                            samples_per_pixel=args.samples_per_pixel)
        if args.lights != "off":
            return r.render_sensors(K, Ts, W, H, Tl, angles, to_host=to_host)
        out = r._launch(K, Ts, W, H, Tl, angles, lit=False)  # the renderer's unlit launch (depth/segmentation use)
        return r._fetch(out) if to_host else out  # the renderer's own copy to new NumPy arrays

    def timed(to_host, fetch=None):
        for i in range(args.warmup):
            out = run(i, to_host)
            if fetch:
                fetch(out)
        r.sync()
        t0 = time.perf_counter()
        for i in range(n_batches):
            out = run(i, to_host)
            if fetch:
                fetch(out)
        r.sync()
        return n_batches * B / (time.perf_counter() - t0)

    copies = [c for c in args.host_copy.split(",") if c and c != "none"]
    if set(copies) - {"taichi", "reused", "pinned"}:
        ap.error(f"--host-copy: unknown {sorted(set(copies) - {'taichi', 'reused', 'pinned'})}")
    on_gpu = r.arch == "cuda"
    fps = timed(to_host=not on_gpu)  # frames in GPU memory on CUDA; on the CPU, new NumPy arrays
    # and copied to NumPy arrays by the renderer
    fps_host = (timed(to_host=True) if "taichi" in copies else None) if on_gpu else fps
    extra = {}
    if on_gpu:
        import gpu_host  # this folder is on sys.path when a script here runs

        for mode in copies:
            want = {k: v.to_numpy() for k, v in run(0, False).items()}  # Taichi's own copy
            if mode == "taichi":  # the renderer's to_host=True (timed above)
                got = run(0, True)
            elif mode == "pinned":  # the renderer's own page-locked path
                got = {k: v.copy() for k, v in run(0, "pinned").items()}
            else:  # the renderer's copier driven here with ordinary memory
                copier = gpu_host.HostCopier(pinned=False)
                got = copier.copy(run(0, False))
            if any(not np.array_equal(got[k], want[k]) for k in want):
                raise SystemExit(f"--host-copy {mode}: the copies differ from to_numpy's")
            if mode == "pinned":
                extra["fps_host_pinned"] = timed(to_host="pinned")
            elif mode == "reused":
                extra["fps_host_reused"] = timed(to_host=False, fetch=copier.copy)
                copier.close()
        extra.update(gpu_host.device_info())
    # Taichi's primary rays alone: the renderer's unlit launch of camera rays only (closest hit, depth, segmentation
    # and the textured albedo under ambient light; no lights, no laser), to set beside Embree's primary rays below
    for i in range(args.warmup):
        r._launch(K, np.stack([cams[(i * B + b) % len(cams)] for b in range(B)]), W, H, None, None, lit=False)
    r.sync()
    t_primary = time.perf_counter()
    for i in range(n_batches):
        r._launch(K, np.stack([cams[(i * B + b) % len(cams)] for b in range(B)]), W, H, None, None, lit=False)
    r.sync()
    primary_mrays = W * H * n_batches * B / (time.perf_counter() - t_primary) / 1e6
    frames = n_batches * B
    out = {"env": args.env, "width": W, "height": H, "arch": r.arch, "batch": B, "frames": frames,
           "shadow_samples": args.shadow_samples, "samples_per_pixel": args.samples_per_pixel, "fps": fps, "ms_per_frame": 1e3 / fps,
           "mrays_per_s": W * H * fps / 1e6, "primary_mrays_per_s": primary_mrays, "prims": int(scene.prim_type.shape[0]),
           "bvh_nodes": int(r._packed["nodes_f"].shape[0]), "lights": int(scene.light_kind.shape[0]),
           "lights_on": args.lights != "off", "lights_kept": args.lights,
           "style": scene.style, "lamps_with_maps": r.lamps_with_maps,
           "sun_map": r.sun_map, "baked_points": r.baked_points,
           "triangles": int(scene.tri_v.shape[0]), "build_scene_s": t_build,
           "setup_s": t_setup, "bvh_build_s": sum(bvh_s), "fps_with_host_copy": fps_host,
           "scene_mb": sum(r._packed[k].nbytes for k in _IN_PACKED) / 2**20,
           "bvh_mb": r._packed["nodes"].nbytes / 2**20,
           "device_buffers": r.device_buffers, **extra,
           "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
           "machine": platform.processor() or platform.machine(), "cpu_count": os.cpu_count(),
           "outputs": "rgb+depth+class+instance+laser(360)"}
    if not args.no_embree:
        try:
            from trimesh.ray.ray_pyembree import RayMeshIntersector

            from benchbot_worlds.scene.export import scene_mesh

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
        print(f"{args.env} ({scene.style}, {out['triangles']} triangles, {out['lamps_with_maps'] + out['sun_map']} of {out['lights']} lights with shadow maps) {W}x{H} arch={out['arch']} batch={B}: {fps:.1f} fps ({out['ms_per_frame']:.1f} ms/frame), "
              f"{out['mrays_per_s']:.2f} Mrays/s primary in whole frames, {primary_mrays:.2f} alone; "
              f"{fps_host or float('nan'):.1f} fps with host copies; "
              f"embree {out.get('embree_mrays_per_s', float('nan')):.2f} "
              f"Mrays/s on {out.get('embree_triangles', 0)} triangles")
    return 0


if __name__ == "__main__":
    sys.exit(main())
