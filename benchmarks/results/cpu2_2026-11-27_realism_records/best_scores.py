"""best_scores.py A B CLASS: for each visible object of CLASS in two runs of benchmarks/realism.py (run folders A
and B, the same frames), the best score of a fast-mode detection of that class whose box has IoU >= 0.5 with the
object's box, at any score the run kept (0 where none); one line per object, then the mean over the objects and how
many rose or fell by more than 0.02. Run from the repository root:

    uv run --extra realism python benchmarks/results/cpu2_2026-11-27_realism_records/best_scores.py A B couch
"""
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, "benchmarks")
import realism as R  # noqa: E402

#: A score that moves by more than this counts as risen or fallen.
MOVE = 0.02


def best_scores(run: str, cls: str) -> dict:
    """{(environment, pose index, instance): best score} of the visible objects of ``cls`` in a run folder."""
    path = Path(run) / "realism.json"
    if not path.is_file():
        sys.exit(f"{path}: not found; give the --out folder of a finished benchmarks/realism.py run")
    out = {}
    for env, e in json.loads(path.read_text())["environments"].items():
        for frame in e["frames"]:
            dets = [d for d in frame["detections_fast"] if R.bear_name(int(d[5])) == cls]
            for o in frame["objects"]:
                if o["cls"] == cls and o["visible"]:
                    box = np.asarray(o["box"], float)
                    hits = [d[4] for d in dets if R.box_iou(box, np.asarray(d[:4], float)) >= 0.5]
                    out[env, frame["pose_index"], o["instance"]] = max(hits, default=0.0)
    return out


if len(sys.argv) != 4:
    sys.exit("usage: best_scores.py RUN_A RUN_B CLASS")
a, b = best_scores(sys.argv[1], sys.argv[3]), best_scores(sys.argv[2], sys.argv[3])
keys = sorted(set(a) & set(b))
if not keys:
    sys.exit(f"no visible {sys.argv[3]} in both runs")
for k in keys:
    print(*k, round(a[k], 2), "->", round(b[k], 2))
va, vb = np.array([a[k] for k in keys]), np.array([b[k] for k in keys])
print(f"mean {va.mean():.3f} -> {vb.mean():.3f} over {len(keys)}  up {(vb > va + MOVE).sum()} "
      f"down {(vb < va - MOVE).sum()}")
