"""Seconds Intel Open Image Denoise (``benchbot_sim_taichi.render.denoiser.denoise_radiance``: pyoidn's RT filter, HDR, on the
CPU or an NVIDIA GPU) takes for one quality-mode frame with its albedo and normal guides.

The inputs are seeded noise of the frame's size (the filter's time does not depend on the content); the first call,
which creates the device and loads the network, is timed apart as ``first_s``. Each timed call includes the copies of
the three inputs to the device and of the output back (a GPU call returns only once its output is on the host).

    python benchmarks/denoise.py [--device cpu|cuda] [--quality high|balanced|fast] [--width 640 --height 480]
                                 [--repeats 5] [--json [PATH]]

``--json`` prints the figures as one JSON object; ``--json PATH`` writes that object to PATH as well.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time

import numpy as np

import smoke  # this folder is on sys.path when a script here runs


def _gpu_name() -> str:
    try:
        out = subprocess.run(["nvidia-smi", "--query-gpu=name,driver_version", "--format=csv,noheader", "-i", "0"],
                             capture_output=True, text=True, timeout=30)
        return out.stdout.strip() or "unknown GPU"
    except (OSError, subprocess.SubprocessError):
        return "unknown GPU"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--device", choices=("cpu", "cuda"), default="cpu")
    ap.add_argument("--quality", choices=("high", "balanced", "fast"), default="high")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", nargs="?", const="-", default=None, metavar="PATH")
    a = smoke.parse_args(ap, argv, width=64, height=48, repeats=1)

    from benchbot_sim_taichi.render.denoiser import denoise_radiance

    rng = np.random.default_rng(0)
    radiance = rng.random((a.height, a.width, 3), dtype=np.float32)
    albedo = rng.random((a.height, a.width, 3), dtype=np.float32)
    normal = np.zeros_like(radiance)
    normal[..., 2] = 1.0
    t = time.perf_counter()
    try:
        denoise_radiance(radiance, albedo, normal, device=a.device, quality=a.quality)
    except RuntimeError as e:  # e.g. no GPU: its one-line reason, not a traceback
        print(f"error: {e}", file=sys.stderr)
        return 1
    first = time.perf_counter() - t
    times = []
    for _ in range(a.repeats):
        t = time.perf_counter()
        denoise_radiance(radiance, albedo, normal, device=a.device, quality=a.quality)
        times.append(time.perf_counter() - t)
    out = {"device": a.device, "quality": a.quality, "width": a.width, "height": a.height,
           "first_s": round(first, 3), "median_s": round(statistics.median(times), 3),
           "median_ms": round(1e3 * statistics.median(times), 2), "min_ms": round(1e3 * min(times), 2),
           "repeats": a.repeats, "machine": f"{platform.machine()} ({os.cpu_count()} cores)"}
    if a.device == "cuda":
        out["gpu"] = _gpu_name()
    if a.json is not None:
        text = json.dumps(out)
        print(text)
        if a.json != "-":
            with open(a.json, "w") as f:
                f.write(text + "\n")
    else:
        print("\n".join(f"{k:10s} {v}" for k, v in out.items()))
    sys.stdout.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
