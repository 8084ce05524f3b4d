"""fridge_probe.py VARIANT RUN OUT [--cls CLASS] [--detectors centernet,nanodet,ssd,yolo]: every pose of a finished
benchmarks/realism.py run (RUN, its ``--out`` folder) where a CLASS object (default ``refrigerator``) is visible,
rendered again in fast mode at 640×480 with VARIANT applied to the scene (built afresh, the scene cache not used),
and each detector's best same-class score on each visible CLASS object (IoU >= 0.5 with its counted box, as
realism.py matches): the views found at score >= 0.3 and the mean best score, per detector, and all classes' objects
found in those frames. Frames go to OUT as PNGs, the scores to OUT/scores.json. Variants (the scene as the
benchmark builds it, then):

- ``base``: nothing changed;
- ``kitchen_walls_tile``: a kitchen's walls in the kitchens' floor tiles (``surfaces.room_materials``);
- ``kitchen_walls_white``: a kitchen's walls in the ceilings' white plaster;
- ``fridge_white``: the refrigerators' grey (every material of theirs lighter than linear 0.15) a white enamel,
  linear 0.72, not metallic, glTF roughness 0.4;
- ``fridge_darker_0.75`` and ``fridge_darker_0.55``: that grey times 0.75 or 0.55.

Run from the repository root (docs/history/realism-2026-11.md, *The procedural fridges: five more levers probed*):

    uv run --extra realism python benchmarks/results/cpu2_2026-11-30_realism_records/fridge_probe.py \\
        kitchen_walls_tile RUN runs/probe_tiles
"""
import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
from PIL import Image

sys.path.insert(0, "benchmarks")
import realism as R  # noqa: E402
from benchbot.core.geometry import se2_to_matrix  # noqa: E402
from benchbot.core.seeding import environment_world_seed  # noqa: E402
from benchbot_sim_taichi.render.renderer import Renderer  # noqa: E402
from benchbot_task_semslam.coco import bear_name, box_iou  # noqa: E402
from benchbot_worlds.homes import furnished  # noqa: E402
from benchbot_worlds.scene import model  # noqa: E402
from benchbot_worlds.scene.build import build_scene  # noqa: E402

#: Materials of the class's models lighter than this (mean linear albedo) are its body, not its dark trim.
BODY_MIN_ALBEDO = 0.15
FOUND_SCORE = 0.3


def kitchen_walls(kind: str, seed: int | None) -> None:
    """Kitchens' walls drawn as surface ``kind`` (its texture seed: the room's own, or ``seed``)."""
    own = furnished.room_materials

    def room_materials(room_kind, s=0):
        out = own(room_kind, s)
        return out if room_kind != "kitchen" else dict(out, wall=(kind, out["wall"][1] if seed is None else seed))

    furnished.room_materials = room_materials


def recolour(scene, cls: str, albedo=None, scale: float = 1.0, metallic=None, roughness=None):
    """``scene`` with the body materials of ``cls``'s triangles set to ``albedo`` (linear) or scaled by ``scale``."""
    tri = scene.prim_type == model.PRIM_TRIANGLE
    obj = scene.prim_object[tri]
    mine = np.zeros(len(obj), bool)
    mine[obj >= 0] = scene.box_class[obj[obj >= 0]] == scene.class_ids[cls]
    mats = [int(k) for k in np.unique(scene.tri_material[scene.prim_axis[tri][mine]]) if k >= 0]
    alb, met, rough = scene.mat_albedo.copy(), scene.mat_metallic.copy(), scene.mat_roughness.copy()
    for k in mats:
        if float(alb[k].mean()) > BODY_MIN_ALBEDO:
            alb[k] = alb[k] * scale if albedo is None else albedo
            met[k] = met[k] if metallic is None else metallic
            rough[k] = rough[k] if roughness is None else roughness
    return dataclasses.replace(scene, mat_albedo=alb, mat_metallic=met, mat_roughness=rough)


