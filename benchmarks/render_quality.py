"""Frames per second of the Taichi simulator's ``quality`` mode (path tracing, ``benchbot_sim_taichi.render.pathtrace``, then
Open Image Denoise, ``benchbot_sim_taichi.render.denoiser``) on one environment, along its trajectory poses.

    python benchmarks/render_quality.py --env house:1 --width 640 --height 480 [--arch cpu|cuda] [--spp 4]
        [--bounces 8] [--frames 20] [--denoise-device cpu|cuda] [--no-denoise] [--camera plain|robot] [--json [PATH]]

Each frame is ``Renderer.render(mode='quality')``: a fast-mode launch for depth and segmentation, the path tracer's
launch, the denoiser (``--denoise-device``; default: the renderer's, ``cuda`` on CUDA) and the camera model's 8-bit
encoding, and the copies of the results to the host. On CUDA the denoiser reads the path tracer's images in GPU
memory and the encoding runs there too; on the CPU (or with ``--denoise-device cpu`` on CUDA) they run on NumPy
arrays. Printed/JSON keys: ``fps`` (frames per second, denoised, as returned to the caller), ``fps_no_denoise``
(``denoise=False``), ``ms_path_trace`` (the same frame without denoising: launches, encoding and copies),
``ms_denoise`` (the difference), ``spp``, ``bounces``, ``triangles``, ``lights``, ``arch``, ``denoise_device``,
``gpu`` (on CUDA), ``first_frame_s`` (compiling the kernels and starting the denoiser included), ``camera`` and
``camera_model``. ``--no-denoise`` times the path tracer alone (``fps`` and ``ms_denoise`` are then null), for a
machine without Open Image Denoise. ``--camera robot`` renders through the default robot's camera model (the filmic
curve, and each frame's exposure metered: ``camera_model.py``) instead of the plain one, so the meter's cost shows.

``--compare-host-path`` renders the first ``--frames`` poses (at most 4) again with a renderer that finishes frames
on the host (``device_buffers=False``: NumPy arrays, NumPy encoding) and adds ``host_path``: per output, the largest
absolute difference and how many values differ, denoised and not.
"""

import argparse
import dataclasses
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

import smoke  # this folder is on sys.path when a script here runs


