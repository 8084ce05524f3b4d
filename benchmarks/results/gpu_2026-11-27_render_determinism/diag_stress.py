"""Issue 60: render frames A..B of an environment's trajectory over and over in this process through the backend
(as an episode does) until a deadline, and report every render unlike the process's first render of its frame: the
outputs that differ and, for up to 6 RGB pixels that differ, the values of both renders (with diag_patch.py applied:
depth = green radiance before the tone curve, class = pane index, instance = primitive index). Also counts renders
whose radiance differs where the RGB does not. Arch: DIAG_ARCH (default cuda; cpu to try the script on a CPU).
Usage: diag_stress.py ENV A B SECONDS TAG"""
import os, sys, time
import numpy as np
import yaml
from benchbot_worlds import bear
from benchbot_sim_taichi import plugin
from benchbot_sim_taichi.backend import TaichiSimBackend
env, a, b, secs, tag = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4]), sys.argv[5]
spec = yaml.safe_load(open(plugin.ROBOTS_DIR / "carter.yaml"))
envs = {f"{e['name']}:{e['variant']}": e for e in bear.environment_specs()}
be = TaichiSimBackend(spec, {"arch": os.environ.get("DIAG_ARCH", "cuda")})
be.load_scene(envs[env], seed=0)
poses = [np.asarray(p, np.float64) for p in be.scene.trajectory_se2]
r = be._renderer
orig = r.render
got = {}
def wrapped(*args, **kw):
    out = orig(*args, **kw)
    got.clear(); got.update({k: np.array(v, copy=True) for k, v in out.items()})
    return out
r.render = wrapped
first = {}
n = odd = rad_only = 0
t_end = time.time() + secs
rep = 0
while time.time() < t_end:
    for i in range(a, b + 1):
        be.set_pose(poses[i])
        be.observe(["image_rgb", "image_depth", "image_segment", "laser"])
        n += 1
        if i not in first:
            first[i] = dict(got)
            continue
        f = first[i]
        diffs = {k: int(np.sum(np.any((f[k] != got[k]).reshape(f[k].shape[0], -1), axis=1))) if f[k].ndim >= 2 else int(np.sum(f[k] != got[k]))
                 for k in f if f[k].tobytes() != got[k].tobytes()}
        if not diffs:
            continue
        if "rgb" not in diffs:
            rad_only += 1
            if rad_only <= 3:
                print(f"RADONLY {tag} rep {rep} frame {i}: {diffs}", flush=True)
            continue
        odd += 1
        m = np.argwhere(np.any(f["rgb"] != got["rgb"], axis=-1))
        px = []
        for (y, x) in m[:6]:
            px.append(f"({y},{x}) rgb {f['rgb'][y, x].tolist()}->{got['rgb'][y, x].tolist()} g {f['depth'][y, x]!r}->{got['depth'][y, x]!r} "
                      f"prim {f['instance'][y, x]}->{got['instance'][y, x]} pane {f['class'][y, x]}->{got['class'][y, x]}")
        print(f"ODD {tag} rep {rep} frame {i}: {diffs}; {len(m)} rgb px: {'; '.join(px)}", flush=True)
    rep += 1
print(f"SUM {tag} renders {n} reps {rep} odd_rgb {odd} radiance_only {rad_only}", flush=True)
be.close()
