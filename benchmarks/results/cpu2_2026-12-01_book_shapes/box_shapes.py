"""box_shapes.py CLS RUN [RUN ...] [--ratio R]: a class's single objects on the photos and in the sim, split by the
shape of their box, from ``benchmarks/realism.py --real-reference`` run folders (their ``realism.json``).

A box is *wide* when its width is at least ``R`` (default 1) times its height, else *tall*: for books, a book lying
flat seen from the side (or from above, a cover wider than high) against a book standing on a shelf (its spine). For
each run's detector: per size bin (the square root of the mask pixels, as ``benchmarks/realism_real.py`` bins them)
and shape, the objects and those found under COCO's crowd rule at the run's score threshold and IoU, on the photos
and in the sim's fast frames (BEAR's groups are crowd, neither found nor missed); then what the sim's objects would
give found at the photos' rate matched by size alone (as ``benchmarks/realism.py`` weighs them) and matched by size
and shape, each with the chance of finding at most as many as the sim's did at that rate (each view found
independently at its bin's photo recall: a sum of binomials; the photos' own sampling error is not in it).

With ``--picture OUT.jpg``, the first run's views as rows of crops (``--views`` each, of at least 32 px, evenly spaced
through each list so that one photo or room does not fill a row): the photos' wide objects, the photos' tall objects
and the sim's wide objects, the object's box in blue, each titled found (green) or missed (red) by that run's
detector; the sim's crops come from the run's PNGs (``--pngs``), which carry the detector's boxes. Run from the
repository root:

    uv run --extra realism python benchmarks/results/cpu2_2026-12-01_book_shapes/box_shapes.py book RUN ... \
        [--picture docs/gallery/single_book_shapes.jpg]
"""
import argparse
import json
import sys
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

sys.path.insert(0, str(Path("benchmarks").resolve()))
import realism  # noqa: E402
import realism_real  # noqa: E402

SHAPES = ("wide", "tall")


def shape(box, ratio: float) -> int:
    """0 (wide: width ≥ ``ratio`` × height) or 1 (tall), of a box [x1, y1, x2, y2] pixels."""
    return 0 if box[2] - box[0] >= ratio * (box[3] - box[1]) else 1


def views(images, cls: str, threshold: float, iou: float, ratio: float):
    """(image key, box, size bin, shape, found) of each visible ``cls`` object of ``images``, an iterable of
    (key, truths, detections), under COCO's crowd rule."""
    for key, truths, detections in images:
        as_crowd = realism.with_crowd_rule(truths)
        hits = realism.score_frame(as_crowd, detections, threshold, iou, crowd_rule=True).hits
        for t in as_crowd:
            if t.visible and t.cls == cls:
                yield key, t.box, realism_real.size_bin(t.pixels), shape(t.box, ratio), bool(hits[t.instance])


def counts(rows: list) -> np.ndarray:
    """int (2, size bins, shapes): the objects of :func:`views` rows and those found."""
    out = np.zeros((2, len(realism_real.SIZE_LABELS), len(SHAPES)), np.int64)
    for _, _, b, s, found in rows:
        out[0, b, s] += 1
        out[1, b, s] += found
    return out


def chance_at_most(k: int, n, rate) -> float:
    """P(at most ``k`` found) of views ``n`` (int array) found independently at ``rate`` (float array of the same
    shape): the distribution of a sum of binomials (one per cell), by convolution."""
    from scipy.stats import binom

    pmf = np.array([1.0])
    for ni, pi in zip(np.ravel(n), np.ravel(rate)):
        if ni:
            pmf = np.convolve(pmf, binom.pmf(np.arange(ni + 1), ni, pi))
    return float(pmf[:k + 1].sum())


def crop(path: Path, box, tile: int, label: str, found: bool) -> Image.Image:
    """A ``tile`` × ``tile`` crop of the image at ``path`` around ``box`` (1.8 times its larger side), the box in
    blue, ``label`` on top in green (``found``) or red."""
    with Image.open(path) as im:
        im = im.convert("RGB")
        x0, y0, x1, y1 = box
        half = 0.9 * max(x1 - x0, y1 - y0, 24)
        cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
        ImageDraw.Draw(im).rectangle([x0, y0, x1 - 1, y1 - 1], outline=(40, 90, 255), width=1)
        out = im.crop((int(cx - half), int(cy - half), int(cx + half), int(cy + half))).resize((tile, tile))
    draw = ImageDraw.Draw(out)
    draw.rectangle([0, 0, tile, 14], fill=(0, 0, 0))
    draw.text((3, 1), label, fill=(80, 230, 80) if found else (255, 80, 80))
    return out


