"""Procedural home generation: time per home, distinct valid homes over consecutive seeds, and the pooled class
histogram against BEAR's (chi-square goodness of fit, scipy.stats.chisquare).

    uv run python benchmarks/world_generation.py            # 1,000 seeds (chi-square over the first 200)
    uv run python benchmarks/world_generation.py --smoke    # 20 seeds, same checks (a slow test runs this)

Times cover the layout, objects, variants and trajectory (``generate_home``), not the rendering. Prints figures
(times, poses and objects per home, homes with an object no trajectory pose sees or a room the robot cannot reach,
both checked on the JSON: :func:`~benchbot_worlds.procedural.visibility.unseen_objects` over the union of the
variants' objects, :func:`~benchbot_worlds.procedural.free_space.main_component`); exits 1 when two seeds give the
same home, a home is invalid (objects overlapping or floating), has an unseen object or an unreachable room.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time

import numpy as np


def _valid(home) -> str:
    """'' when the home's union of objects has no overlap and nothing floats, else why."""
    union = {}
    for v in home.variants:
        for o in v["ground_truth"]["objects"]:
            union[(o["ID_name"], tuple(o["centroid"]))] = o
    objs = list(union.values())
    c = np.array([o["centroid"] for o in objs]).reshape(-1, 3)
    e = np.array([o["extent"] for o in objs]).reshape(-1, 3)
    lo, hi = c - e / 2, c + e / 2
    ov = np.all(lo[:, None] < hi[None] - 1e-3, axis=2) & np.all(hi[:, None] > lo[None] + 1e-3, axis=2)
    np.fill_diagonal(ov, False)
    if ov.any():
        return "overlap"
    for k in np.nonzero(np.abs(lo[:, 2]) > 1e-3)[0]:
        under = (np.abs(hi[:, 2] - lo[k, 2]) <= 1e-3) & np.all(lo[:, :2] < hi[k, :2], axis=1) & \
            np.all(hi[:, :2] > lo[k, :2], axis=1)
        if not under.any():
            return f"floating {objs[k]['ID_name']}"
    return ""


def _unseen_unreached(home) -> tuple[int, int]:
    """(objects of the variants' union no trajectory pose sees, rooms outside the robot's main free component)."""
    from benchbot_worlds.procedural.free_space import free_space, main_component
    from benchbot_worlds.procedural.visibility import unseen_objects

    union = {}
    for v in home.variants:
        for o in v["ground_truth"]["objects"]:
            union[(o["ID_name"], tuple(o["centroid"]))] = o
    objs = list(union.values())
    env = home.variants[0]["environment"]
    unseen = unseen_objects(home.layout, objs, [env["start_pose"]] + env["trajectory_poses"])
    return len(unseen), sum(not r for r in main_component(free_space(home.layout, objs))[1])


def main(argv=None) -> int:
    import smoke

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=None, help="consecutive seeds from 0 (default 1000)")
    args = smoke.parse_args(ap, argv, style=None, seeds=20)
    from scipy.stats import chisquare

    from benchbot_worlds.procedural.generator import GENERATOR_VERSION, generate_home
    from benchbot_worlds.procedural.objects import bear_proportions

    n = args.seeds or 1000
    names, p = bear_proportions()
    counts = dict.fromkeys(names, 0)
    times, digests, bad, notes, poses, n_objects, unseen, unreached = [], set(), [], 0, [], [], [], []
    generate_home(0, "warm_up")
    for seed in range(n):
        t0 = time.perf_counter()
        home = generate_home(seed, f"procedural_bench_{seed:04d}")
        times.append(time.perf_counter() - t0)
        digests.add(hashlib.sha256(json.dumps(home.variants, sort_keys=True).encode()).hexdigest())
        why = _valid(home)
        if why:
            bad.append((seed, why))
        notes += len(home.notes)
        poses.append(len(home.variants[0]["environment"]["trajectory_poses"]))
        n_objects.append(len(home.variants[0]["ground_truth"]["objects"]))
        u, r = _unseen_unreached(home)
        if u:
            unseen.append(seed)
        if r:
            unreached.append(seed)
        if seed < 200:
            for o in home.variants[0]["ground_truth"]["objects"]:
                counts[o["class"]] += 1
    t = np.array(times)
    obs = np.array([counts[k] for k in names])
    chi = chisquare(obs, p * obs.sum())
    print(f"generator v{GENERATOR_VERSION}: {n} seeds; per home {t.mean():.3f} s mean, {np.median(t):.3f} s median, "
          f"{np.percentile(t, 95):.3f} s p95, {t.max():.3f} s max (seed {int(t.argmax())})")
    print(f"distinct homes: {len(digests)} of {n}; invalid: {len(bad)} {bad[:5]}; homes with an object no pose sees: "
          f"{len(unseen)} {unseen[:5]}; homes with a room the robot cannot reach: {len(unreached)} {unreached[:5]}; "
          f"notes: {notes}")
    print(f"trajectory poses per home: median {np.median(poses):.0f}, min {min(poses)}, max {max(poses)}; objects per "
          f"home (variant 1): median {np.median(n_objects):.0f}, min {min(n_objects)}, max {max(n_objects)}")
    print(f"pooled class histogram of variant 1 over {min(n, 200)} homes ({obs.sum()} objects) vs BEAR: "
          f"chi-square {chi.statistic:.1f}, p {chi.pvalue:.3g}, {len(names) - 1} dof")
    print("  " + ", ".join(f"{k} {c}" for k, c in zip(names, obs.tolist())))
    return 0 if len(digests) == n and not bad and not unseen and not unreached else 1


if __name__ == "__main__":
    sys.exit(main())
