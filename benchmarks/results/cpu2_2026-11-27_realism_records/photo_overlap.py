"""photo_overlap.py ANNOTATIONS IMAGE_DIR [ANNOTATIONS IMAGE_DIR ...]: for every val2017 photo that two or more of
the given sources hold, whether their files are byte-identical and their boxes equal (the check behind "where two
repositories give the same photo, its bytes and boxes are the same" in docs/history/realism-2026-11.md)."""
import hashlib
import json
import sys
from pathlib import Path

pairs = list(zip(sys.argv[1::2], sys.argv[2::2]))
files, boxes = {}, {}
for ann, folder in pairs:
    data = json.loads(Path(ann).read_text())
    by_image = {}
    for a in data["annotations"]:
        by_image.setdefault(a["image_id"], []).append((a["id"], a["category_id"], tuple(a["bbox"]), a["iscrowd"]))
    for im in data["images"]:
        path = Path(folder) / im["file_name"]
        if path.exists():
            files.setdefault(im["id"], []).append(hashlib.sha256(path.read_bytes()).hexdigest())
            boxes.setdefault(im["id"], []).append(sorted(by_image.get(im["id"], [])))
shared = [i for i, h in files.items() if len(h) > 1]
same_bytes = sum(len(set(files[i])) == 1 for i in shared)
same_boxes = sum(all(b == boxes[i][0] for b in boxes[i]) for i in shared)
print(f"{len(shared)} photos in two or more sources: {same_bytes} byte-identical, {same_boxes} with equal boxes")
