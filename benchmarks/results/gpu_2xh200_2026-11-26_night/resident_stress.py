"""Issue 60: a resident worker's life in one process, as the service's pool worker lives it (set_resident: scenes
kept between episodes): episodes of several environments in a seeded random order, each a new backend that loads
its world (sharing the kept renderer), walks the trajectory and observes as the server does (observe_borrowed), then
closes. Every frame is compared with the same frame of the process's first episode of that environment; on a
difference, the differing pixels are described. The episodes run on a backend thread, as in a service worker;
``--main-thread`` runs them on the main thread. Usage: resident_stress.py [--main-thread] SEED EPISODES ENV..."""
import random, sys
import numpy as np
import yaml
from benchbot.service import set_resident
from benchbot_worlds import bear
from benchbot_sim_taichi import plugin
from benchbot_sim_taichi.backend import TaichiSimBackend

MAIN_THREAD = "--main-thread" in sys.argv
if MAIN_THREAD:
    sys.argv.remove("--main-thread")
NAMES = ["image_rgb", "image_depth", "image_rgb_info", "image_depth_info", "image_segment", "laser"]
seed, episodes, envs = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3:]
set_resident(True)


def main():
    spec = yaml.safe_load(open(plugin.ROBOTS_DIR / "carter.yaml"))
    specs = {f"{e['name']}:{e['variant']}": e for e in bear.environment_specs()}
    rng = random.Random(seed)
    order = list(envs) + [rng.choice(envs) for _ in range(episodes - len(envs))]
    canon, n, odd = {}, 0, 0
    for ep, env in enumerate(order):
        be = TaichiSimBackend(spec, {"arch": "cuda"})
        be.load_scene(specs[env], seed=0)
        for i, pose in enumerate(be.scene.trajectory_se2):
            be.set_pose(np.asarray(pose, np.float64))
            obs = be.observe_borrowed(NAMES)
            rgb, depth = np.array(obs["image_rgb"]), np.array(obs["image_depth"])
            cls = np.array(obs["image_segment"]["class_segment_img"])
            n += 1
            key = (env, i)
            if key not in canon:
                canon[key] = (rgb, depth, cls)
                continue
            r0, d0, c0 = canon[key]
            if not np.array_equal(rgb, r0) or not np.array_equal(depth, d0):
                odd += 1
                px = np.argwhere(np.any(rgb != r0, axis=-1))
                lo, hi = (px.min(0).tolist(), px.max(0).tolist()) if len(px) else ([], [])
                dd = int(np.sum(depth != d0))
                first = px[:3].tolist()
                vals = [(r0[v, u].tolist(), rgb[v, u].tolist(), float(d0[v, u]), int(c0[v, u]), int(cls[v, u]))
                        for v, u in first]
                print(f"DIFF seed {seed} episode {ep} {env} frame {i}: {len(px)} rgb pixels in rows/cols {lo}..{hi}, "
                      f"{dd} depth pixels; first (canon rgb, rgb, depth, canon class, class): {vals}", flush=True)
        be.close()
    print(f"SUM seed {seed}: {n} frames in {len(order)} episodes ({' '.join(order)}), {odd} unlike the first episode's",
          flush=True)


if __name__ == "__main__":
    if MAIN_THREAD:
        main()
    else:
        from benchbot.server.service import backend_worker
        backend_worker().submit(main).result()  # on the backend thread, as a service worker renders
