"""confusions.py RUN [CLS]: what a detector took a class's objects for, in a ``benchmarks/realism.py`` run folder
(its ``realism.json``, fast frames). For every visible CLS (toaster) object: each detection of IoU ≥ 0.4 with its box
counted by COCO class and by whether its score reaches 0.3; and the best score of a detection of CLS itself at IoU ≥
0.5 (0 where none), of which the twelve highest are printed with how many reach 0.1. Run from the repository root:

    uv run python benchmarks/results/cpu2_2026-11-30_toasters/confusions.py RUN toaster
"""
import collections
import json
import sys
from pathlib import Path

from benchbot_task_semslam.coco import COCO80

if len(sys.argv) not in (2, 3):
    sys.exit("usage: confusions.py RUN [CLS]")
cls = sys.argv[2] if len(sys.argv) == 3 else "toaster"
try:
    run = json.loads((Path(sys.argv[1]) / "realism.json").read_text())
    sections = run["environments"].values()
except (OSError, ValueError, KeyError, AttributeError) as e:
    sys.exit(f"{sys.argv[1]}/realism.json: cannot read it ({type(e).__name__}: {e}); give the --out folder of a "
             "finished benchmarks/realism.py run")


def iou(a, b) -> float:
    """IoU of two boxes (x0, y0, x1, y1), pixels."""
    w = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    h = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - w * h
    return w * h / union if union else 0.0


taken_for, best = collections.Counter(), []
for section in sections:
    for frame in section["frames"]:
        for o in frame["objects"]:
            if o["cls"] != cls or not o["visible"]:
                continue
            near = [(iou(o["box"], d[:4]), d) for d in frame["detections_fast"]]  # d: x0, y0, x1, y1, score, class
            taken_for.update((COCO80[d[5]], d[4] >= 0.3) for overlap, d in near if overlap >= 0.4)
            own = [d[4] for overlap, d in near if COCO80[d[5]] == cls and overlap >= 0.5]
            best.append(round(max(own), 2) if own else 0.0)
print(f"{len(best)} {cls} views; detections of IoU >= 0.4 by (class, score >= 0.3):")
print(", ".join(f"{name}{' (>= 0.3)' if high else ''} {n}" for (name, high), n in taken_for.most_common(16)))
print(f"best {cls} scores at IoU >= 0.5: {sorted(best)[-12:]}; {sum(b >= 0.1 for b in best)} of them >= 0.1")
