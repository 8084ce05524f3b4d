"""area_rule_check.py [RUN/realism.json ...]: how far the box-only photos' estimated mask areas move the real-photo
reference, measured on the photos whose masks COCO gives (``benchmarks/realism/photos``, the boxes without
``area_from_box``).

For each such photo object of a BEAR class, its mask area is replaced by the estimate the box-only photos get (box
area × ``info.area_ratios`` of its class, ``tools/realism_photos.py``) and the script prints: how many objects pass
the 400-pixel floor and land in the same size bin both ways; and, for each finished ``realism.py --real-reference``
RUN given, the sim / real ratio (overall and per class with at least 10 photo objects) against the masked photos
with their mask areas, the same with their estimated areas, and the box-only photos alone (their areas all
estimates), the detector's photo detections and the sim frames read from the run (no detector is run). Run from the
repository root:

    uv run python benchmarks/results/cpu2_2026-11-30_photo_set/area_rule_check.py runs/realism_centernet/realism.json
"""
import dataclasses
import json
import sys
from pathlib import Path

sys.path.insert(0, "benchmarks")
import realism as R  # noqa: E402
import realism_real as RR  # noqa: E402
from benchbot_task_semslam.coco import COCO_TO_BEAR  # noqa: E402

MIN_PIXELS = 400


def masked_photos() -> tuple[list, list, list]:
    """(the photos with COCO masks as :class:`realism_real.Photo`, the same with every box's mask area replaced by
    its estimate, the box-only photos)."""
    manifest = json.loads((RR.PHOTOS / RR.MANIFEST).read_text(encoding="utf-8"))
    ratios = manifest["info"]["area_ratios"]
    ratio_of = {COCO_TO_BEAR.get(c["name"], c["name"]): ratios[str(c["id"])] for c in manifest["categories"]}
    estimated_ids = {a["image_id"] for a in manifest["annotations"] if a.get("area_from_box")}
    every = RR.load_photos(R, min_pixels=MIN_PIXELS)
    photos = [p for p in every if p.image_id not in estimated_ids]
    estimated = []
    for p in photos:
        truths = []
        for t in p.truths:
            area = (t.box[2] - t.box[0]) * (t.box[3] - t.box[1]) * ratio_of[t.cls]
            truths.append(dataclasses.replace(t, pixels=int(round(area)), visible=area >= MIN_PIXELS))
        estimated.append(dataclasses.replace(p, truths=truths))
    return photos, estimated, [p for p in every if p.image_id in estimated_ids]


def agreement(photos: list, estimated: list) -> str:
    """One line: the BEAR-class, non-crowd objects counted (≥ the floor) by mask and by estimate, and in the same
    size bin."""
    keep = RR.bear_classes()
    pairs = [(a, b) for p, q in zip(photos, estimated) for a, b in zip(p.truths, q.truths)
             if a.cls in keep and not a.crowd]
    by_mask = sum(a.visible for a, _ in pairs)
    by_box = sum(b.visible for _, b in pairs)
    both = [(a, b) for a, b in pairs if a.visible and b.visible]
    same = sum(RR.size_bin(a.pixels) == RR.size_bin(b.pixels) for a, b in both)
    return (f"{len(photos)} photos with masks: {by_mask} BEAR-class objects counted by mask, {by_box} by estimate, "
            f"{len(both)} by both, {same} of them ({same / len(both):.0%}) in the same size bin")


def ratios(run: Path, photos: list, estimated: list, box_only: list) -> list[str]:
    """Lines: the run's sim / real overall and per class (≥ 10 masked photo objects), with mask areas → estimated
    areas → the box-only photos."""
    try:
        data = json.loads(run.read_text(encoding="utf-8"))
        found = {int(k): v for k, v in data["real_reference"]["photo_detections"].items()}
        threshold, iou = data["real_reference"]["threshold"], data["real_reference"]["iou"]
    except (OSError, ValueError, KeyError) as e:
        sys.exit(f"{run}: not a finished realism.py --real-reference run ({e}); give its realism.json")
    missing = [p.image_id for p in photos + box_only if p.image_id not in found]
    if missing:
        sys.exit(f"{run}: no detections of photo {missing[0]}; give a run against the whole photo set")
    sim = RR.sim_records(R, data["environments"], threshold, iou)
    results = []
    for set_ in (photos, estimated, box_only):
        real = [[r for r in RR.records(R, p.truths, found[p.image_id], threshold, iou) if r[0] in RR.bear_classes()]
                for p in set_]
        results.append(RR.compare(sim, real))

    def fmt(v: dict) -> str:
        low, high, value = (x if isinstance(x, str) else f"{x:.2f}" for x in (*v["ratio"]["ci95"], v["ratio"]["value"]))
        return f"{value} [{low}, {high}] ({v['objects_real']} objects)"

    lines = [f"{run} ({data['settings'].get('detector', '?')}), sim / real, the masked photos' mask areas -> their "
             f"estimated areas -> the box-only photos ({len(photos)}, {len(photos)}, {len(box_only)} photos):",
             "  all: " + " -> ".join(fmt(r["overall"]) for r in results)]
    for cls, v in results[0]["classes"].items():
        rows = [r["classes"].get(cls) for r in results]
        if v["objects_real"] >= 10 and all(w and isinstance(w["ratio"]["value"], float) for w in rows):
            lines.append(f"  {cls}: " + " -> ".join(fmt(w) for w in rows))
    return lines


def main(argv: list[str]) -> int:
    photos, estimated, box_only = masked_photos()
    print(agreement(photos, estimated))
    for run in argv:
        print("\n".join(ratios(Path(run), photos, estimated, box_only)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
