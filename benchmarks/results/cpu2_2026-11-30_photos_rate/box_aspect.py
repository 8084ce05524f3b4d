"""box_aspect.py RUN CLASS [--max-size PX]: how a class's boxes are shaped in the homes and in the photos, width over
height (the median and the share over 4), for the visible objects of CLASS (a BEAR class name) in a finished
``benchmarks/realism.py`` run (its fast frames) and for the photos' objects of CLASS (not crowd regions) of at least
400 mask pixels and a size, √(mask pixels), under PX (64), as ``realism_real.load_photos`` reads them. A keyboard seen
from a camera 0.3 m over its desk is a wider strip than one seen from over the desk, as most photos see it:

    uv run python benchmarks/results/cpu2_2026-11-30_photos_rate/box_aspect.py RUN keyboard

Exit 2 with one line when RUN holds no finished run or the photos cannot be read.
"""
import argparse
import json
import statistics
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]


def summary(ratios: list[float]) -> str:
    """``n, median w/h, share over 4`` of a list of width / height ratios."""
    if not ratios:
        return "none"
    over = sum(r > 4 for r in ratios) / len(ratios)
    return f"{len(ratios)} boxes, median {statistics.median(ratios):.2f}, over 4: {over:.0%}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("cls")
    ap.add_argument("--max-size", type=float, default=64.0)
    args = ap.parse_args()
    try:
        run = json.loads((args.run / "realism.json").read_text())
        sim = [(o["box"][2] - o["box"][0]) / max(1, o["box"][3] - o["box"][1])
               for s in run["environments"].values() for f in s["frames"] for o in f["objects"]
               if o["visible"] and o["cls"] == args.cls]
    except (OSError, ValueError, KeyError, TypeError) as e:
        print(f"error: {args.run}: not a finished benchmarks/realism.py run ({type(e).__name__}: {e})", file=sys.stderr)
        return 2
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import realism
    import realism_real

    try:
        photos = realism_real.load_photos(realism)  # the benchmark's own reading of the photos' boxes and areas
    except realism.RealismError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    real = [(t.box[2] - t.box[0]) / max(1.0, t.box[3] - t.box[1]) for p in photos for t in p.truths
            if t.cls == args.cls and t.visible and not t.crowd and t.pixels < args.max_size ** 2]
    print(f"{args.cls}, width / height: homes {summary(sim)}; photos under {args.max_size:.0f} px {summary(real)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
