"""The example solution's mapping per frame: ``semslam_geometric``'s ``GeometricMapper.integrate`` on the frames of an
environment's passive trajectory (rendered first, in this process), timed as it is (frames merged into the map 32 at
a time, the map's voxel keys merged by a stable sort, Timsort, which merges the sorted runs it finds), merged every 8
frames as before, and merged every 8 frames by NumPy's quicksort (``np.unique``) as before that, in turns; the time
to make the objects from the map (``build_map``) as it is; and whether the maps are equal, bit for bit.

    uv run python benchmarks/example_mapping.py [--env house:1] [--frames 0] [--repeat 3] [--width 640 --height 480] [--json]

``--frames 0`` takes the whole trajectory (269 frames for house:1). Figures are the best of ``--repeat`` passes, in
milliseconds per frame, the map's last merge included.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import time
from pathlib import Path

import smoke  # this folder is on sys.path when a script here runs

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as the example runs (semslam_geometric.py)


def record_frames(env: str, width: int, height: int, limit: int) -> list[tuple]:
    """``(rgb (H, W, 3) uint8, depth (H, W) float32 m, K (3, 3), T_map_camera (4, 4))`` of each step of ``env``'s
    passive trajectory (``move_next`` until it ends, or ``limit`` frames when > 0), rendered in this process.

    Raises:
        BenchbotError: no such environment, or its backend cannot start (the message says why)."""
    from benchbot.api.benchbot import InProcessBenchBot
    from benchbot.core.registry import get_registry
    from benchbot.core.session import resolve_run, start_service
    from semslam_geometric import observation_frame

    registry = get_registry()
    spec = resolve_run(registry, "semantic_slam:passive:ground_truth", "carter", env)
    with contextlib.redirect_stdout(sys.stderr):
        service = start_service(registry, spec, options={"width": width, "height": height})
    frames = []
    try:
        bot = InProcessBenchBot(service)
        observations, _ = bot.reset()
        while True:
            frame = observation_frame(observations)
            if frame is not None:
                frames.append(tuple(a.copy() for a in frame))
            if (limit and len(frames) >= limit) or "move_next" not in bot.actions:
                break
            observations, _ = bot.step("move_next")
    finally:
        service.close()
    return frames


def fuse(mapping, frames: list[tuple], **mapper_kwargs) -> tuple[float, bytes, object]:
    """Seconds to fuse ``frames`` into a new mapper with ``mapper_kwargs`` (the last merge included), its map's
    bytes, and the mapper."""
    mapper = mapping.GeometricMapper(**mapper_kwargs)
    t0 = time.perf_counter()
    for frame in frames:
        mapper.integrate(*frame)
    mapper._flush()
    seconds = time.perf_counter() - t0
    return seconds, b"".join(a.tobytes() for a in (mapper._keys, mapper._count, mapper._sum_xyz, mapper._sum_rgb)), \
        mapper


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--env", default="house:1")
    ap.add_argument("--frames", type=int, default=0, help="frames of the trajectory to fuse (0: all)")
    ap.add_argument("--repeat", type=int, default=3, help="passes of each way; the best is reported")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = smoke.parse_args(ap, argv, env="miniroom:1", frames=6, repeat=1, width=64, height=48)
    if args.repeat < 1 or args.frames < 0:
        ap.error("--repeat must be at least 1 and --frames at least 0")
    from benchbot_task_semslam import __file__ as plugin_file

    sys.path.insert(0, str(Path(plugin_file).parent / "examples" / "semslam_geometric"))
    import mapping
    import numpy as np

    from benchbot.core.errors import BenchbotError

    try:
        frames = record_frames(args.env, args.width, args.height, args.frames)
    except BenchbotError as exc:
        ap.error(f"--env {args.env}: {exc.message}")
    from semslam_geometric import DEFAULT_CLASS_LIST

    stable = mapping._sorted_unique_inverse
    quicksort = lambda keys: np.unique(keys, return_inverse=True)  # noqa: E731 (the merge before the stable sort)
    ways = {"as it is": (stable, {}), "every 8 frames": (stable, {"merge_every": 8}),  # the merge before 32
            "np.unique": (quicksort, {"merge_every": 8})}  # and before the stable sort
    best = dict.fromkeys(ways, float("inf"))
    objects_s = float("inf")
    maps = {}
    for _ in range(args.repeat):
        for name, (merge, kwargs) in ways.items():
            mapping._sorted_unique_inverse = merge
            try:
                seconds, maps[name], mapper = fuse(mapping, frames, **kwargs)
            finally:
                mapping._sorted_unique_inverse = stable
            best[name] = min(best[name], seconds)
            if name == "as it is":
                t0 = time.perf_counter()
                mapper.build_map(DEFAULT_CLASS_LIST)
                objects_s = min(objects_s, time.perf_counter() - t0)
    figures = {"env": args.env, "frames": len(frames), "width": args.width, "height": args.height,
               "ms_per_frame": {name: round(1000 * s / max(len(frames), 1), 3) for name, s in best.items()},
               "objects_s": round(objects_s, 3), "identical": len(set(maps.values())) == 1}
    if args.json:
        print(json.dumps(figures))
    else:
        print(f"{args.env}: {len(frames)} frames at {args.width}x{args.height}, best of {args.repeat}")
        for name, ms in figures["ms_per_frame"].items():
            print(f"  merged {name:<16} {ms:8.3f} ms a frame")
        print(f"  objects from the map (as it is)  {figures['objects_s']:8.3f} s")
        print(f"  the maps equal bit for bit: {'yes' if figures['identical'] else 'NO'}")
    return 0 if figures["identical"] else 1


if __name__ == "__main__":
    sys.exit(main())
