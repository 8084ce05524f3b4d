"""fridge_front_views.py ENV POSE OUT.jpg: one view of a procedural home of generator v2's seeds (ENV,
``name:variant``) made without and with the rule that keeps the floor in front of a refrigerator clear (generator
v3's ``FRIDGE_FRONT_M``), both seen from pose POSE of the home's trajectory without the rule, in fast mode at 640×480,
with CenterNet's best box on each visible fridge (IoU >= 0.5 with its counted box, as benchmarks/realism.py
matches): the two frames side by side in OUT.jpg, their scores printed. Each home is made afresh in a cache of its own
(the rule changes no file, so the worlds cache would not tell the two apart). Run from the repository root
(docs/gallery/procedural_fridge_front.jpg; docs/history/realism-2026-11.md, *The floor in front of the fridge kept
clear: generator v3*):

    uv run --extra realism python benchmarks/results/cpu2_2026-11-30_realism_records/fridge_front_views.py \\
        procedural_val_17:1 372 docs/gallery/procedural_fridge_front.jpg
"""
import atexit
import os
import re
import shutil
import sys
import tempfile
from pathlib import Path

from PIL import Image, ImageDraw

sys.path.insert(0, "benchmarks")
import realism as R  # noqa: E402
from benchbot.core.geometry import se2_to_matrix  # noqa: E402
from benchbot.core.seeding import environment_world_seed  # noqa: E402
from benchbot_sim_taichi.render.renderer import Renderer  # noqa: E402
from benchbot_task_semslam.coco import bear_name, box_iou  # noqa: E402
from benchbot_worlds.procedural import generator, objects, worlds  # noqa: E402
from benchbot_worlds.scene.build import build_scene  # noqa: E402

#: The generator's own clearance, kept before the rule is turned off for the first home.
FRONT = objects.FRIDGE_FRONT_M

def scene_of(name: str, rule: bool):
    """(scene, environment spec) of ``name`` (``procedural_<split>_<index>:<variant>``) with v2's seeds, the rule on
    or off, its files made in a fresh cache (removed at exit)."""
    cache = tempfile.mkdtemp(prefix="fridge_front_")
    atexit.register(shutil.rmtree, cache, ignore_errors=True)
    os.environ["BENCHBOT_CACHE_DIR"] = cache
    objects.FRIDGE_FRONT_M = FRONT if rule else 0.0
    home, variant = name.split(":")
    _, split, index = home.rsplit("_", 2)
    files = worlds.home_files(split, int(index))
    env = worlds.environment_spec(files[int(variant) - 1], files, split, int(index))
    return build_scene(env, seed=environment_world_seed(0, env)), env


def view(scene, env, pose, detector) -> tuple[Image.Image, list]:
    """The fast frame from ``pose`` (SE(2) row of the trajectory), annotated; [(fridge box, best score)]."""
    K, Tc = R.camera_setup(640, 480)
    r = Renderer(None, seed=environment_world_seed(0, env), camera=R.camera_model())
    r.set_scene(scene)
    T = se2_to_matrix(*pose) @ Tc
    o = r.render(K, T, 640, 480, mode="fast")
    truths = R.frame_truths(o["instance"], scene, K, T, R.MIN_PIXELS, R.MAX_TRUNCATION, R.crowd_instances(scene, env),
                            depth=o["depth"])
    dets = detector.detect(o["rgb"])
    im = Image.fromarray(o["rgb"])
    draw, found = ImageDraw.Draw(im), []
    for t in truths:
        if t.cls == "refrigerator" and t.visible:
            hits = [(s, box) for (*box, s, c) in dets
                    if bear_name(int(c)) == "refrigerator" and box_iou(box, t.box) >= 0.5]
            s, box = max(hits, default=(0.0, None))
            draw.rectangle(list(t.box), outline=(0, 255, 0) if s >= 0.3 else (255, 0, 0), width=3)
            if box is not None:
                draw.rectangle(list(box), outline=(255, 255, 0), width=2)
            found.append((t.box, s))
    return im, found



def main() -> None:
    if len(sys.argv) != 4:
        sys.exit(__doc__.split("\n\n")[0])
    name, out = sys.argv[1], Path(sys.argv[3])
    if not re.fullmatch(r"procedural_(train|val)_\d+:[1-5]", name):
        sys.exit(f"ENV must be procedural_val_<index>:<variant> (or train), not {name!r}")
    try:
        pose_index = int(sys.argv[2])
    except ValueError:
        sys.exit(f"POSE must be a pose index, not {sys.argv[2]!r}")
    generator.GENERATOR_VERSION = 2
    before, env = scene_of(name, rule=False)
    after, _ = scene_of(name, rule=True)
    if not 0 <= pose_index < len(before.trajectory_se2):
        sys.exit(f"{name}: POSE must be 0..{len(before.trajectory_se2) - 1}")
    pose = before.trajectory_se2[pose_index]
    d = R.start_detector(R.parse_args(["--detector", "centernet"]))
    try:
        panels = [view(s, env, pose, d) for s in (before, after)]
    finally:
        d.close()
    sheet = Image.new("RGB", (1280, 480))
    titles = ("generator v2", "with the floor in front of the fridge clear")
    for k, (title, (im, found)) in enumerate(zip(titles, panels)):
        scores = ", ".join(f"{s:.2f}" for _, s in found)
        ImageDraw.Draw(im).text((6, 6), f"{title}: CenterNet {scores}", fill=(255, 255, 0))
        sheet.paste(im, (640 * k, 0))
        boxes = [(list(map(int, b)), round(s, 3)) for b, s in found]
        print(f"{title}: fridge boxes and CenterNet's best scores {boxes}")
    sheet.resize((960, 360)).save(out, quality=88)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
