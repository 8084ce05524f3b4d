"""probe_sheet.py OUT FRAME DIR:TITLE ...: one frame (FRAME, e.g. ``procedural_val_17_1_372.png``) of several
``fridge_probe.py`` output folders side by side, three to a row, each 320×240 and titled; written as JPEG. Made
docs/gallery/procedural_fridge_probes.jpg from the six probes of docs/history/realism-2026-11.md, *The procedural
fridges: five more levers probed*. Run from the repository root:

    uv run --extra realism python benchmarks/results/cpu2_2026-11-30_realism_records/probe_sheet.py OUT.jpg \\
        procedural_val_17_1_372.png runs/fp_base:"as it is" runs/fp_kitchen_walls_tile:"kitchen walls tiled" ...
"""
import sys
from pathlib import Path

from PIL import Image, ImageDraw

if len(sys.argv) < 4 or any(":" not in a for a in sys.argv[3:]):
    sys.exit("usage: probe_sheet.py OUT FRAME DIR:TITLE ... (DIR: a fridge_probe.py output folder)")
out, frame, panels = sys.argv[1], sys.argv[2], [a.split(":", 1) for a in sys.argv[3:]]
W, H = 320, 240
sheet = Image.new("RGB", (W * min(3, len(panels)), H * ((len(panels) + 2) // 3)), "white")
draw = ImageDraw.Draw(sheet)
for i, (folder, title) in enumerate(panels):
    path = Path(folder) / frame
    if not path.is_file():
        sys.exit(f"{path}: not found; give folders written by fridge_probe.py for the same run")
    x, y = (i % 3) * W, (i // 3) * H
    sheet.paste(Image.open(path).convert("RGB").resize((W, H)), (x, y))
    draw.rectangle((x, y, x + W, y + 14), fill="black")
    draw.text((x + 4, y + 1), title, fill="yellow")
sheet.save(out, quality=88)
print(f"wrote {out}: {len(panels)} panels")
