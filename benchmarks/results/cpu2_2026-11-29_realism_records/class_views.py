"""class_views.py CLASS RUN_BEFORE RUN_AFTER OUT [--model-before M] [--model-after M] [--titles BEFORE AFTER]
[--views N] [--tile PX]: a picture of a class's views before and after a change. Top row: the first N (5) visible
views of CLASS in RUN_BEFORE (drawn by model M, if given); bottom row: the first N in RUN_AFTER; each a PX × PX
(300) crop around the object's counted box from the run's annotated fast frame. The runs are the ``--out`` folders
of benchmarks/realism.py runs made with ``--pngs 999`` (which writes those frames). Made, from the runs the history
names:

- docs/gallery/procedural_open_laptops.jpg (*Open laptops in BEAR's proportion*; CenterNet, the twenty homes)::

    uv run python benchmarks/results/cpu2_2026-11-29_realism_records/class_views.py laptop V1_RUN V2_RUN OUT.jpg \\
        --model-before laptop__kl_apple-ibook-2001_closed --model-after laptop__kl_apple-ibook-2001 \\
        --titles "generator v1: every laptop closed" "generator v2: open in 2 of 7, as BEAR's"

- docs/gallery/procedural_keyboards.jpg (*Keyboards made in code*; NanoDet, the seven homes with keyboards)::

    uv run python benchmarks/results/cpu2_2026-11-29_realism_records/class_views.py keyboard BEFORE AFTER OUT.jpg \\
        --titles "the pack's keyboard model" "keyboards made in code" --views 10 --tile 200

- docs/gallery/procedural_monitor_screens.jpg (*A dark screen for the pack's monitor*; NanoDet, before: the seven
  homes with keyboards, after: homes 2, 3 and 4)::

    uv run python benchmarks/results/cpu2_2026-11-29_realism_records/class_views.py tv BEFORE AFTER OUT.jpg \\
        --model-before tv__sc_apple_pc_monitor --model-after tv__sc_apple_pc_monitor --views 8 --tile 200 \\
        --titles "the pack's monitor: a light-grey screen" "its screen drawn dark, as the pack's flat TV's"
"""
import argparse
import json
import sys
from pathlib import Path

from PIL import Image, ImageDraw


def crops(run: Path, cls: str, model: str | None, n: int, size: int) -> list[tuple[str, Image.Image]]:
    """The first ``n`` views of a visible ``cls`` object (drawn by ``model``, if given) in ``run``: (label, crop)."""
    out = []
    for env, section in json.loads((run / "realism.json").read_text())["environments"].items():
        for frame in section["frames"]:
            for o in frame["objects"]:
                png = run / env.replace(":", "_") / f"pose{frame['pose_index']:03d}_fast.png"
                if o["cls"] != cls or not o["visible"] or (model and o["model"] != model) or not png.is_file():
                    continue
                x0, y0, x1, y1 = o["box"]
                half, cx, cy = max(x1 - x0, y1 - y0) * 1.2 + 30, (x0 + x1) / 2, (y0 + y1) / 2
                box = (int(cx - half), int(cy - half), int(cx + half), int(cy + half))
                tile = Image.open(png).convert("RGB").crop(box).resize((size, size))
                out.append((f"{env} pose {frame['pose_index']}", tile))
                if len(out) == n:
                    return out
    return out


parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("cls")
parser.add_argument("before", type=Path)
parser.add_argument("after", type=Path)
parser.add_argument("out")
parser.add_argument("--model-before")
parser.add_argument("--model-after")
parser.add_argument("--titles", nargs=2, default=("before", "after"))
parser.add_argument("--views", type=int, default=5)
parser.add_argument("--tile", type=int, default=300)
args = parser.parse_args()
if args.views < 1 or args.tile < 16:
    sys.exit(f"--views {args.views} --tile {args.tile}: give at least one view and tiles of at least 16 px")
rows = []
for title, run, model in ((args.titles[0], args.before, args.model_before),
                          (args.titles[1], args.after, args.model_after)):
    try:
        rows.append((title, crops(run, args.cls, model, args.views, args.tile)))
    except (OSError, ValueError, KeyError, TypeError) as e:
        sys.exit(f"{run}/realism.json: cannot read its frames ({type(e).__name__}: {e}); give the --out folder of a "
                 "finished benchmarks/realism.py run made with --pngs 999")
TILE = args.tile
sheet = Image.new("RGB", (TILE * args.views, 2 * (TILE + 30)), "white")
draw = ImageDraw.Draw(sheet)
for r, (title, tiles) in enumerate(rows):
    top = r * (TILE + 30)
    draw.text((6, top + 8), title, fill="black")
    for i, (label, tile) in enumerate(tiles):
        sheet.paste(tile, (i * TILE, top + 28))
        draw.text((i * TILE + 4, top + 30), label, fill="yellow")
sheet.save(args.out, quality=88)
print(f"wrote {args.out}: {len(rows[0][1])} and {len(rows[1][1])} views")
