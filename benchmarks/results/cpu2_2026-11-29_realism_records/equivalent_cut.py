"""equivalent_cut.py RUN/realism.json [RUN/realism.json ...] [--cuts 0.2,0.25,...]: a detector's equivalent cut,
chosen on the real photos alone. For each finished ``benchmarks/realism.py --real-reference`` run (its detector's
detections on the 156 photos are stored in ``realism.json``), the photos' objects of the classes both sides have
(the homes' classes) that the detector finds at each score cut, on all photos and on the first 72, unweighted,
matched by realism.py's own rules (COCO's crowd rule, ``--iou`` 0.5). docs/realism.md chose SSD's and YOLOv4-tiny's
headline cuts so that these counts lie between CenterNet's and NanoDet's at 0.3. Made, on the ten BEAR homes' runs::

    uv run python benchmarks/results/cpu2_2026-11-29_realism_records/equivalent_cut.py \\
        runs/centernet/realism.json runs/nanodet/realism.json runs/yolo/realism.json

Run from the repository root. A run that is not a finished --real-reference run ends in one line naming it.
"""
import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, "benchmarks")
import realism  # noqa: E402
import realism_real  # noqa: E402


def found(run: dict, photos: list, cut: float, first: int | None) -> tuple[int, int]:
    """(objects found at score ≥ ``cut``, objects) over the first ``first`` photos (all: None), of ``run``'s classes
    of both sides."""
    reference = run["real_reference"]
    classes = set(reference["classes"])
    detections = reference["photo_detections"]
    hits = total = 0
    for photo in photos[:first]:
        for cls, _, hit in realism_real.records(realism, photo.truths, detections[str(photo.image_id)], cut,
                                                reference["iou"]):
            if cls in classes:
                total += 1
                hits += hit
    return hits, total


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--cuts", default="0.2,0.25,0.3,0.35,0.4")
    args = ap.parse_args()
    try:
        cuts = [float(c) for c in args.cuts.split(",")]
    except ValueError:
        sys.exit(f"--cuts {args.cuts!r}: give scores separated by commas, e.g. 0.2,0.25,0.3")
    photos = realism_real.load_photos(realism)
    for path in args.runs:
        try:
            run = json.loads(path.read_text())
            detector = run["settings"]["detector"]
            rows = [(c, found(run, photos, c, None), found(run, photos, c, 72)) for c in cuts]
        except (OSError, ValueError, KeyError, TypeError) as e:
            sys.exit(f"{path}: not a finished realism.py --real-reference run ({type(e).__name__}: {e})")
        for cut, (k, n), (k72, n72) in rows:
            print(f"{detector:10s} cut {cut:.2f}: {k} of {n} (all {len(photos)} photos), {k72} of {n72} (the first 72)")


if __name__ == "__main__":
    main()
