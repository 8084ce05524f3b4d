"""Compare two ``benchmarks/realism.py`` runs of the same frames object by object: of one class's objects visible in
both runs (the same environment, pose and instance), how many each run's detector found (a box of the class, score
≥ 0.3, IoU ≥ 0.5 with the object's mask box, as ``realism.py`` counts), and what the objects visible in one run only
add. A change that makes objects larger on screen lets more of them pass the 400-pixel floor; this keeps the
comparison to the same objects. Unlike ``realism.py`` it does not match detections to objects one to one (a box
between two cups counts for both), so its counts can exceed the tables' by one or two.

    uv run python paired.py BEFORE_RUN AFTER_RUN [--cls cup]

BEFORE_RUN and AFTER_RUN are ``--out`` folders of ``realism.py`` (each holds ``realism.json``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

SCORE, IOU = 0.3, 0.5


def _iou(a, b) -> float:
    """IoU of two boxes [x0, y0, x1, y1] (pixels)."""
    x0, y0, x1, y1 = max(a[0], b[0]), max(a[1], b[1]), min(a[2], b[2]), min(a[3], b[3])
    inter = max(0.0, x1 - x0) * max(0.0, y1 - y0)
    return inter / ((a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter + 1e-9)


def found(run: Path, cls: str) -> dict:
    """``{(environment, pose, instance): found}`` of the visible ``cls`` objects of a run's fast frames."""
    from benchbot_task_semslam.coco import COCO80

    target = COCO80.index(cls)
    data = json.loads((run / "realism.json").read_text())
    out = {}
    for env, e in data["environments"].items():
        for frame in e["frames"]:
            for o in frame["objects"]:
                if o["cls"] == cls and o["visible"]:
                    out[(env, frame["pose_index"], o["instance"])] = any(
                        int(d[5]) == target and d[4] >= SCORE and _iou(o["box"], d[:4]) >= IOU
                        for d in frame["detections_fast"])
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("before", type=Path)
    ap.add_argument("after", type=Path)
    ap.add_argument("--cls", default="cup", help="the BEAR class compared (default cup)")
    args = ap.parse_args(argv)
    for run in (args.before, args.after):
        if not (run / "realism.json").is_file():
            print(f"error: {run}/realism.json not found; give two --out folders of benchmarks/realism.py",
                  file=sys.stderr)
            return 2
    a, b = found(args.before, args.cls), found(args.after, args.cls)
    both, only_a, only_b = set(a) & set(b), set(a) - set(b), set(b) - set(a)
    print(f"{args.cls}: {len(both)} visible in both runs, found {sum(a[k] for k in both)} before, "
          f"{sum(b[k] for k in both)} after; visible before only {len(only_a)} ({sum(a[k] for k in only_a)} found), "
          f"after only {len(only_b)} ({sum(b[k] for k in only_b)} found)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
