"""fast_quality_probe.py CLASS SPP OUT ENV:POSE ...: the given poses rendered in fast mode and in quality mode (SPP
samples a pixel, the robot's camera, metered), as benchmarks/realism.py renders them; the three detectors run on
both, and for each visible CLASS object it prints whether it is found (score >= 0.3, IoU >= 0.5, same class: "Y")
and the best same-class score at that IoU, then the found counts. Environment variables: MODES (default
"fast,quality"), LAMBERT=1 (every material made Lambertian, roughness 1 and metallic 0, before rendering: quality mode
without its specular lobe). PNGs of every frame go to OUT. Run from the repository root:
uv run --extra realism python benchmarks/results/cpu2_2026-11-27_realism_records/fast_quality_probe.py \
    refrigerator 16 runs/fq house:1:16 house:1:20 ..."""
import dataclasses
import os
import sys
from pathlib import Path

import numpy as np
from PIL import Image

sys.path.insert(0, "benchmarks")
import realism as R  # noqa: E402
from benchbot.core.geometry import se2_to_matrix  # noqa: E402
from benchbot.core.seeding import environment_world_seed  # noqa: E402
from benchbot_sim_taichi import scene_cache  # noqa: E402
from benchbot_sim_taichi.render.renderer import Renderer  # noqa: E402
from benchbot_task_semslam.coco import bear_name, box_iou  # noqa: E402
from benchbot_worlds.scene.build import build_scene  # noqa: E402

cls, spp, out = sys.argv[1], int(sys.argv[2]), Path(sys.argv[3])
out.mkdir(parents=True, exist_ok=True)
modes = os.environ.get("MODES", "fast,quality").split(",")
want: dict = {}
for a in sys.argv[4:]:
    e, p = a.rsplit(":", 1)
    want.setdefault(e, []).append(int(p))
frames = []
for name, pose_indices in want.items():
    env = R._env_spec(name, None)
    world = environment_world_seed(0, env)
    scene, key = scene_cache.scene_for(env, world, build=build_scene)
    if os.environ.get("LAMBERT"):
        scene = dataclasses.replace(scene, mat_roughness=np.ones_like(scene.mat_roughness),
                                    mat_metallic=np.zeros_like(scene.mat_metallic))
        key = None
    K, Tc = R.camera_setup(640, 480)
    r = Renderer(None, seed=world, camera=R.camera_model())
    scene_cache.set_scene(r, scene, key)
    crowd = R.crowd_instances(scene, env)
    for i in pose_indices:
        T = se2_to_matrix(*scene.trajectory_se2[i]) @ Tc
        o = {m: r.render(K, T, 640, 480, mode=m, spp=spp) for m in modes}
        truths = R.frame_truths(o[modes[0]]["instance"], scene, K, T, 400, 0.5, crowd, depth=o[modes[0]]["depth"])
        for m in o:
            Image.fromarray(o[m]["rgb"]).save(out / f"{name.replace(':', '_')}_{i:03d}_{m}.png")
        frames.append((name, i, truths, {m: o[m]["rgb"] for m in o}))
        print("rendered", name, i, flush=True)
res: dict = {}
for det in ("centernet", "nanodet", "ssd"):
    d = R.start_detector(R.parse_args(["--detector", det]))
    for name, i, truths, imgs in frames:
        for m, rgb in imgs.items():
            dets = d.detect(rgb)
            sc = R.score_frame(truths, dets, 0.3, 0.5)
            for t in truths:
                if t.cls == cls and t.visible:
                    best = max([s for (*box, s, c) in dets if box_iou(box, t.box) >= 0.5 and bear_name(int(c)) == cls]
                               + [0])
                    res.setdefault((name, i, t.instance), {})[(det, m)] = ("Y" if sc.hits.get(t.instance) else "-") \
                        + f"{best:.2f}"
    d.close()
total: dict = {}
for k, v in res.items():
    print(k, " ".join(f"{a[0][:3]}/{a[1][:1]}:{b}" for a, b in v.items()))
    for a, b in v.items():
        total[a] = total.get(a, 0) + b.startswith("Y")
print("found of", len(res), total)
