"""First-frame latency of the Taichi simulator: how long the kernels take to compile in a fresh process with an
empty Taichi kernel cache (what a user's first ``benchbot run`` pays once; later processes load the cache).

    uv run python benchmarks/compile_time.py [--arch cpu] [--json]

Renders a tiny empty scene (32×24) once in ``fast`` mode (the all-sensors kernel) and once in ``quality`` mode (the
path tracer, no denoiser), each timed from the call to its return, in a temporary kernel cache that is removed
afterwards. Prints the seconds of each. ``--smoke`` renders the same frames with the usual kernel cache instead
(compiling takes minutes: its seconds are then the cache's load times, not compile times).
"""

import argparse
import contextlib
import json
import os
import sys
import tempfile
import time

import smoke  # this folder is on sys.path when a script here runs


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--arch", default="cpu", choices=("cpu", "cuda", "gpu"), help="Taichi arch (default: cpu)")
    ap.add_argument("--json", action="store_true")
    args = smoke.parse_args(ap, argv, style=None)
    if args.smoke:
        smoke.left_out("the empty kernel cache", "compiling both kernels takes about 2 minutes on 2 cores; this run "
                       "loads them from the usual cache, so its seconds are load times")
    empty_cache = not args.smoke
    with tempfile.TemporaryDirectory(prefix="benchbot-ticache-") if empty_cache else contextlib.nullcontext() as cache:
        if cache:
            os.environ["TI_OFFLINE_CACHE_FILE_PATH"] = cache  # read by ti.init: an empty cache
        import numpy as np

        from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
        from benchbot_worlds.scene.model import Scene

        z = np.zeros((0, 3), np.float32)
        scene = Scene(box_min=z, box_max=z, box_albedo=z, box_class=np.zeros(0, np.int32),
                      box_instance=np.zeros(0, np.int32), box_names=[], room_min=np.array([-2, -2, 0], np.float32),
                      room_max=np.array([2, 2, 3], np.float32), shell_albedo=np.full((3, 3), 0.5, np.float32),
                      background_class=0, class_list=["background"], ambient=np.ones(3, np.float32),
                      light_kind=np.zeros(0, np.int32), light_vec=z, light_colour=z,
                      light_range=np.zeros(0, np.float32), lighting="base", start_se2=np.zeros(3),
                      trajectory_se2=np.zeros((0, 3)))
        renderer = Renderer(args.arch)
        renderer.set_scene(scene)
        K, T = intrinsics(32, 24, 60.0), np.eye(4)
        t = time.perf_counter()
        renderer.render(K, T, 32, 24)
        fast_s = time.perf_counter() - t
        t = time.perf_counter()
        renderer.render(K, T, 32, 24, mode="quality", spp=1, denoise=False)
        quality_s = time.perf_counter() - t
    out = {"arch": renderer.arch, "fast_first_frame_s": fast_s, "quality_first_frame_s": quality_s,
           "empty_cache": empty_cache, "cpus": os.cpu_count()}
    if args.json:
        print(json.dumps(out))
    else:
        print(f"first frame on {out['arch']}, {'empty' if empty_cache else 'usual'} kernel cache: fast {fast_s:.1f} s, "
              f"quality {quality_s:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
