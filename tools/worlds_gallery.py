"""Draw the gallery of procedural homes in ``docs/worlds.md``: the floor plans of 20 validation homes chosen at
random (a fixed seed) on one sheet — rooms by type, walls, doors, windows, lamps, ground-truth boxes and the passive
trajectory of variant 1 — and print a line per home (rooms, objects, poses, seconds to generate).

    uv run python tools/worlds_gallery.py [--count 20] [--split val] [--seed 2026] [-o docs/gallery/procedural_homes.png]

Views of the same homes as the simulator draws them: ``uv run python tools/render_gallery.py --envs
procedural_val_N:1,...`` (the indices this prints).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--count", type=int, default=20, help="homes on the sheet (default 20)")
    ap.add_argument("--split", default="val", help="train or val (default val)")
    ap.add_argument("--seed", type=int, default=2026, help="chooses the home indices (default 2026)")
    ap.add_argument("--max-index", type=int, default=10_000, help="indices are drawn from 0..max-index-1")
    ap.add_argument("-o", "--output", default="docs/gallery/procedural_homes.png")
    args = ap.parse_args(argv)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from benchbot.core.geometry import pose7_to_se2
    from benchbot.core.seeding import home_seed
    from benchbot_worlds.homes.floorplan import plan_for_home
    from benchbot_worlds.homes.floorplan_plot import draw_plan
    from benchbot_worlds.procedural.worlds import home_files, home_name

    indices = sorted(np.random.default_rng(args.seed).choice(args.max_index, args.count, replace=False).tolist())
    cols = min(5, args.count)
    rows = math.ceil(args.count / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.6 * cols, 3.4 * rows), squeeze=False)
    for ax in axes.ravel()[args.count:]:
        ax.axis("off")
    for ax, index in zip(axes.ravel(), indices):
        name = home_name(args.split, index)
        t0 = time.perf_counter()
        variants = [json.loads(Path(f).read_text()) for f in home_files(args.split, index)]
        made = time.perf_counter() - t0
        plan = plan_for_home(variants, seed=home_seed(name))
        env = variants[0]["environment"]
        path = np.array([pose7_to_se2(p)[:2] for p in [env["start_pose"], *env["trajectory_poses"]]])
        objects = variants[0]["ground_truth"]["objects"]
        draw_plan(ax, plan, objects, [path], title=f"{name}: {len(objects)} objects, {len(path)} poses", small=True)
        ax.set_xlabel("")
        ax.set_ylabel("")
        print(f"{name}: {len(plan.rooms)} rooms ({', '.join(r.kind for r in plan.rooms)}), {len(objects)} objects, "
              f"{len(path)} poses, made in {made:.2f} s", flush=True)
    fig.suptitle(f"{args.count} procedural homes of split {args.split} (floor plans of variant 1; red: doors, blue: "
                 "windows, green: ground-truth boxes, line: the passive trajectory)", fontsize=11)
    fig.tight_layout()
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=90)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
