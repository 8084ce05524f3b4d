"""photo_luma.py [CLASS]: the mean sRGB luma (Rec. 709 weights on the 8-bit values / 255) of the middle of each
COCO box of CLASS (default ``refrigerator``) in the real photos realism.py compares with (the box's inner 60 % in
each direction, to leave out most of what surrounds the object: boxes have no masks here), one line a box, then the
median. Compare with ``../cpu2_2026-11-29_realism_records/fridge_luminance.py`` on the homes. Run from the
repository root:

    uv run --extra realism python benchmarks/results/cpu2_2026-11-30_realism_records/photo_luma.py
"""
import json
import sys
from pathlib import Path

import numpy as np
from PIL import Image

PHOTOS = Path("benchmarks/realism/photos")
LUMA = np.array([0.2126, 0.7152, 0.0722])
INNER = 0.6

cls = sys.argv[1] if len(sys.argv) > 1 else "refrigerator"
try:
    coco = json.loads((PHOTOS / "coco_val2017.json").read_text())
except (OSError, ValueError) as e:
    sys.exit(f"{PHOTOS}/coco_val2017.json: cannot read it ({e}); run from the repository root")
ids = {c["id"] for c in coco["categories"] if c["name"] == cls}
if not ids:
    sys.exit(f"{cls!r}: no such COCO class in the photos' annotations")
images = {i["id"]: i for i in coco["images"]}
lumas = []
for a in coco["annotations"]:
    if a["category_id"] not in ids:
        continue
    im = images[a["image_id"]]
    rgb = np.asarray(Image.open(PHOTOS / im["file_name"]).convert("RGB"), float) / 255
    sx, sy = rgb.shape[1] / im["width"], rgb.shape[0] / im["height"]
    x, y, w, h = a["bbox"]
    m = (1 - INNER) / 2
    crop = rgb[int((y + m * h) * sy):int((y + (1 - m) * h) * sy), int((x + m * w) * sx):int((x + (1 - m) * w) * sx)]
    if crop.size:
        lumas.append(float((crop @ LUMA).mean()))
        print(f"{im['file_name']}: box area {a['area']:.0f} px, luma {lumas[-1]:.3f}")
print(f"median luma of {len(lumas)} {cls} boxes: {np.median(lumas):.3f}" if lumas else f"no {cls} box")
