"""Trial (28 Nov 2026, not kept): fast mode metered once per home. Quality mode's meter rule (key 0.18 on the
log-average luminance, then the camera's -0.5 EV compensation) applied once per home, the log-average taken over the
meter's pixels of every 8th pose (radiance decoded from the fast frames at the fixed exposure). Run from the
repository root with benchmarks/realism.py's arguments:

    uv run --extra realism python benchmarks/results/cpu2_2026-11-28_realism_records/metered_per_home.py \
        --all-homes --every 4 --quality-frames 0 --reference-frames 0 --real-reference --detector centernet --out DIR

The homes' exposures (EV) are read from metered_per_home_ev.json beside this file; delete it to meter them again.
"""
import dataclasses, json, sys
from pathlib import Path
import numpy as np
sys.path.insert(0, "benchmarks")
import realism as R
from benchbot_sim_taichi.render.camera_model import CameraModel, METER_KEY, METER_DELTA
from benchbot_worlds.scene.model import LUMA_709

EV_FILE = Path(__file__).with_name("metered_per_home_ev.json")
default_cam = R.camera_model()

def home_evs() -> dict:
    """{environment name: exposure (EV)} for the ten BEAR homes: metered_per_home_ev.json if it exists, else metered
    from fast frames of every 8th pose (seed 0) and written there."""
    if EV_FILE.exists():
        return json.loads(EV_FILE.read_text())
    from benchbot_sim_taichi.render.renderer import Renderer
    from benchbot_sim_taichi import scene_cache
    from benchbot_worlds.scene.build import build_scene
    from benchbot.core.geometry import se2_to_matrix
    from benchbot.core.seeding import environment_world_seed
    evs = {}
    for name in R.all_homes():
        env = R._env_spec(name, None)
        world = environment_world_seed(0, env)
        scene, key = scene_cache.scene_for(env, world, build=build_scene)
        K, Tc = R.camera_setup(640, 480)
        poses = scene.trajectory_se2
        r = Renderer("cpu", seed=world, camera=default_cam); scene_cache.set_scene(r, scene, key)
        logs = []
        for i in range(0, len(poses), 8):
            rgb = r.render(K, se2_to_matrix(*poses[i]) @ Tc, 640, 480, mode="fast")["rgb"]
            lin = CameraModel.meter_sample(default_cam.decode(rgb))  # radiance before exposure
            y = np.maximum(lin.reshape(-1, 3) @ np.asarray(LUMA_709), 0.0)
            logs.append(np.log(METER_DELTA + y))
        lbar = float(np.exp(np.mean(np.concatenate(logs))))
        evs[name] = default_cam.exposure_ev + float(np.log2(METER_KEY / lbar))
        print(name, round(evs[name], 3), flush=True)
    EV_FILE.write_text(json.dumps(evs, indent=1))
    return evs

def main(argv: list[str]) -> int:
    """realism.py's main with each home judged at its own exposure (realism.py's camera_model replaced per home)."""
    evs = home_evs()
    judge_at_default = R.judge_environment

    def judge(name, *a, **k):
        R.camera_model = lambda: dataclasses.replace(default_cam, exposure_ev=evs[name])
        try:
            return judge_at_default(name, *a, **k)
        finally:
            R.camera_model = lambda: default_cam
    R.judge_environment = judge
    return R.main(argv)


if __name__ == "__main__" and len(sys.argv) > 1:
    sys.exit(main(sys.argv[1:]))
