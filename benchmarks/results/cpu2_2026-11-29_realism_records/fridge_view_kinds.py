"""fridge_view_kinds.py RUN [RUN ...]: the visible refrigerators of benchmarks/realism.py runs, by how the frame
shows them, and how many each run's detector found (score >= 0.3, IoU >= 0.5 with the counted box; the best score
of ``best_scores.py``):

- **whole**: inside the image (truncation at most 0.01) and wider than a quarter of its height;
- **edge-on**: inside the image, but narrower than a quarter of its height (seen from the side, a slab);
- **cut**: cut by the image border (truncation over 0.01; at most realism.py's ``--max-truncation``, 0.5).

One line per run. Run from the repository root (history: *CenterNet misses the procedural fridges it sees whole*):

    uv run --extra realism python benchmarks/results/cpu2_2026-11-29_realism_records/fridge_view_kinds.py RUN ...
"""
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, "benchmarks")
import realism as R  # noqa: E402

#: A view inside the image whose box is narrower than this fraction of its height is edge-on.
EDGE_ON_ASPECT = 0.25
#: A view whose cuboid lies more than this fraction outside the image is cut by its border.
CUT_TRUNCATION = 0.01
#: Score at which an object counts as found (the benchmark's headline cut).
FOUND_SCORE = 0.3


def kind(obj: dict) -> str:
    """``whole``, ``edge-on`` or ``cut``: how a frame shows a visible object (module docstring)."""
    x0, y0, x1, y1 = obj["box"]
    if obj["truncation"] > CUT_TRUNCATION:
        return "cut"
    return "edge-on" if (x1 - x0) < EDGE_ON_ASPECT * (y1 - y0) else "whole"


def tally(run: Path, cls: str = "refrigerator") -> dict[str, tuple[int, int]]:
    """{kind: (found, visible)} of ``cls`` in a run folder."""
    out = {k: [0, 0] for k in ("whole", "edge-on", "cut")}
    for section in json.loads((run / "realism.json").read_text())["environments"].values():
        for frame in section["frames"]:
            dets = [d for d in frame["detections_fast"] if R.bear_name(int(d[5])) == cls]
            for o in frame["objects"]:
                if o["cls"] != cls or not o["visible"]:
                    continue
                box = np.asarray(o["box"], float)
                best = max((d[4] for d in dets if R.box_iou(box, np.asarray(d[:4], float)) >= 0.5), default=0.0)
                tally_of = out[kind(o)]
                tally_of[0] += best >= FOUND_SCORE
                tally_of[1] += 1
    return {k: (f, n) for k, (f, n) in out.items()}


if len(sys.argv) < 2:
    sys.exit("usage: fridge_view_kinds.py RUN [RUN ...] (RUN: a benchmarks/realism.py --out folder)")
for arg in sys.argv[1:]:
    if not (Path(arg) / "realism.json").is_file():
        sys.exit(f"{arg}/realism.json: not found; give the --out folder of a finished benchmarks/realism.py run")
    counts = tally(Path(arg))
    print(arg, "; ".join(f"{k} {f}/{n}" for k, (f, n) in counts.items()))
