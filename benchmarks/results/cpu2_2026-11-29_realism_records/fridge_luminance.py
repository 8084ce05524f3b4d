"""fridge_luminance.py RUN [CLASS]: for every visible object of CLASS (default ``refrigerator``) in a
benchmarks/realism.py run, the fast frame rendered again from the same pose and the mean sRGB luma (Rec. 709
weights on the 8-bit values / 255) of the object's pixels (its instance mask), their standard deviation, that of the
pixels within 20 px around the object's box (not the object) and that of the whole frame; then the medians. Run from
the repository root:

    uv run --extra realism python benchmarks/results/cpu2_2026-11-29_realism_records/fridge_luminance.py RUN
"""
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, "benchmarks")
import realism as R  # noqa: E402
from benchbot.core.geometry import se2_to_matrix  # noqa: E402
from benchbot.core.seeding import environment_world_seed  # noqa: E402
from benchbot_sim_taichi import scene_cache  # noqa: E402
from benchbot_sim_taichi.render.renderer import Renderer  # noqa: E402
from benchbot_worlds.scene.build import build_scene  # noqa: E402

#: Rec. 709 luma weights.
LUMA = np.array([0.2126, 0.7152, 0.0722])
#: The ring around an object's box (px).
RING_PX = 20


def views(env: dict, cls: str) -> list:
    """[(pose index, object)] of the visible objects of ``cls`` in one environment's section of a run."""
    return [(f["pose_index"], o) for f in env["frames"] for o in f["objects"] if o["cls"] == cls and o["visible"]]


def luminances(name: str, seen: list) -> list:
    """[(pose, object luma, its sd, ring luma, frame luma)] of one environment's views, rendered as realism.py does
    with its default ``--seed`` 0 (the world an episode with seed 0 sees), 640×480, fast mode."""
    env = R._env_spec(name, None)
    world = environment_world_seed(0, env)
    scene, key = scene_cache.scene_for(env, world, build=build_scene)
    K, Tc = R.camera_setup(640, 480)
    r = Renderer("cpu", seed=world, camera=R.camera_model())
    scene_cache.set_scene(r, scene, key)
    out = []
    for pose, o in seen:
        frame = r.render(K, se2_to_matrix(*scene.trajectory_se2[pose]) @ Tc, 640, 480, mode="fast")
        luma = (frame["rgb"].astype(np.float64) / 255) @ LUMA
        mask = frame["instance"] == o["instance"]
        x0, y0, x1, y1 = o["box"]
        ring = np.zeros_like(mask)
        ring[max(0, y0 - RING_PX):y1 + RING_PX, max(0, x0 - RING_PX):x1 + RING_PX] = True
        ring &= ~mask
        out.append((pose, luma[mask].mean(), luma[mask].std(), luma[ring].mean(), luma.mean()))
    return out


if len(sys.argv) not in (2, 3):
    sys.exit("usage: fridge_luminance.py RUN [CLASS] (RUN: the --out folder of a finished benchmarks/realism.py run)")
path = Path(sys.argv[1]) / "realism.json"
if not path.is_file():
    sys.exit(f"{path}: not found; give the --out folder of a finished benchmarks/realism.py run")
cls = sys.argv[2] if len(sys.argv) == 3 else "refrigerator"
rows = []
for name, env in json.loads(path.read_text())["environments"].items():
    seen = views(env, cls)
    for pose, m, sd, ring, whole in luminances(name, seen) if seen else []:
        print(f"{name} pose {pose}: {cls} {m:.3f} (sd {sd:.3f}), around it {ring:.3f}, frame {whole:.3f}", flush=True)
        rows.append((m, sd, ring, whole))
if rows:
    med = np.median(np.array(rows), axis=0)
    print(f"{len(rows)} views, medians: {cls} {med[0]:.3f} (sd {med[1]:.3f}), around it {med[2]:.3f}, "
          f"frame {med[3]:.3f}")
