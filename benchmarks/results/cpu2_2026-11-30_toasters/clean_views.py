"""clean_views.py RUN CLS OUT.jpg [--title T] [--views N] [--tile PX] [--min-px P] [--below IMAGE]: a row of a
class's views as the camera sees them, without a detector's boxes. The first N (6) visible CLS objects of at least
P (70) pixels across in RUN (a ``benchmarks/realism.py`` run folder: its ``realism.json``) are rendered again in
fast mode at the run's poses by the checkout this runs in (its code draws them: run it in a worktree of an earlier
commit for a before row) and each cropped around the object's box, PX × PX (240); the row gets the title T on
top; with ``--below IMAGE`` the row is added under that picture. Run from the repository root, e.g.::

    uv run --extra realism python benchmarks/results/cpu2_2026-11-30_toasters/clean_views.py RUN toaster \\
        before.jpg --title "the pack's toaster model"          # in a worktree of the commit before
    uv run --extra realism python benchmarks/results/cpu2_2026-11-30_toasters/clean_views.py RUN toaster \\
        docs/gallery/toasters.jpg --title "toasters made in code" --below before.jpg
"""
import argparse
import json
import sys
from pathlib import Path

from PIL import Image, ImageDraw

ROOT = Path.cwd()
sys.path.insert(0, str(ROOT / "benchmarks"))
import realism as R  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("run", type=Path)
ap.add_argument("cls")
ap.add_argument("out", type=Path)
ap.add_argument("--title", default="")
ap.add_argument("--views", type=int, default=6)
ap.add_argument("--tile", type=int, default=240)
ap.add_argument("--min-px", type=int, default=70)
ap.add_argument("--below", type=Path)
a = ap.parse_args()
if a.views < 1 or a.tile < 16:
    sys.exit(f"--views {a.views} --tile {a.tile}: give at least one view and tiles of at least 16 px")
top = None  # the picture the row goes under (--below), read before the rendering
if a.below is not None:
    try:
        top = Image.open(a.below).convert("RGB")
    except OSError as e:
        sys.exit(f"--below {a.below}: cannot read it as an image ({e})")

views = []  # (environment, pose index, box)
try:
    for env, section in json.loads((a.run / "realism.json").read_text())["environments"].items():
        for frame in section["frames"]:
            for o in frame["objects"]:
                x0, y0, x1, y1 = o["box"]
                if o["cls"] == a.cls and o["visible"] and max(x1 - x0, y1 - y0) >= a.min_px:
                    views.append((env, frame["pose_index"], o["box"]))
except (OSError, ValueError, KeyError, TypeError) as e:
    sys.exit(f"{a.run}/realism.json: cannot read its frames ({type(e).__name__}: {e}); give the --out folder of a "
             "finished benchmarks/realism.py run")
views = views[: a.views]
if not views:
    sys.exit(f"{a.run}: no visible {a.cls} of {a.min_px} px or more")

from benchbot.core.geometry import se2_to_matrix  # noqa: E402
from benchbot.core.seeding import environment_world_seed  # noqa: E402
from benchbot_sim_taichi import scene_cache  # noqa: E402
from benchbot_sim_taichi.render.renderer import Renderer  # noqa: E402
from benchbot_worlds.scene.build import build_scene  # noqa: E402

K, T_robot_camera = R.camera_setup(640, 480)
tiles, loaded = [], {}
for env, pose, (x0, y0, x1, y1) in views:
    if env not in loaded:  # one environment's scene and renderer at a time
        spec = R._env_spec(env, None)
        world = environment_world_seed(0, spec)
        scene, key = scene_cache.scene_for(spec, world, build=build_scene)
        renderer = Renderer("cpu", seed=world, camera=R.camera_model())
        scene_cache.set_scene(renderer, scene, key)
        loaded = {env: (scene, renderer)}
    scene, renderer = loaded[env]
    rgb = renderer.render(K, se2_to_matrix(*scene.trajectory_se2[pose]) @ T_robot_camera, 640, 480, mode="fast")["rgb"]
    side = max(x1 - x0, y1 - y0)
    half = side // 2 + int(0.6 * side)
    cx, cy = (x0 + x1) // 2, (y0 + y1) // 2
    tile = Image.fromarray(rgb).crop((cx - half, cy - half, cx + half, cy + half)).resize((a.tile, a.tile),
                                                                                         Image.Resampling.LANCZOS)
    ImageDraw.Draw(tile).text((4, 4), f"{env} pose {pose}", fill=(255, 255, 0))
    tiles.append(tile)
head = 22 if a.title else 0
row = Image.new("RGB", (a.tile * len(tiles), a.tile + head), "white")
ImageDraw.Draw(row).text((6, 5), a.title, fill=(0, 0, 0))
for k, tile in enumerate(tiles):
    row.paste(tile, (k * a.tile, head))
if top is not None:
    both = Image.new("RGB", (max(top.width, row.width), top.height + row.height), "white")
    both.paste(top, (0, 0))
    both.paste(row, (0, top.height))
    row = both
row.save(a.out, quality=90)
print(f"wrote {a.out}: {len(tiles)} views")
