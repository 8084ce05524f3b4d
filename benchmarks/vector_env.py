"""Environment steps per second of the Gym vector environment: N batched robots, one renderer launch per step.

For each ``--num-envs`` N the script builds ``gym.make_vec("BenchBot-v0", num_envs=N, ...)`` (task ``--task``,
environment ``--env``, ``--width``×``--height`` RGB-D + laser, fast mode, Taichi on ``--arch``), resets it, runs
``--warmup`` steps, then times ``--steps`` steps of random actions (seeded). A step is everything a training loop
waits for: N actions driven with the pose controller and collision checks, N camera and laser renders in one launch,
and the observations handed over:

* host (default): NumPy arrays the caller owns (on CUDA, copied from the GPU);
* ``--on-device``: the renderer's buffers without a copy, taken by the consumer each step: ``torch.from_dlpack`` of
  the images when PyTorch is installed (``--consumer torch``: it also sums the colour image on the GPU, so the frame
  is read), ``numpy.from_dlpack`` on the CPU (``--consumer numpy``).

``--devices G [G ...]`` also spreads the sub-environments over G devices (``gym.make_vec(..., devices=G)``: one
process per GPU, docs/gym.md, *Several GPUs*): N is then per device (``num_envs`` = G × N), each G is timed at each
N, and the ratio of G devices' env-steps/s to one device's is printed (the goal: ≥ 1.8 at N = 512 per GPU on two
H100-class GPUs). On the CPU (``--arch cpu``, the smoke run) G means G processes on the CPU (``devices=['cpu'] * G``).

``env_steps_per_s`` = N × steps / seconds. ``--sync`` also times ``vectorization_mode="sync"`` (N simulators stepped
one after another, each its own launch; the number of its steps is ``--sync-steps``) for the smallest N, the
comparison a user of ``gym.make_vec`` had before.

For scale, the figure printed beside ours: ManiSkill3 (Tao et al., "ManiSkill3: GPU Parallelized Robotics
Simulation and Rendering for Generalizable Embodied AI", 2024, its rendering benchmark) reports about 10.8k frames per
second at 640×480 on one RTX 4090 — rasterised RGB(-D) of tabletop manipulation scenes with physics, in SAPIEN's
parallel renderer. Ours are ray-traced (BVH) RGB-D + segmentation + 360-beam laser of whole furnished homes
(599k triangles for house:1) with the pose controller, on whatever GPU ran this script: not the same work or
hardware, a rough scale only.

    uv run --extra gym python benchmarks/vector_env.py [--env house:1] [--num-envs 1 16 64 256] [--arch cuda]
        [--on-device] [--sync] [--devices 1 2] [--width 640 --height 480] [--steps 30] [--json FILE] [--smoke]

``--json FILE`` writes ``{machine, arch, env, task, width, height, style, on_device, consumer, runs: [{mode,
num_envs, devices, steps, seconds, env_steps_per_s, start_s}], ratios: [{per_device, devices, ratio}]}``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

import smoke  # this folder is on sys.path when a script here runs

#: ManiSkill3's published batched-render rate (frames/s at 640×480 on one RTX 4090), printed for scale.
MANISKILL3_FPS_640x480_RTX4090 = 10_800


def _consumer(name: str):
    """``take(observations)``: what a training loop does with the images each step (see the module docstring)."""
    if name == "torch":
        import torch

        def take(obs):
            sums = []
            for rgb, depth in zip(_per_device(obs["image_rgb"]), _per_device(obs["image_depth"])):
                image = torch.from_dlpack(rgb)  # no copy: the renderer's buffer (on its GPU)
                torch.from_dlpack(depth)
                sums.append(image.sum(dtype=torch.int64))  # read on the GPU (asynchronously)
            return sums
        return take
    if name == "numpy":
        def take(obs):
            return [np.from_dlpack(rgb).sum(dtype=np.int64) for rgb in _per_device(obs["image_rgb"])]
        return take
    return lambda obs: None


def _per_device(images) -> tuple:
    """On-device images as a tuple of per-device arrays (several devices give a tuple already)."""
    return images if isinstance(images, tuple) else (images,)


def run_one(args, n: int, mode: str, steps: int, devices: int = 1) -> dict:
    """Time ``steps`` steps of a vector environment of N sub-environments per device in ``mode`` (``batched`` or
    ``sync``) over ``devices`` devices (GPUs on CUDA, processes on the CPU)."""
    import gymnasium as gym

    import benchbot.gym  # noqa: F401  (registers BenchBot-v0)

    options = {"width": args.width, "height": args.height, "arch": args.arch}
    t0 = time.perf_counter()
    spread = None if devices == 1 else (devices if args.arch == "cuda" else ["cpu"] * devices)
    n_total = n * devices
    if mode == "batched":
        vec = gym.make_vec("BenchBot-v0", num_envs=n_total, vectorization_mode="vector_entry_point", task=args.task,
                           env=args.env, options=options, max_steps=10**9, on_device=args.on_device, devices=spread)
        take = _consumer(args.consumer if args.on_device else "none")
    else:
        vec = gym.make_vec("BenchBot-v0", num_envs=n, vectorization_mode="sync", task=args.task, env=args.env,
                           options=options, max_steps=10**9)
        take = _consumer("none")
    try:
        vec.reset(seed=0)
        start_s = time.perf_counter() - t0
        rng = np.random.default_rng(0)
        actions = rng.integers(0, vec.single_action_space.n, size=(args.warmup + steps, n_total))
        for a in actions[:args.warmup]:
            take(vec.step(a)[0])
        _synchronise(args)
        t = time.perf_counter()
        for a in actions[args.warmup:]:
            take(vec.step(a)[0])
        _synchronise(args)
        seconds = time.perf_counter() - t
    finally:
        vec.close()
    return {"mode": mode, "num_envs": n_total, "devices": devices, "steps": steps, "seconds": round(seconds, 4),
            "env_steps_per_s": round(n_total * steps / seconds, 1), "start_s": round(start_s, 2)}


def _synchronise(args) -> None:
    if args.on_device and args.consumer == "torch":
        import torch

        for device in range(torch.cuda.device_count()):
            torch.cuda.synchronize(device)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--env", default="house:1")
    ap.add_argument("--task", default="semantic_slam:active:ground_truth")
    ap.add_argument("--num-envs", type=int, nargs="+", default=[1, 16, 64, 256])
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--steps", type=int, default=30)
    ap.add_argument("--warmup", type=int, default=3)
    ap.add_argument("--arch", default=os.environ.get("BENCHBOT_TAICHI_ARCH", "cpu"), choices=["cpu", "cuda"])
    ap.add_argument("--on-device", action="store_true", help="images as the renderer's buffers (DLPack)")
    ap.add_argument("--consumer", choices=["torch", "numpy", "none"], default=None,
                    help="what takes the on-device images each step (default: torch on CUDA, numpy on the CPU)")
    ap.add_argument("--sync", action="store_true", help="also time vectorization_mode='sync' at the smallest N")
    ap.add_argument("--sync-steps", type=int, default=10)
    ap.add_argument("--devices", type=int, nargs="+", default=[1],
                    help="device counts to time; N (--num-envs) is then per device (default: 1)")
    ap.add_argument("--json", type=Path, default=None, help="write the figures to this file")
    args = smoke.parse_args(ap, argv, env="miniroom:4", num_envs=[1, 3], width=32, height=24, steps=3, warmup=1,
                            sync_steps=2, devices=[1, 2])
    if args.consumer is None:
        args.consumer = "torch" if args.arch == "cuda" else "numpy"
    if args.smoke:
        args.sync = True
    runs, ratios = [], []
    for n in args.num_envs:
        by_devices = {}
        for g in args.devices:
            runs.append(run_one(args, n, "batched", args.steps, g))
            by_devices[g] = runs[-1]["env_steps_per_s"]
            where = "" if g == 1 else f"  [{g} {'GPUs' if args.arch == 'cuda' else 'CPU processes'}, {n} each]"
            print(f"batched  N={n * g:<4} {runs[-1]['env_steps_per_s']:>10.1f} env-steps/s  ({args.steps} steps in "
                  f"{runs[-1]['seconds']:.2f} s; start {runs[-1]['start_s']:.1f} s){where}", flush=True)
        for g in args.devices:
            if g != 1 and 1 in by_devices:
                ratios.append({"per_device": n, "devices": g, "ratio": round(by_devices[g] / by_devices[1], 3)})
                print(f"ratio    {g} devices / 1 at N={n} per device: {ratios[-1]['ratio']:.2f}x", flush=True)
    if args.sync:
        n = min(args.num_envs)
        runs.append(run_one(args, n, "sync", args.sync_steps))
        print(f"sync     N={n:<4} {runs[-1]['env_steps_per_s']:>10.1f} env-steps/s  ({args.sync_steps} steps in "
              f"{runs[-1]['seconds']:.2f} s; start {runs[-1]['start_s']:.1f} s)", flush=True)
    print(f"for scale: ManiSkill3 reports ~{MANISKILL3_FPS_640x480_RTX4090:,} rasterised frames/s at 640x480 on one "
          "RTX 4090 (a different renderer, scene and GPU: see this script's docstring)")
    record = {"machine": f"{platform.node()} {platform.processor() or platform.machine()}, {os.cpu_count()} cores",
              "arch": args.arch, "env": args.env, "task": args.task, "width": args.width, "height": args.height,
              "style": os.environ.get("BENCHBOT_SIM_STYLE", "furnished"), "on_device": args.on_device,
              "consumer": args.consumer if args.on_device else None, "runs": runs, "ratios": ratios}
    if args.json:
        tmp = args.json.with_suffix(args.json.suffix + ".tmp")
        tmp.write_text(json.dumps(record, indent=1) + "\n")
        os.replace(tmp, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
