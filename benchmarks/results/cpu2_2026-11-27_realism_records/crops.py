"""crops.py RUN CLASS OUT.png [MODEL]: a sheet of crops of every visible CLASS object (of MODEL, if given) in the
fast frames of a benchmarks/realism.py run made with --pngs 999: ground truth green, detections of score >= 0.2
over it red with their COCO class index (0-79) and score. Needs Pillow (the realism extra)."""
import json, sys
from PIL import Image, ImageDraw
run, cls, out = sys.argv[1:4]
model = sys.argv[4] if len(sys.argv) > 4 else None
d = json.load(open(f"{run}/realism.json"))
tiles = []
for env, e in d["environments"].items():
    for fr in e["frames"]:
        for o in fr["objects"]:
            if o["cls"] != cls or not o["visible"] or (model and o.get("model") != model):
                continue
            im = Image.open(f"{run}/{env.replace(':', '_')}/pose{fr['pose_index']:03d}_fast.png").convert("RGB")
            x0, y0, x1, y1 = o["box"]
            dr = ImageDraw.Draw(im)
            dr.rectangle([x0, y0, x1, y1], outline=(0, 255, 0), width=2)
            for det in fr["detections_fast"]:
                bx0, by0, bx1, by1, s, c = det
                if s >= 0.2 and not (bx1 < x0 or bx0 > x1 or by1 < y0 or by0 > y1):
                    dr.rectangle([bx0, by0, bx1, by1], outline=(255, 0, 0), width=1)
                    dr.text((bx0 + 2, by0 + 2), f"{int(c)}:{s:.2f}", fill=(255, 0, 0))
            m = 40
            crop = im.crop((max(0, x0 - m), max(0, y0 - m), min(640, x1 + m), min(480, y1 + m)))
            crop.thumbnail((240, 240))
            ImageDraw.Draw(crop).text((2, 2), f"{env} {fr['pose_index']}", fill=(255, 255, 0))
            tiles.append(crop)
W = 6; H = (len(tiles) + W - 1) // W
sheet = Image.new("RGB", (240 * W, 240 * H))
for k, t in enumerate(tiles):
    sheet.paste(t, ((k % W) * 240, (k // W) * 240))
sheet.save(out); print(len(tiles))
