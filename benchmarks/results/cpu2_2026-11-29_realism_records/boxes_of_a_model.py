"""boxes_of_a_model.py RUN CLASS MODEL: for every visible object of CLASS drawn by MODEL (the asset id of
``realism.json``'s objects, e.g. ``sink__ccby_kitchenSink``) in a benchmarks/realism.py run, the best IoU of a
fast-mode detection of that class at score >= 0.3 with the object's counted box (none where the detector put no such
box on the frame), then how many views got one and their IoUs (a match needs 0.5). Run from the repository root:

    uv run --extra realism python benchmarks/results/cpu2_2026-11-29_realism_records/boxes_of_a_model.py \
        RUN sink sink__ccby_kitchenSink
"""
import json
import sys
from pathlib import Path

sys.path.insert(0, "benchmarks")
import realism as R  # noqa: E402

#: The headline score cut.
SCORE = 0.3

if len(sys.argv) != 4:
    sys.exit("usage: boxes_of_a_model.py RUN CLASS MODEL (RUN: the --out folder of a finished realism.py run)")
run, cls, model = sys.argv[1:]
path = Path(run) / "realism.json"
if not path.is_file():
    sys.exit(f"{path}: not found; give the --out folder of a finished benchmarks/realism.py run")
best = []
for env, section in json.loads(path.read_text())["environments"].items():
    for frame in section["frames"]:
        boxes = [d for d in frame["detections_fast"] if R.bear_name(int(d[5])) == cls and d[4] >= SCORE]
        for o in frame["objects"]:
            if o["cls"] == cls and o["visible"] and o["model"] == model:
                iou = max((R.box_iou(o["box"], d[:4]) for d in boxes), default=None)
                best.append(iou)
                print(f"{env} pose {frame['pose_index']}: " + ("no box" if iou is None else f"IoU {iou:.2f}"))
got = sorted(round(float(v), 2) for v in best if v is not None)
print(f"{len(best)} views of {model}: {len(got)} with a {cls} box at score >= {SCORE}, IoU {got}")
