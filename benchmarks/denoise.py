"""Seconds Intel Open Image Denoise (``renderer.denoise_radiance``: pyoidn's RT filter, high quality, CPU) takes for
one quality-mode frame with its albedo and normal guides.

The inputs are seeded noise of the frame's size (the filter's time does not depend on the content); the first call,
which loads the network, is timed apart as ``first_s``.

    python benchmarks/denoise.py [--width 640 --height 480] [--repeats 5] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)

    from benchbot_sim_taichi.renderer import denoise_radiance

    rng = np.random.default_rng(0)
    radiance = rng.random((a.height, a.width, 3), dtype=np.float32)
    albedo = rng.random((a.height, a.width, 3), dtype=np.float32)
    normal = np.zeros_like(radiance)
    normal[..., 2] = 1.0
    t = time.perf_counter()
    denoise_radiance(radiance, albedo, normal)
    first = time.perf_counter() - t
    times = []
    for _ in range(a.repeats):
        t = time.perf_counter()
        denoise_radiance(radiance, albedo, normal)
        times.append(time.perf_counter() - t)
    out = {"width": a.width, "height": a.height, "first_s": round(first, 3),
           "median_s": round(statistics.median(times), 3), "repeats": a.repeats,
           "machine": f"{platform.machine()} ({os.cpu_count()} cores)"}
    print(json.dumps(out) if a.json else "\n".join(f"{k:10s} {v}" for k, v in out.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
