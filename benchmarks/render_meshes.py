"""Render throughput of the Taichi simulator on triangle-heavy, textured scenes (benchbot_worlds.scene.meshes).

A room (the primitive style's shell, no ground-truth objects) holds a grid of ``--count`` instances of one mesh: a
GLB/OBJ given with ``--mesh``, else a generated textured sphere of about ``--triangles`` triangles. Each frame is
RGB + depth + class/instance segmentation + a 360-beam laser scan (``Renderer.render_sensors``, fast mode) from
poses circling the room's centre, ``--batch N`` cameras (and scans) per kernel launch. The same scene is timed twice:
with its textures and with them removed (``mat_texture = −1``), which isolates the texture sampling's cost.

    python benchmarks/render_meshes.py [--mesh FILE.glb] [--count 100] [--triangles 2000] [--width 640]
        [--height 480] [--frames 20] [--batch 1] [--arch cpu|cuda] [--json]

JSON keys: ``triangles``, ``textures``, ``bvh_nodes``, ``build_scene_s`` (instances flattened into the scene),
``set_scene_s`` (BVH build, packing and, on CUDA, upload), ``bvh_build_s`` (``bvh.build_bvh`` alone, inside the
first ``set_scene``, on the host CPU), ``scene_mb`` (the packed scene arrays the kernels read: on CUDA what
``set_scene`` uploads), ``bvh_mb`` (its nodes), ``fps_textured``, ``fps_untextured`` (frames in the renderer's
memory: GPU memory on CUDA, the timing ending with a device synchronisation), on CUDA
``fps_textured_with_host_copy`` (the renderer's ``to_host=True``), ``gpu``, ``gpu_mem_used_mb`` (device memory in
use after the timings, the whole device), ``mrays_per_s`` (primary rays, textured), ``peak_rss_mb`` (host),
``machine``, ``cpu_count``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import smoke  # this folder is on sys.path when a script here runs


def _sphere(triangles: int):
    """A UV sphere (radius 0.35 m, bottom at z = 0) of about ``triangles`` triangles with a 256² texture."""
    import trimesh

    from benchbot_worlds.scene.meshes import Material, make_mesh

    seg = max(4, int(math.sqrt(triangles / 4)))
    s = trimesh.creation.uv_sphere(radius=0.35, count=[seg, seg])
    v = np.asarray(s.vertices)
    uv = np.stack([0.5 + np.arctan2(v[:, 1], v[:, 0]) / (2 * np.pi), 0.5 + np.arcsin(np.clip(v[:, 2] / 0.35, -1, 1))
                   / np.pi], axis=1)
    y, x = np.mgrid[0:256, 0:256]
    tex = np.stack([(x * 3) % 256, (y * 5) % 256, ((x // 16 + y // 16) % 2) * 200 + 30], axis=-1).astype(np.uint8)
    return make_mesh(v + (0.0, 0.0, 0.35), s.faces, uv=uv, materials=[Material(np.ones(3, np.float32), texture=tex)])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mesh", default=None, help="a mesh file (GLB/glTF, OBJ, …); default: a textured sphere")
    ap.add_argument("--count", type=int, default=100)
    ap.add_argument("--triangles", type=int, default=2000)
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--frames", type=int, default=20)
    ap.add_argument("--batch", type=int, default=1, help="cameras per kernel launch")
    ap.add_argument("--arch", default=os.environ.get("BENCHBOT_TAICHI_ARCH", "cpu"))
    ap.add_argument("--json", action="store_true")
    args = smoke.parse_args(ap, argv, count=4, triangles=100, width=32, height=24, frames=2)

    from benchbot.core.geometry import se2_to_matrix
    from render import time_bvh_builds  # this folder is on sys.path when a script here runs
    from benchbot_sim_taichi.backend import camera_at
    from benchbot_worlds.scene.meshes import MeshInstance, add_mesh_instances, load_mesh
    from benchbot_sim_taichi.render.renderer import _IN_PACKED, Renderer, intrinsics
    from benchbot_worlds.scene.build import BEAR_CLASS_LIST, build_scene

    bvh_s = time_bvh_builds()

    mesh = load_mesh(args.mesh) if args.mesh else _sphere(args.triangles)
    side = max(1, math.ceil(math.sqrt(args.count)))
    spacing = 1.2 * max(float(np.max(mesh.bounds[1, :2] - mesh.bounds[0, :2])), 0.5)
    half = side * spacing / 2
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:  # an empty ground truth: the room only
        gt = Path(tmp) / "empty.json"
        gt.write_text(json.dumps({"environment": {}, "ground_truth": {"class_list": list(BEAR_CLASS_LIST),
                                                                      "objects": []}}))
        scene = build_scene({"name": "meshes", "variant": 1, "style": "primitives", "lighting": "day",
                             "map_path": str(gt), "start_pose": [1, 0, 0, 0, 0, 0, 0],
                             "trajectory_poses": [[1, 0, 0, 0, -half - 1.0, -half - 1.0, 0],
                                                  [1, 0, 0, 0, half + 1.0, half + 1.0, 0]]})
    instances = []
    for k in range(args.count):
        T = np.eye(4)
        c, s = math.cos(k * 0.7), math.sin(k * 0.7)
        T[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
        T[:3, 3] = (-half + (k % side + 0.5) * spacing, -half + (k // side + 0.5) * spacing, -mesh.bounds[0, 2])
        instances.append(MeshInstance(mesh, T, -1))
    add_mesh_instances(scene, instances)
    t_build = time.perf_counter() - t0
    r = Renderer(args.arch)
    bvh_s.clear()
    t0 = time.perf_counter()
    r.set_scene(scene)
    r.sync()
    t_set = time.perf_counter() - t0
    t_bvh = sum(bvh_s)
    scene_mb = sum(r._packed[k].nbytes for k in _IN_PACKED) / 2**20
    bvh_mb = r._packed["nodes"].nbytes / 2**20
    W, H = args.width, args.height
    K = intrinsics(W, H, 90.0)
    radius = half + 0.8
    poses = [(radius * math.cos(a), radius * math.sin(a), a + math.pi) for a in np.linspace(0, 2 * math.pi, 8,
                                                                                          endpoint=False)]
    cams = [camera_at(*p, z=1.2) for p in poses]
    lidars = [se2_to_matrix(*p, z=0.3) for p in poses]
    angles = np.radians(np.arange(-180.0, 180.0, 1.0))

    B = max(1, args.batch)
    n_launches = max(1, math.ceil(args.frames / B))

    def launch(i: int, to_host: bool):
        idx = [(i * B + b) % len(cams) for b in range(B)]
        return r.render_sensors(K, np.stack([cams[k] for k in idx]), W, H, np.stack([lidars[k] for k in idx]),
                                angles, to_host=to_host)

    def timed(to_host: bool) -> float:
        for i in range(2):
            launch(i, to_host)
        r.sync()
        t = time.perf_counter()
        for i in range(n_launches):
            launch(i, to_host)
        r.sync()
        return n_launches * B / (time.perf_counter() - t)

    on_gpu = r.arch == "cuda"  # frames left in GPU memory there; on the CPU, new NumPy arrays
    fps_tex = timed(to_host=not on_gpu)
    extra = {}
    if on_gpu:
        import gpu_host  # this folder is on sys.path when a script here runs

        extra["fps_textured_with_host_copy"] = timed(to_host=True)
        extra.update(gpu_host.device_info())
    scene.mat_texture = np.full_like(scene.mat_texture, -1)
    r.set_scene(scene)
    fps_plain = timed(to_host=not on_gpu)
    out = {"mesh": args.mesh or f"textured sphere ({mesh.n_triangles} triangles)", "count": args.count,
           "triangles": int(scene.tri_v.shape[0]), "textures": int(scene.tex_info.shape[0]),
           "bvh_nodes": int(r._packed["nodes_f"].shape[0]), "build_scene_s": t_build, "set_scene_s": t_set,
           "bvh_build_s": t_bvh, "scene_mb": scene_mb, "bvh_mb": bvh_mb, "batch": B, "frames": n_launches * B,
           "width": W, "height": H, "arch": r.arch, "fps_textured": fps_tex, "fps_untextured": fps_plain, **extra,
           "mrays_per_s": W * H * fps_tex / 1e6,
           "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
           "machine": platform.processor() or platform.machine(),
           "cpu_count": os.cpu_count(),
           "outputs": "rgb+depth+class+instance+laser(360)"}
    if args.json:
        print(json.dumps(out))
    else:
        print(f"{out['triangles']} triangles ({out['count']} × {out['mesh']}), {out['textures']} textures: scene "
              f"{t_build:.2f} s, BVH+pack {t_set:.2f} s; {W}x{H} arch={r.arch}: {fps_tex:.1f} fps textured, "
              f"{fps_plain:.1f} fps untextured")
    return 0


if __name__ == "__main__":
    sys.exit(main())