def picture(out: Path, photo_rows: list, sim_rows: list, run: Path, cls: str, n: int, tile: int = 160) -> None:
    """Three rows of ``n`` crops (:func:`crop`) of :func:`views` rows of at least 32 px: the photos' wide and tall
    objects (their key the photo's path), the sim's wide ones (key (environment, pose index), the PNG in ``run``)."""
    def sim_path(key):
        env, pose = key
        return run / env.replace(":", "_") / f"pose{pose:03d}_fast.png"

    rows = [("photos, wide", [(k, b, f) for k, b, sb, s, f in photo_rows if s == 0 and sb >= 1], lambda k: k),
            ("photos, tall", [(k, b, f) for k, b, sb, s, f in photo_rows if s == 1 and sb >= 1], lambda k: k),
            ("sim, wide", [(k, b, f) for k, b, sb, s, f in sim_rows if s == 0 and sb >= 1
                           and sim_path(k).is_file()], sim_path)]
    sheet = Image.new("RGB", (n * tile, len(rows) * (tile + 18)), (255, 255, 255))
    for r, (title, picked, where) in enumerate(rows):
        y = r * (tile + 18)
        ImageDraw.Draw(sheet).text((3, y + 3), f"{title} single {cls} objects", fill=(0, 0, 0))
        for c, (key, box, found) in enumerate(picked[::max(1, len(picked) // n)][:n]):
            sheet.paste(crop(where(key), box, tile, "found" if found else "missed", found), (c * tile, y + 18))
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp")
    sheet.save(tmp, format="JPEG", quality=88)
    tmp.replace(out)


def report(path: Path, cls: str, ratio: float) -> tuple[str, list, list]:
    """The Markdown section of one run folder, and its photo and sim :func:`views` rows (for :func:`picture`).
    Raises OSError, ValueError, KeyError, TypeError or AttributeError on a bad run."""
    run = json.loads((path / "realism.json").read_text(encoding="utf-8"))
    ref = run["real_reference"]
    threshold, iou = ref["threshold"], ref["iou"]
    photos = realism_real.load_photos(realism, Path(ref["photos"]), ref["min_pixels"], None, ref["drop_border"])
    dets = ref["photo_detections"]
    photo_rows = list(views(((p.path, p.truths, dets[str(p.image_id)]) for p in photos), cls, threshold, iou, ratio))
    sim_rows = list(views((((env, fr["pose_index"]), [realism.Truth(**o) for o in fr["objects"]],
                            fr.get("detections_fast", []))
                           for env, sec in run["environments"].items() for fr in sec["frames"]),
                          cls, threshold, iou, ratio))
    real, sim = counts(photo_rows), counts(sim_rows)
    name = run["detector"]["model"]
    lines = [f"## {name}: single {cls} objects found / visible at score ≥ {threshold} ({path})", "",
             "| size | photos, wide | photos, tall | sim, wide | sim, tall |", "|---|---|---|---|---|"]
    for b, label in enumerate(realism_real.SIZE_LABELS):
        if real[0, b].any() or sim[0, b].any():
            lines.append(f"| {label} | " + " | ".join(f"{c[1, b, s]}/{c[0, b, s]}" for c in (real, sim)
                                                      for s in range(2)) + " |")
    lines.append("| all | " + " | ".join(f"{c[1, :, s].sum()}/{c[0, :, s].sum()}" for c in (real, sim)
                                        for s in range(2)) + " |")
    by_size = realism_real.at_photos_rate(sim[0].sum(-1), real[1].sum(-1), real[0].sum(-1))[0]
    sized = real[0].sum(-1) > 0
    at_most_size = chance_at_most(int(sim[1].sum(-1)[sized].sum()), np.where(sized, sim[0].sum(-1), 0),
                                  realism_real.photo_rate(real[1].sum(-1), real[0].sum(-1)))
    matched = np.where(real[0] > 0, sim[0], 0)
    rate = realism_real.photo_rate(real[1], real[0])
    by_shape = float((matched * rate).sum())
    at_most = chance_at_most(int(np.where(real[0] > 0, sim[1], 0).sum()), matched, rate)
    unmatched = int(np.where(real[0] > 0, 0, sim[0]).sum())
    lines += ["", f"{name}: the sim's single {cls} views found {int(sim[1].sum())} of {int(sim[0].sum())}; at the "
              f"photos' rate matched by size {float(by_size):.2f} (P(at most as many) {at_most_size:.2f}), by size and "
              f"shape {by_shape:.2f} ({at_most:.2f})"
              + (f" ({unmatched} sim views in a size and shape without photo objects count none)" if unmatched else ""),
              ""]
    return "\n".join(lines), photo_rows, sim_rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cls", help="a BEAR class name, e.g. book")
    ap.add_argument("runs", nargs="+", type=Path, help="--out folders of benchmarks/realism.py --real-reference runs")
    ap.add_argument("--ratio", type=float, default=1.0, help="a box is wide when width >= RATIO x height (default 1)")
    ap.add_argument("--picture", type=Path, help="write the first run's views here as a JPEG (see above)")
    ap.add_argument("--views", type=int, default=8, help="crops a row of --picture (default 8)")
    args = ap.parse_args()
    if not args.ratio > 0:
        ap.error(f"--ratio {args.ratio}: give a positive number, e.g. 1")
    if args.views < 1:
        ap.error(f"--views {args.views}: give at least 1")
    for i, path in enumerate(args.runs):
        try:
            text, photo_rows, sim_rows = report(path, args.cls, args.ratio)
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
            sys.exit(f"{path}/realism.json: cannot read it ({type(exc).__name__}: {exc}); give the --out folder of a "
                     "finished benchmarks/realism.py --real-reference run")
        if not photo_rows and not sim_rows:
            sys.exit(f"{path}: no visible {args.cls!r} object in its frames or its photos; give a BEAR class name, "
                     "e.g. book, cup or laptop")
        print(text)
        if i == 0 and args.picture is not None:
            try:
                picture(args.picture, photo_rows, sim_rows, path, args.cls, args.views)
            except OSError as exc:
                sys.exit(f"--picture {args.picture}: cannot write it from {path}'s photos and PNGs ({exc}); give a "
                         "writable .jpg path and a run made with --pngs")


if __name__ == "__main__":
    main()