VARIANTS = {
    "base": (None, None),
    "kitchen_walls_tile": (lambda: kitchen_walls("tile", None), None),
    "kitchen_walls_white": (lambda: kitchen_walls("ceiling", 0), None),
    "fridge_white": (None, lambda s: recolour(s, "refrigerator", albedo=0.72, metallic=0.0, roughness=0.4)),
    "fridge_darker_0.75": (None, lambda s: recolour(s, "refrigerator", scale=0.75)),
    "fridge_darker_0.55": (None, lambda s: recolour(s, "refrigerator", scale=0.55)),
}


def poses_with(run: Path, cls: str) -> dict[str, list[int]]:
    """{environment: [pose index]} of RUN's frames where a ``cls`` object is visible."""
    out: dict[str, list[int]] = {}
    for env, section in json.loads((run / "realism.json").read_text())["environments"].items():
        for frame in section["frames"]:
            if any(o["cls"] == cls and o["visible"] for o in frame["objects"]):
                out.setdefault(env, []).append(frame["pose_index"])
    return out


def render(want: dict, patch_scene, out: Path) -> list:
    """[(environment, pose, truths, rgb)] of the poses in ``want``, fast mode, 640×480."""
    frames = []
    for name, poses in want.items():
        env = R._env_spec(name, None)
        world = environment_world_seed(0, env)
        scene = build_scene(env, seed=world)
        scene = patch_scene(scene) if patch_scene else scene
        K, Tc = R.camera_setup(640, 480)
        r = Renderer(None, seed=world, camera=R.camera_model())
        r.set_scene(scene)
        crowd = R.crowd_instances(scene, env)
        for i in poses:
            T = se2_to_matrix(*scene.trajectory_se2[i]) @ Tc
            o = r.render(K, T, 640, 480, mode="fast")
            truths = R.frame_truths(o["instance"], scene, K, T, R.MIN_PIXELS, R.MAX_TRUNCATION, crowd,
                                    depth=o["depth"])
            Image.fromarray(o["rgb"]).save(out / f"{name.replace(':', '_')}_{i:03d}.png")
            frames.append((name, i, truths, o["rgb"]))
    return frames


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("variant", choices=sorted(VARIANTS))
    ap.add_argument("run", type=Path)
    ap.add_argument("out", type=Path)
    ap.add_argument("--cls", default="refrigerator")
    ap.add_argument("--detectors", default="centernet,nanodet,ssd,yolo")
    args = ap.parse_args()
    try:
        want = poses_with(args.run, args.cls)
    except (OSError, ValueError, KeyError, TypeError) as e:
        sys.exit(f"{args.run}/realism.json: cannot read its frames ({type(e).__name__}: {e}); give the --out folder "
                 "of a finished benchmarks/realism.py run")
    detectors = args.detectors.split(",")
    if not want or not set(detectors) <= set(R.DETECTORS):
        sys.exit(f"nothing to probe: no visible {args.cls} in {args.run}, or --detectors not among {R.DETECTORS}")
    args.out.mkdir(parents=True, exist_ok=True)
    patch_build, patch_scene = VARIANTS[args.variant]
    if patch_build:
        patch_build()
    frames = render(want, patch_scene, args.out)
    best: dict = {}
    found_all = {}
    for det in detectors:
        d = R.start_detector(R.parse_args(["--detector", det]))
        found_all[det] = 0
        try:
            for name, i, truths, rgb in frames:
                dets = d.detect(rgb)
                found_all[det] += sum(R.score_frame(truths, dets, FOUND_SCORE, R.MATCH_IOU).hits.values())
                for t in truths:
                    if t.cls == args.cls and t.visible:
                        best.setdefault(f"{name} {i} {t.instance}", {})[det] = max(
                            [s for (*box, s, c) in dets if box_iou(box, t.box) >= R.MATCH_IOU
                             and bear_name(int(c)) == args.cls] + [0.0])
        finally:
            d.close()
    (args.out / "scores.json").write_text(json.dumps(best, indent=1))
    print(f"{args.variant}: {len(best)} {args.cls} views in {len(frames)} frames")
    print("| detector | found (score >= 0.3) | mean best score | all classes found in these frames |")
    print("|---|---|---|---|")
    for det in detectors:
        s = [v.get(det, 0.0) for v in best.values()]
        print(f"| {det} | {sum(x >= FOUND_SCORE for x in s)} | {np.mean(s):.3f} | {found_all[det]} |")


if __name__ == "__main__":
    main()
