"""BVH build time, size, depth, SAH cost and peak memory of the sim_taichi builder (benchbot_sim_taichi.render.bvh).

For each scene and triangle count, ``build_bvh`` (level-by-level, vectorised) and, up to ``--old-max`` triangles,
``build_bvh_reference`` (the recursive builder it replaced; same tree) build a BVH over the triangles' boxes, each
in its own child process so that its peak RSS is its own. Scenes:

* ``soup``: random thin triangles (edges ~5 cm) in a 20 × 20 × 3 m room;
* ``house1``: house:1's 56 ground-truth cuboids (the BEAR JSON shipped with the plugin), each a tessellated
  ellipsoid filling it, the triangle budget shared by area, inside the room's shell (12 large triangles): a home's
  clustering (dense furniture, empty floor), from fixed data;
* ``mesh:PATH``: a real mesh file (``--mesh PATH``, anything trimesh reads; its own triangle count).

    python benchmarks/bvh_build.py [--sizes 10000,100000,1000000] [--old-max 100000] [--scenes soup,house1]
        [--mesh PATH] [--json [PATH]]

Prints one line per build; ``--json`` prints (or writes to PATH) one JSON object: ``machine``, ``runs`` (each
``scene``, ``builder``, ``triangles``, ``build_s``, ``nodes``, ``depth``, ``sah_cost``, ``peak_rss_mb``,
``input_rss_mb`` (RSS with the input made, before the build)).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import time

import numpy as np

import smoke  # this folder is on sys.path when a script here runs


def soup(n: int, seed: int = 0) -> np.ndarray:
    """(n, 3, 3) float32 random thin triangles in a 20 × 20 × 3 m room."""
    rng = np.random.default_rng(seed)
    c = rng.uniform([-10, -10, 0], [10, 10, 3], (n, 3))
    return (c[:, None, :] + rng.normal(0.0, 0.05, (n, 3, 3))).astype(np.float32)


def ellipsoid(tris: int) -> np.ndarray:
    """(≈tris, 3, 3) triangles of a unit-diameter sphere centred at the origin (a UV grid, no degenerate ones)."""
    rings = max(2, int(np.sqrt(tris / 4.0) + 0.5) + 1)
    seg = 2 * rings
    th, ph = np.meshgrid(np.linspace(0, np.pi, rings + 1), np.linspace(0, 2 * np.pi, seg + 1), indexing="ij")
    p = 0.5 * np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], axis=-1)
    a, b, c, d = p[:-1, :-1], p[1:, :-1], p[1:, 1:], p[:-1, 1:]
    lower = np.stack([a, b, c], axis=2)[:-1].reshape(-1, 3, 3)  # the last ring's (a, b, c) meet at the pole
    upper = np.stack([a, c, d], axis=2)[1:].reshape(-1, 3, 3)  # the first ring's (a, c, d) too
    return np.concatenate([lower, upper])


def box_shell(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(12, 3, 3): the six faces of the box ``lo..hi`` as two triangles each (a room's floor, walls, ceiling)."""
    c = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float) * (hi - lo) + lo
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return np.array([c[[q[0], q[1], q[2]]] for q in quads] + [c[[q[0], q[2], q[3]]] for q in quads])


def house1(n: int) -> np.ndarray:
    """(≈n, 3, 3) float32: house:1's ground-truth objects (the BEAR JSON shipped with benchbot-worlds, 56 cuboids)
    as tessellated ellipsoids filling their cuboids, the budget shared by surface area, inside the room's shell."""
    from benchbot_worlds.bear import DATA_DIR

    path = DATA_DIR / "house_1.json"
    objects = json.loads(path.read_text(encoding="utf-8"))["ground_truth"]["objects"]
    cen = np.array([o["centroid"] for o in objects], float)
    ext = np.maximum(np.array([o["extent"] for o in objects], float), 1e-3)
    area = ext[:, 0] * ext[:, 1] + ext[:, 1] * ext[:, 2] + ext[:, 2] * ext[:, 0]
    budget = np.maximum(8, n * area / area.sum())
    parts = [ellipsoid(int(t)) * e + c for c, e, t in zip(cen, ext, budget)]
    lo, hi = (cen - ext / 2).min(axis=0), (cen + ext / 2).max(axis=0)
    parts.append(box_shell(np.array([lo[0] - 1, lo[1] - 1, 0.0]), np.array([hi[0] + 1, hi[1] + 1, 3.0])))
    return np.concatenate(parts).astype(np.float32)


