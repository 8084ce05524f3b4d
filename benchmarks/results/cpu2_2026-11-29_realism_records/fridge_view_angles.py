"""fridge_view_angles.py RUN [RUN ...]: for every visible refrigerator of a benchmarks/realism.py run, the angle (deg)
between the fridge's front (its model's facing, as the furnishing placed it) and the direction from the fridge to
the camera, in the floor plane (0: seen square-on from the front; 90: from the side; over 90: from behind its front
plane), and whether each run's detector found it at score >= 0.3 (IoU >= 0.5). The runs must be of the same
environments and frames (e.g. one a detector); then the counts found per angle band, one figure per run. The
trajectory comes from the scene as the simulator builds it (the scene cache), so each home's scene is built once.
Run from the repository root:

    uv run --extra realism python benchmarks/results/cpu2_2026-11-29_realism_records/fridge_view_angles.py \
        RUN_CENTERNET RUN_NANODET RUN_SSD
"""
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, "benchmarks")
import realism as R  # noqa: E402
from benchbot.core.seeding import environment_world_seed  # noqa: E402
from benchbot_sim_taichi import scene_cache  # noqa: E402
from benchbot_worlds.scene.build import build_scene  # noqa: E402

sys.path.insert(0, "benchmarks/results/cpu2_2026-11-29_procedural_kitchens")
from fridge_rooms import furnished  # noqa: E402  (the home as the scene build furnishes it)

#: Angle bands (deg) the counts are given in.
BANDS = ((0, 45), (45, 70), (70, 181))


def load(run: str) -> dict:
    """A run's ``environments`` section; exits with one line if the folder holds no finished run."""
    path = Path(run) / "realism.json"
    if not path.is_file():
        sys.exit(f"{path}: not found; give the --out folder of a finished benchmarks/realism.py run")
    return json.loads(path.read_text())["environments"]


def fridge_fronts(name: str) -> list:
    """[(centroid xy (2,), unit front xy (2,))] of the environment's refrigerators, map frame."""
    _, objects, home = furnished(name)
    out = []
    for inst in home.instances:
        if inst.object_index >= 0 and objects[inst.object_index].get("class") == "refrigerator":
            f = (np.asarray(inst.transform, float)[:3, :3] @ np.array([0.0, -1.0, 0.0]))[:2]  # a model's front: -y
            out.append((np.asarray(objects[inst.object_index]["centroid"], float)[:2], f / np.linalg.norm(f)))
    return out


def found(frame: dict, box) -> bool:
    """Whether a fast-mode refrigerator detection of score >= 0.3 has IoU >= 0.5 with ``box``."""
    return any(R.bear_name(int(d[5])) == "refrigerator" and d[4] >= 0.3
               and R.box_iou(np.asarray(box, float), np.asarray(d[:4], float)) >= 0.5 for d in frame["detections_fast"])


if len(sys.argv) < 2:
    sys.exit("usage: fridge_view_angles.py RUN [RUN ...] (--out folders of benchmarks/realism.py)")
runs = [load(r) for r in sys.argv[1:]]
rows = []
for name, e in runs[0].items():
    fronts = fridge_fronts(name)
    if not fronts:
        continue
    spec = R._env_spec(name, None)
    scene, _ = scene_cache.scene_for(spec, environment_world_seed(0, spec), build=build_scene)
    for f in e["frames"]:
        for o in f["objects"]:
            if o["cls"] != "refrigerator" or not o["visible"]:
                continue
            cam = np.asarray(scene.trajectory_se2[f["pose_index"]][:2], float)
            centre, front = min(fronts, key=lambda cf: np.linalg.norm(cf[0] - cam))
            to_cam = (cam - centre) / np.linalg.norm(cam - centre)
            angle = float(np.degrees(np.arccos(np.clip(to_cam @ front, -1.0, 1.0))))
            hits = [found(next(x for x in run[name]["frames"] if x["pose_index"] == f["pose_index"]), o["box"])
                    for run in runs]
            rows.append((angle, hits))
            print(name, f["pose_index"], round(angle), *("found" if h else "missed" for h in hits), flush=True)
angles = np.array([r[0] for r in rows])
hits = np.array([r[1] for r in rows])
for lo, hi in BANDS:
    m = (angles >= lo) & (angles < hi)
    print(f"{lo}-{min(hi, 180)} deg: {int(m.sum())} views, found {', '.join(str(int(v)) for v in hits[m].sum(axis=0))}")
