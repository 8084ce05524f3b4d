"""laptop_views.py RUN_V1 RUN_V2 OUT: a picture of laptop views before and after generator v2's open laptops. Top row:
the first five views of the closed laptop model in RUN_V1; bottom row: the first five of the open iBook in RUN_V2,
each a 300 × 300 crop around the laptop's counted box from the run's annotated fast frame. RUN_V1 and RUN_V2 are the
``--out`` folders of benchmarks/realism.py runs made with ``--pngs 999`` (which writes those frames). Made
docs/gallery/procedural_open_laptops.jpg from the twenty homes' runs (history: *Open laptops in BEAR's proportion*):

    uv run python benchmarks/results/cpu2_2026-11-29_realism_records/laptop_views.py V1_RUN V2_RUN OUT.jpg
"""
import json
import sys
from pathlib import Path

from PIL import Image, ImageDraw

TILE = 300


def crops(run: Path, model: str, n: int = 5) -> list[tuple[str, Image.Image]]:
    """The first ``n`` views of a visible laptop drawn by ``model`` in ``run``: (label, crop)."""
    out = []
    for env, section in json.loads((run / "realism.json").read_text())["environments"].items():
        for frame in section["frames"]:
            for o in frame["objects"]:
                png = run / env.replace(":", "_") / f"pose{frame['pose_index']:03d}_fast.png"
                if o["cls"] != "laptop" or not o["visible"] or o["model"] != model or not png.is_file():
                    continue
                x0, y0, x1, y1 = o["box"]
                half, cx, cy = max(x1 - x0, y1 - y0) * 1.2 + 30, (x0 + x1) / 2, (y0 + y1) / 2
                box = (int(cx - half), int(cy - half), int(cx + half), int(cy + half))
                tile = Image.open(png).convert("RGB").crop(box).resize((TILE, TILE))
                out.append((f"{env} pose {frame['pose_index']}", tile))
                if len(out) == n:
                    return out
    return out


if len(sys.argv) != 4:
    sys.exit("usage: laptop_views.py RUN_V1 RUN_V2 OUT.jpg (RUN: a realism.py --out folder made with --pngs 999)")
for run in sys.argv[1:3]:
    if not (Path(run) / "realism.json").is_file():
        sys.exit(f"{run}/realism.json: not found; give the --out folder of a finished benchmarks/realism.py run")
rows = [("generator v1: every laptop closed", crops(Path(sys.argv[1]), "laptop__kl_apple-ibook-2001_closed")),
        ("generator v2: open in 2 of 7, as BEAR's", crops(Path(sys.argv[2]), "laptop__kl_apple-ibook-2001"))]
sheet = Image.new("RGB", (TILE * 5, 2 * (TILE + 30)), "white")
draw = ImageDraw.Draw(sheet)
for r, (title, tiles) in enumerate(rows):
    top = r * (TILE + 30)
    draw.text((6, top + 8), title, fill="black")
    for i, (label, tile) in enumerate(tiles):
        sheet.paste(tile, (i * TILE, top + 28))
        draw.text((i * TILE + 4, top + 30), label, fill="yellow")
sheet.save(sys.argv[3], quality=88)
print(f"wrote {sys.argv[3]}: {len(rows[0][1])} and {len(rows[1][1])} views")