def mesh(path: str) -> np.ndarray:
    import trimesh

    return np.asarray(trimesh.load(path, force="mesh", process=False).triangles, np.float32)


def one(scene: str, builder: str, n: int) -> dict:
    """Build once in this process; the figures of that build."""
    from benchbot_sim_taichi.render import bvh

    tris = soup(n) if scene == "soup" else house1(n) if scene == "house1" else mesh(scene[len("mesh:"):])
    lo, hi = tris.min(axis=1), tris.max(axis=1)
    input_rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    build = bvh.build_bvh if builder == "new" else bvh.build_bvh_reference
    t0 = time.perf_counter()
    nodes_f, nodes_i, _order = build(lo, hi)
    seconds = time.perf_counter() - t0
    return {"scene": scene, "builder": builder, "triangles": int(tris.shape[0]), "build_s": round(seconds, 3),
            "nodes": int(nodes_f.shape[0]), "depth": bvh.bvh_depth(nodes_i),
            "sah_cost": round(bvh.sah_cost(nodes_f, nodes_i), 4),
            "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
            "input_rss_mb": round(input_rss, 1)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="10000,100000,1000000", help="triangle counts (soup, house1)")
    ap.add_argument("--old-max", type=int, default=100_000, help="largest count also built by the old builder")
    ap.add_argument("--scenes", default="soup,house1")
    ap.add_argument("--mesh", action="append", default=[], help="a real mesh file (repeatable)")
    ap.add_argument("--json", nargs="?", const="-", help="print one JSON object (or write it to PATH)")
    ap.add_argument("--one", help=argparse.SUPPRESS)  # scene:builder:n, in a child process
    args = smoke.parse_args(ap, argv, sizes="2000", old_max=2000)
    if args.one:
        scene, builder, n = args.one.rsplit(":", 2)
        print(json.dumps(one(scene, builder, int(n))))
        return 0
    sizes = [int(s) for s in args.sizes.split(",") if s]
    cases = [(sc, b, n) for sc in args.scenes.split(",") if sc for n in sizes
             for b in (("old", "new") if n <= args.old_max else ("new",))]
    cases += [(f"mesh:{p}", b, 0) for p in args.mesh for b in ("old", "new")]
    runs = []
    for scene, builder, n in cases:
        out = subprocess.run([sys.executable, __file__, "--one", f"{scene}:{builder}:{n}"], capture_output=True,
                             text=True, check=False, timeout=3600)
        if out.returncode != 0:
            print(f"{scene} {builder} {n}: failed\n{out.stderr[-2000:]}", file=sys.stderr)
            return 1
        run = json.loads(out.stdout.strip().splitlines()[-1])
        runs.append(run)
        if args.json != "-":
            print(f"{run['scene']:>8} {run['builder']:>3} {run['triangles']:>9} tris  {run['build_s']:>8.2f} s  "
                  f"{run['nodes']:>8} nodes  depth {run['depth']:>2}  SAH {run['sah_cost']:>9.2f}  "
                  f"peak RSS {run['peak_rss_mb']:>6.0f} MB (input {run['input_rss_mb']:.0f})", flush=True)
    result = {"machine": {"cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(),
                          "python": platform.python_version(), "numpy": np.__version__,
                          "load_avg": [round(x, 2) for x in os.getloadavg()]},
              "runs": runs}
    if args.json == "-":
        print(json.dumps(result, indent=1))
    elif args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(result, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