def compare_host_path(r, scene, K, cams, W: int, H: int, args) -> dict:
    """``{"denoised"|"plain": {output: {"max_abs": float, "differing": int, "values": int}}}`` between ``r``'s frames
    and those of a renderer of the same settings without device buffers (the NumPy path), over ``cams``."""
    from benchbot_sim_taichi.render.renderer import Renderer

    host = Renderer(r.arch, device_buffers=False, denoise_device=r.denoise_device, camera=r.camera)
    host.set_scene(scene)
    report = {}
    for name, denoise in (("denoised", True), ("plain", False)):
        stats: dict = {}
        for T in cams:
            kw = {"mode": "quality", "spp": args.spp, "bounces": args.bounces, "denoise": denoise}
            a, b = r.render(K, T, W, H, **kw), host.render(K, T, W, H, **kw)
            for k in a:
                d = np.abs(a[k].astype(np.float64) - b[k].astype(np.float64))
                s = stats.setdefault(k, {"max_abs": 0.0, "differing": 0, "values": 0})
                s["max_abs"] = max(s["max_abs"], float(d.max()))
                s["differing"] += int((d > 0).sum())
                s["values"] += int(d.size)
        report[name] = stats
    host.close()
    return report


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--env", default="house:1")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--arch", default=os.environ.get("BENCHBOT_TAICHI_ARCH", "cpu"))
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--bounces", type=int, default=8)
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--denoise-device", choices=("cpu", "cuda"), default=None)
    ap.add_argument("--no-denoise", action="store_true",
                    help="time the path tracer alone (where Open Image Denoise is not installed)")
    ap.add_argument("--camera", choices=("plain", "robot"), default="plain",
                    help="the camera model: plain (0 EV, clip; the default) or the default robot's (filmic, and "
                         "quality mode meters each frame's exposure)")
    ap.add_argument("--json", nargs="?", const="-", default=None, help="print JSON (or write it to PATH)")
    ap.add_argument("--compare-host-path", action="store_true",
                    help="also compare the frames with a renderer that finishes them on the host (NumPy)")
    args = smoke.parse_args(ap, argv, env="miniroom:4", width=32, height=24, spp=1, bounces=2, frames=1)
    if min(args.width, args.height, args.spp, args.frames) < 1 or args.bounces < 0:
        ap.error("--width, --height, --spp and --frames must be ≥ 1 and --bounces ≥ 0")

    from benchbot_worlds import bear
    from benchbot_sim_taichi.backend import camera_model, trajectory_cameras
    from benchbot_sim_taichi.render.camera_model import CameraModel
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene

    envs = {f"{e['name']}:{e['variant']}": e for e in bear.environment_specs()}
    if args.env not in envs:
        ap.error(f"unknown environment {args.env}; one of {sorted(envs)}")
    scene = build_scene(envs[args.env])
    try:
        r = Renderer(args.arch, denoise_device=args.denoise_device,
                     camera=camera_model() if args.camera == "robot" else CameraModel())
    except ValueError as e:
        ap.error(f"--arch {args.arch}: {e}")
    r.set_scene(scene)
    W, H = args.width, args.height
    K = intrinsics(W, H, 90.0)
    cams = trajectory_cameras(scene)

    def frame(i: int, denoise: bool) -> None:
        r.render(K, cams[i % len(cams)], W, H, mode="quality", spp=args.spp, bounces=args.bounces, denoise=denoise)

    t0 = time.perf_counter()
    try:
        frame(0, not args.no_denoise)
    except RuntimeError as e:  # the denoiser's device cannot start (one line, naming it and why)
        print(f"error: {e}", file=sys.stderr)
        return 1
    first = time.perf_counter() - t0
    frame(1, False)

    def timed(denoise: bool) -> float:
        t = time.perf_counter()
        for i in range(args.frames):
            frame(i, denoise)
        return (time.perf_counter() - t) / args.frames

    s_plain = timed(False)
    s_denoised = None if args.no_denoise else timed(True)
    out = {"env": args.env, "width": W, "height": H, "arch": r.arch, "spp": args.spp, "bounces": args.bounces,
           "frames": args.frames, "camera": args.camera, "camera_model": dataclasses.asdict(r.camera),
           "denoise_device": None if args.no_denoise else r.denoise_device,
           "fps": None if s_denoised is None else 1.0 / s_denoised,
           "fps_no_denoise": 1.0 / s_plain, "ms_path_trace": 1e3 * s_plain,
           "ms_denoise": None if s_denoised is None else 1e3 * (s_denoised - s_plain), "first_frame_s": first,
           "triangles": int(scene.tri_v.shape[0]), "prims": int(scene.prim_type.shape[0]),
           "lights": int(scene.light_kind.shape[0]), "machine": platform.machine(), "cpus": os.cpu_count()}
    if args.compare_host_path:
        out["host_path"] = compare_host_path(r, scene, K, cams[:min(4, args.frames)], W, H, args)
    if r.arch == "cuda":
        try:
            import subprocess

            out["gpu"] = subprocess.run(["nvidia-smi", "--query-gpu=name", "--format=csv,noheader"],
                                        capture_output=True, text=True, timeout=10).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            out["gpu"] = "unknown"
    if args.json is not None:
        text = json.dumps(out, indent=1)
        if args.json == "-":
            print(text)
        else:
            Path(args.json).write_text(text + "\n")
    if args.json != "-" and s_denoised is None:
        print(f"{args.env} {W}x{H} quality {args.spp} spp, ≤{args.bounces} bounces on {r.arch}, {args.camera} "
              f"camera, not denoised: {out['fps_no_denoise']:.2f} fps ({out['ms_path_trace']:.1f} ms a frame); "
              f"{out['triangles']:,} triangles, {out['lights']} lights; first frame {first:.1f} s")
    elif args.json != "-":
        print(f"{args.env} {W}x{H} quality {args.spp} spp, ≤{args.bounces} bounces on {r.arch}, {args.camera} "
              f"camera (denoiser on {r.denoise_device}): {out['fps']:.2f} fps denoised, {out['fps_no_denoise']:.2f} "
              f"fps without ({out['ms_path_trace']:.1f} ms path tracing + {out['ms_denoise']:.1f} ms denoising); "
              f"{out['triangles']:,} triangles, {out['lights']} lights; first frame {first:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
