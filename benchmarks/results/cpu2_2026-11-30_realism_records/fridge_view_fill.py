"""fridge_view_fill.py RUN [PROBE_OUT]: the visible refrigerators of a benchmarks/realism.py run (RUN, its ``--out``
folder) by how much of their counted box their pixels fill (the mask's pixels over the box's area: under
:data:`HIDDEN_FILL`, something in front hides part of the fridge, a table or a chair), and how many the run's
detector found (score >= 0.3, IoU >= 0.5 with the counted box); with PROBE_OUT (a ``fridge_probe.py base`` output
folder made from RUN), how many each probed detector found. Run from the repository root:

    uv run --extra realism python benchmarks/results/cpu2_2026-11-30_realism_records/fridge_view_fill.py RUN [PROBE_OUT]
"""
import json
import sys
from pathlib import Path

sys.path.insert(0, "benchmarks")
import realism as R  # noqa: E402

#: A view whose mask fills less of its box than this is partly hidden.
HIDDEN_FILL = 0.85
FOUND_SCORE = 0.3

if not 2 <= len(sys.argv) <= 3:
    sys.exit("usage: fridge_view_fill.py RUN [PROBE_OUT]")
run = Path(sys.argv[1])
try:
    sections = json.loads((run / "realism.json").read_text())["environments"]
    probe = json.loads((Path(sys.argv[2]) / "scores.json").read_text()) if len(sys.argv) == 3 else {}
except (OSError, ValueError, KeyError) as e:
    sys.exit(f"cannot read the run or the probe ({type(e).__name__}: {e}); give a finished realism.py --out folder "
             "and a fridge_probe.py output folder")
tally: dict = {}
for env, section in sections.items():
    for frame in section["frames"]:
        dets = [d for d in frame["detections_fast"] if R.bear_name(int(d[5])) == "refrigerator"]
        for o in frame["objects"]:
            if o["cls"] != "refrigerator" or not o["visible"]:
                continue
            x0, y0, x1, y1 = o["box"]
            hidden = o["pixels"] / max(1, (x1 - x0) * (y1 - y0)) < HIDDEN_FILL
            best = {"run": max((d[4] for d in dets if R.box_iou(o["box"], d[:4]) >= R.MATCH_IOU), default=0.0)}
            best.update(probe.get(f"{env} {frame['pose_index']} {o['instance']}", {}))
            row = tally.setdefault("partly hidden" if hidden else "in full view", {})
            row["views"] = row.get("views", 0) + 1
            for k, s in best.items():
                row[k] = row.get(k, 0) + (s >= FOUND_SCORE)
for kind, row in sorted(tally.items()):
    print(f"{kind}: {row.pop('views')} views; found: " + ", ".join(f"{k} {v}" for k, v in row.items()))
