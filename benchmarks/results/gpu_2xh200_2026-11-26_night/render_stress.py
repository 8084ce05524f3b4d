"""Issue 60: render an environment's trajectory R times in this process through the simulator's backend (as an
episode does) and print each frame's digests: of the images as returned, and (with --recopy) of a second copy of the
same GPU outputs made after cuCtxSynchronize, so that a first copy that raced the render shows as a difference.
Usage: render_stress.py run ENV REPS [--recopy] > lines;  render_stress.py sum FILES..."""
import collections, hashlib, sys
import numpy as np


def digest(a):
    return hashlib.sha1(np.ascontiguousarray(a).tobytes()).hexdigest()[:10]


def run(env, reps, recopy):
    import yaml
    from benchbot_worlds import bear
    from benchbot_sim_taichi import plugin
    from benchbot_sim_taichi.backend import TaichiSimBackend
    from benchbot_sim_taichi.render import host_copy
    second = {}
    if recopy:
        orig = host_copy.HostCopier.copy

        def checked(self, arrays):
            out = {k: v.copy() for k, v in orig(self, arrays).items()}
            host_copy.check("cuCtxSynchronize", host_copy.cuda_driver().cuCtxSynchronize())
            again = orig(self, arrays)
            second.clear()
            second.update({k: digest(v) for k, v in again.items()})
            return out
        host_copy.HostCopier.copy = checked
    spec = yaml.safe_load(open(plugin.ROBOTS_DIR / "carter.yaml"))
    envs = {f"{e['name']}:{e['variant']}": e for e in bear.environment_specs()}
    be = TaichiSimBackend(spec, {"arch": "cuda"})
    be.load_scene(envs[env], seed=0)
    poses = [np.asarray(p, np.float64) for p in be.scene.trajectory_se2]
    for r in range(reps):
        for i, pose in enumerate(poses):
            be.set_pose(pose)
            obs = be.observe(["image_rgb", "image_depth", "image_segment", "laser"])
            rgb, depth = obs["image_rgb"], obs["image_depth"]
            s = f" {second.get('rgb', '-')} {second.get('depth', '-')}" if recopy else ""
            print(f"F {r} {i} {digest(rgb)} {digest(depth)}{s}", flush=True)
    be.close()


def summarise(files):
    first = collections.defaultdict(collections.Counter)
    again = collections.defaultdict(collections.Counter)
    n = 0
    for f in files:
        for line in open(f):
            p = line.split()
            if not p or p[0] != "F":
                continue
            n += 1
            first[int(p[2])][(p[3], p[4])] += 1
            if len(p) > 6:
                again[int(p[2])][(p[5], p[6])] += 1
    print(f"{n} frames from {len(files)} processes")
    for name, tab in (("as returned", first), ("copied again after cuCtxSynchronize", again)):
        if not tab:
            continue
        odd = {i: dict(c) for i, c in sorted(tab.items()) if len(c) > 1}
        print(f"{name}: {len(odd)} of {len(tab)} frame indices have more than one image; "
              f"{sum(sum(c.values()) - max(c.values()) for c in (collections.Counter(v) for v in odd.values()))}"
              f" frames unlike their commonest")
        for i, c in list(odd.items())[:8]:
            print(f"  frame {i}: {c}")


if __name__ == "__main__":
    if sys.argv[1] == "run":
        run(sys.argv[2], int(sys.argv[3]), "--recopy" in sys.argv)
    else:
        summarise(sys.argv[2:])
