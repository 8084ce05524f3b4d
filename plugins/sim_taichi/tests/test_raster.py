"""The rasterised visibility pass (``benchbot_sim_taichi.render.raster``) finds, for every camera ray, the closest primitive
that the BVH traversal finds (``kernels._trace``, run here ray by ray as the reference), at the same distance, and
the nearest window pane in front of it: on a furnished BEAR home, on triangles that reach behind the camera or fill
the image, on boxes, ellipsoids and cylinders, with a full band queue, and for a batch of cameras."""

import numpy as np
import pytest

ti = pytest.importorskip("taichi")


@pytest.fixture(scope="module")
def kernels():
    """(traced, visibility): the reference kernel (one BVH traversal per pixel) and a function running the
    rasterised pass, both on packed scenes (``renderer.pack_scene``)."""
    from benchbot_sim_taichi.render import layouts, raster, sensors
    from benchbot_sim_taichi.render.kernels import PANES_TRACKED, _ray, _trace
    from benchbot_sim_taichi.render.renderer import ensure_taichi

    ensure_taichi("cpu")

    @ti.kernel
    def traced(cams: ti.types.ndarray(dtype=ti.f32, ndim=2), nodes: ti.types.ndarray(dtype=ti.f32, ndim=2),
               pf: ti.types.ndarray(dtype=ti.f32, ndim=2), pi: ti.types.ndarray(dtype=ti.i32, ndim=2),
               tris: ti.types.ndarray(dtype=ti.f32, ndim=2), depth: ti.types.ndarray(dtype=ti.f32, ndim=3),
               prim: ti.types.ndarray(dtype=ti.i32, ndim=3), pane: ti.types.ndarray(dtype=ti.i32, ndim=3)):
        for b, v, u in depth:
            c = ti.Vector([cams[b, m] for m in ti.static(range(16))])
            o, d = _ray(c, ti.cast(u, ti.f32), ti.cast(v, ti.f32))
            t, k, _n, _tr, _pt, pk = _trace(o, d, 1e30, nodes, pf, pi, tris, False, PANES_TRACKED)
            depth[b, v, u] = t if k >= 0 else 0.0
            prim[b, v, u] = k
            pane[b, v, u] = pk

    def run(kernel_args, cams, W, H, queue_rows=None):
        B = cams.shape[0]
        out = (np.zeros((B, H, W), np.float32), np.zeros((B, H, W), np.int32), np.zeros((B, H, W), np.int32))
        return kernel_args(cams, out, queue_rows) or out

    def traced_run(packed, cams, W, H):
        def go(c, out, _q):
            traced(c, packed["nodes"], packed["pf"], packed["pi"], packed["tris"], *out)
        return run(go, cams, W, H)

    @ti.kernel
    def visible(cams: ti.types.ndarray(dtype=ti.f32, ndim=2), consts: ti.types.ndarray(dtype=ti.f32, ndim=1),
                beams: ti.types.ndarray(dtype=ti.f32, ndim=1), nodes: ti.types.ndarray(dtype=ti.f32, ndim=2),
                pf: ti.types.ndarray(dtype=ti.f32, ndim=2), pi: ti.types.ndarray(dtype=ti.i32, ndim=2),
                tris: ti.types.ndarray(dtype=ti.f32, ndim=2), cluster_box: ti.types.ndarray(dtype=ti.f32, ndim=2),
                cluster_prims: ti.types.ndarray(dtype=ti.i32, ndim=2), n_occluders: ti.i32,
                occluders: ti.types.ndarray(dtype=ti.i32, ndim=1), is_occluder: ti.types.ndarray(dtype=ti.i32, ndim=1),
                listed: ti.types.ndarray(dtype=ti.i32, ndim=1), queue: ti.types.ndarray(dtype=ti.i32, ndim=2),
                counters: ti.types.ndarray(dtype=ti.i32, ndim=1), tiles: ti.types.ndarray(dtype=ti.f32, ndim=2),
                vis: ti.types.ndarray(dtype=ti.i64, ndim=4), ranges: ti.types.ndarray(dtype=ti.f32, ndim=2),
                depth: ti.types.ndarray(dtype=ti.f32, ndim=3), prim: ti.types.ndarray(dtype=ti.i32, ndim=3),
                pane: ti.types.ndarray(dtype=ti.i32, ndim=3)):
        """Steps 1 to 3 of the all-sensors work (``sensors``' own Taichi functions; camera b's row of ``cams`` as
        its pose row, no laser beams), then each pixel's closest primitive, its depth and the nearest pane."""
        pose0 = ti.Vector([0.0 for _ in ti.static(range(layouts.POSE_LEN))])
        sensors._occluders_step(cams, pose0, 0, 1, beams, 0, nodes, pf, pi, tris, consts, n_occluders, occluders,
                                queue, counters, tiles, vis, ranges)
        sensors._clusters_step(cams, pose0, 0, 1, consts, cluster_box, cluster_prims, listed, counters, tiles, vis)
        sensors._primitives_step(cams, pose0, 0, 1, pf, pi, tris, consts, cluster_prims, is_occluder, listed, queue,
                                 counters, tiles, vis)
        for b, v, u in depth:
            t, k = raster.unkey(vis[0, b, v, u])
            pt, pk = raster.unkey(vis[1, b, v, u])
            vis[0, b, v, u] = ti.i64(raster.EMPTY)
            vis[1, b, v, u] = ti.i64(raster.EMPTY)
            depth[b, v, u] = t if k >= 0 else 0.0
            prim[b, v, u] = k
            pane[b, v, u] = pk if pt < t else -1

    def visibility_run(packed, cams, W, H, queue_rows=None):
        B = cams.shape[0]
        vis = np.full((2, B, H, W), raster.EMPTY, np.int64)
        consts = np.zeros(layouts.FRAME_TONE_TABLE, np.float32)
        consts[layouts.FRAME_INTRINSICS:layouts.FRAME_INTRINSICS + 4] = cams[0, layouts.CAM_FX:layouts.CAM_CY + 1]  # the shared intrinsics fx, fy, cx, cy, where the kernels read them

        def go(c, out, q):
            rows = q if q is not None else B * raster.split()["queue_items"]
            visible(c, consts, np.zeros(1, np.float32), packed["nodes"], packed["pf"], packed["pi"], packed["tris"],
                    packed["cluster_box"], packed["cluster_prims"], packed["n_occluders"], packed["occluders"],
                    packed["is_occluder"], np.zeros(B * packed["cluster_prims"].shape[0], np.int32),
                    np.zeros((rows, raster.QUEUE_COLS), np.int32), np.zeros(raster.COUNTERS, np.int32),
                    np.zeros((B, raster.tile_entries(W, H)), np.float32), vis, np.zeros((B, 1), np.float32), *out)
        out = run(go, cams, W, H, queue_rows)
        assert (vis == raster.EMPTY).all()  # the pass leaves its buffer as it found it
        return out

    return traced_run, visibility_run


def _rows(K, poses):
    """The kernels' camera rows (B, 16) float32 of optical-frame poses (4, 4) and intrinsics K."""
    return np.stack([np.concatenate([T[:3, :3].reshape(-1), T[:3, 3], [K[0, 0], K[1, 1], K[0, 2], K[1, 2]]])
                     for T in poses]).astype(np.float32)


#: Pixels (a share of all) where the two passes may see surfaces at different distances: a silhouette pixel whose
#: centre lies within float32 rounding of a triangle's edge, which the ray-triangle test and the edge functions can
#: each put on its own side (1 pixel of 134,400 in furnished miniroom:1's trajectory views from 1.054 m).
SILHOUETTE_SHARE = 1e-4


def _agree(ref, got, min_same=0.999):
    """The same primitive on all but a tie's share of pixels (≥ min_same); where it differs the two are at the same
    distance (a tie of surfaces closer than float32's two tests of them agree: 5e-4 relative, half a millimetre at
    a metre) but on at most :data:`SILHOUETTE_SHARE` of the pixels; elsewhere the distances agree to float32
    rounding."""
    (d_ref, k_ref, p_ref), (d, k, p) = ref, got
    same = k == k_ref
    assert same.mean() >= min_same, f"{1 - same.mean():.5f} of pixels see another primitive"
    hit = same & (k >= 0)
    np.testing.assert_allclose(d[hit], d_ref[hit], rtol=2e-5, atol=1e-6)
    apart = ~same & ~np.isclose(d, d_ref, rtol=5e-4, atol=0.0)
    assert apart.sum() <= max(1, SILHOUETTE_SHARE * d.size), (
        f"{apart.sum()} pixels see surfaces at other distances: {d[apart][:8]} against {d_ref[apart][:8]}")
    assert (p == p_ref).mean() >= min_same


@pytest.mark.slow
def test_closest_hits_equal_the_bvh_traversal_on_a_furnished_home(bear_envs, kernels):
    """miniroom:1 furnished (textured meshes, window panes), views along its trajectory, and a batch of them."""
    from benchbot_sim_taichi.backend import trajectory_cameras
    from benchbot_sim_taichi.render.renderer import intrinsics, pack_scene
    from benchbot_worlds.scene.build import build_scene

    traced, visibility = kernels
    scene = build_scene({**bear_envs["miniroom:1"], "style": "furnished"})
    assert scene.style == "furnished" and scene.prim_glass().any()
    packed = pack_scene(scene)
    W, H = 160, 120
    K = intrinsics(W, H, 90.0)
    poses = trajectory_cameras(scene)
    cams = _rows(K, [poses[i] for i in range(0, len(poses), max(1, len(poses) // 6))])
    ref = traced(packed, cams, W, H)
    got = visibility(packed, cams, W, H)
    _agree(ref, got)
    assert (got[1] >= 0).mean() > 0.9 and (got[2] >= 0).any()  # the room fills the views; some see a window
    for b in range(cams.shape[0]):  # a batch equals its cameras one at a time
        one = visibility(packed, cams[b:b + 1], W, H)
        for a, c in zip(got, one):
            assert np.array_equal(a[b], c[0])
    again = visibility(packed, cams, W, H, queue_rows=1)  # a full queue: the primitives' threads do the bands
    for a, c in zip(got, again):
        assert np.array_equal(a, c)


def _add_tris(scene, tris):
    """Append triangles (T, 3, 3) as primitives of kind triangle belonging to the scene's first object."""
    import dataclasses

    from benchbot_worlds.scene.model import PRIM_TRIANGLE

    n0 = scene.tri_v.shape[0]
    t = tris.shape[0]
    lo, hi = tris.min(axis=1), tris.max(axis=1)
    prim = {
        "prim_type": np.concatenate([scene.prim_type, np.full(t, PRIM_TRIANGLE, scene.prim_type.dtype)]),
        "prim_axis": np.concatenate([scene.prim_axis, np.arange(n0, n0 + t, dtype=scene.prim_axis.dtype)]),
        "prim_min": np.concatenate([scene.prim_min, lo.astype(scene.prim_min.dtype)]),
        "prim_max": np.concatenate([scene.prim_max, hi.astype(scene.prim_max.dtype)]),
        "prim_albedo": np.concatenate([scene.prim_albedo, np.full((t, 3), 0.5, scene.prim_albedo.dtype)]),
        "prim_object": np.concatenate([scene.prim_object, np.zeros(t, scene.prim_object.dtype)]),
        "tri_v": np.concatenate([scene.tri_v.reshape(-1, 3, 3), tris.astype(np.float32)]),
    }
    return dataclasses.replace(scene, **prim)


def test_triangles_reaching_behind_the_camera_and_filling_the_image(synthetic_env, kernels):
    """A floor triangle that passes under and behind the camera (clipped at the rays' nearest distance), a wall
    triangle that fills the whole image (rasterised in queued bands), and a small one in front of it."""
    from benchbot_sim_taichi.render.renderer import intrinsics, pack_scene

    traced, visibility = kernels
    tris = [
        [(-20.0, -20.0, 0.05), (20.0, -20.0, 0.05), (0.0, 30.0, 0.05)],  # under and behind the camera
        [(4.0, -30.0, -10.0), (4.0, 30.0, -10.0), (4.0, 0.0, 30.0)],  # a wall ahead, larger than the view
        [(3.0, -0.2, 0.8), (3.0, 0.3, 0.9), (3.0, 0.0, 1.3)],  # a small triangle in front of the wall
    ]
    from benchbot_worlds.scene.build import build_scene

    env = synthetic_env([("chair", (0.5, 3.0, 0.3), (0.4, 0.4, 0.6))])
    scene = _add_tris(build_scene({**env, "procedural": False}), np.asarray(tris, np.float32))
    packed = pack_scene(scene)
    W, H = 64, 48
    K = intrinsics(W, H, 90.0)
    T = np.eye(4)
    T[:3, :3] = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]]  # optical frame looking along +x, level
    T[:3, 3] = (1.0, 0.0, 1.0)
    down = T.copy()
    down[:3, :3] = T[:3, :3] @ np.array([[1, 0, 0], [0, np.cos(0.9), np.sin(0.9)], [0, -np.sin(0.9), np.cos(0.9)]])
    cams = _rows(K, [T, down])
    ref = traced(packed, cams, W, H)
    got = visibility(packed, cams, W, H)
    _agree(ref, got, min_same=1.0 - 2.0 / (W * H))
    assert (got[1] >= 0).all()  # nothing but triangles in view: the wall and the floor
    small = packed["order"].size - 1  # the last primitive in the scene's order: the small triangle
    assert (got[1][0] == np.flatnonzero(packed["order"] == small)[0]).sum() > 20


def test_boxes_ellipsoids_and_cylinders_equal_the_traversal(synthetic_env, kernels):
    """The procedural primitives of a synthetic room (boxes, ellipsoids, cylinders), seen from its start pose and
    from above."""
    from benchbot_sim_taichi.render.renderer import intrinsics, pack_scene
    from benchbot_worlds.scene.build import build_scene

    traced, visibility = kernels
    env = synthetic_env([("chair", (2.0, 0.5, 0.45), (0.6, 0.6, 0.9)), ("table", (3.0, -0.6, 0.4), (1.2, 0.8, 0.8)),
                         ("chair", (2.5, -1.5, 0.3), (0.5, 0.5, 0.6))])
    scene = build_scene(env)
    kinds = set(np.unique(scene.prim_type).tolist())
    assert len(kinds) >= 2, kinds
    packed = pack_scene(scene)
    W, H = 80, 60
    K = intrinsics(W, H, 90.0)
    ahead = np.eye(4)
    ahead[:3, :3] = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]]
    ahead[:3, 3] = (0.2, 0.0, 0.8)
    above = np.diag([1.0, -1.0, -1.0, 1.0])
    above[:3, 3] = (2.5, -0.5, 2.4)
    ref = traced(packed, _rows(K, [ahead, above]), W, H)
    got = visibility(packed, _rows(K, [ahead, above]), W, H)
    _agree(ref, got)
    assert (got[1] >= 0).mean() > 0.1  # the objects take a good part of the views


def test_a_primitive_with_no_image_has_no_pixels():
    """Nothing in front of the camera (the image box stays at ±1e30) or a NaN box gives no pixels: the box is
    clipped to the image in floating point, before a conversion to int32 could overflow into a vast loop."""
    from benchbot_sim_taichi.render import raster
    from benchbot_sim_taichi.render.renderer import ensure_taichi

    ensure_taichi("cpu")

    @ti.kernel
    def pixels(box: ti.types.ndarray(dtype=ti.f32, ndim=2), out: ti.types.ndarray(dtype=ti.i32, ndim=2)):
        for i in range(box.shape[0]):
            u0, u1, v0, v1 = raster._pixels(ti.Vector([box[i, 0], box[i, 1], box[i, 2], box[i, 3]]), 64, 48)
            out[i, 0], out[i, 1], out[i, 2], out[i, 3] = u0, u1, v0, v1

    boxes = np.array([[1e30, -1e30, 1e30, -1e30], [np.nan, np.nan, np.nan, np.nan], [-5e9, 5e9, 10.2, 11.7],
                      [70.0, 80.0, 0.0, 5.0]], np.float32)
    out = np.zeros((4, 4), np.int32)
    pixels(boxes, out)
    for row in out[[0, 1, 3]]:
        assert row[0] > row[1] or row[2] > row[3], row
    assert out[2].tolist() == [0, 63, 11, 11]


@pytest.mark.parametrize("threads", [1, 2, 3, 16])
def test_spread_loops_visit_every_item_once_dealing_blocks_to_the_cpu_threads(monkeypatch, threads):
    """``sensors._spread``, over blocks of ``block`` items as the callers use it (an image row of pixels, a cluster's
    primitives): a loop over ``_spread_range(blocks) · block`` iterations meets every item of 0..n−1 once (the
    others are ≥ n, skipped), and with Taichi's CPU split (each of T threads one contiguous chunk of
    ⌈iterations / T⌉ when that is at least 512) thread q gets blocks q, q + T, … of ``block`` items."""
    from benchbot_sim_taichi.render import sensors
    from benchbot_sim_taichi.render.renderer import ensure_taichi

    ensure_taichi("cpu")
    monkeypatch.setattr(sensors, "_loop_threads", lambda: threads)

    @ti.kernel
    def dealt(n: ti.i32, block: ti.i32, out: ti.types.ndarray(dtype=ti.i32, ndim=1)) -> ti.i32:
        blocks = (n + block - 1) // block
        r = sensors._spread_range(blocks) * block
        for it in range(r):
            out[it] = sensors._spread(it // block, blocks) * block + it % block
        return r

    for n, block in ((0, 1), (1, 1), (7, 3), (5000, 1), (4800, 640), (3 * 64 + 5, 64)):
        out = np.full(n + threads * block + 1, -1, np.int32)
        r = dealt(n, block, out)
        items = out[:r]
        assert r == threads * -(-(-(-n // block)) // threads) * block
        assert r >= n and r - n < threads * block and (out[r:] == -1).all()
        np.testing.assert_array_equal(np.sort(items[items < n]), np.arange(n))
        chunk = r // threads
        if threads > 1 and chunk >= 512:
            for q in range(threads):
                mine = items[q * chunk:(q + 1) * chunk]
                assert set(np.unique(mine // block).tolist()) <= set(range(q, r // block, threads)), (n, block, q)


def test_the_tile_pyramid_holds_the_farthest_depth_of_each_tile():
    """Step 2's pyramid (``sensors._clusters_step``: row segments, then the levels of tiles), on random keys in an
    image whose sides are not multiples of a tile, for two cameras: each entry is the largest depth of its pixels,
    1e30 where one has no hit, exactly as NumPy computes it (the culling of clusters and primitives relies on it)."""
    from benchbot_sim_taichi.render import layouts, raster, sensors
    from benchbot_sim_taichi.render.renderer import ensure_taichi

    ensure_taichi("cpu")

    @ti.kernel
    def pyramid(table: ti.types.ndarray(dtype=ti.f32, ndim=2), consts: ti.types.ndarray(dtype=ti.f32, ndim=1),
                cluster_box: ti.types.ndarray(dtype=ti.f32, ndim=2),
                cluster_prims: ti.types.ndarray(dtype=ti.i32, ndim=2), listed: ti.types.ndarray(dtype=ti.i32, ndim=1),
                counters: ti.types.ndarray(dtype=ti.i32, ndim=1), tiles: ti.types.ndarray(dtype=ti.f32, ndim=2),
                vis: ti.types.ndarray(dtype=ti.i64, ndim=4)):
        sensors._clusters_step(table, ti.Vector([0.0] * layouts.POSE_LEN), 0, 1, consts, cluster_box, cluster_prims,
                               listed, counters, tiles, vis)

    B, H, W = 2, 150, 70  # 5 × 10 tiles of 16, the last ones partial
    rng = np.random.default_rng(7)
    depth = rng.uniform(0.5, 9.0, (B, H, W)).astype(np.float32)
    empty = rng.random((B, H, W)) < 0.002
    keys = (depth.view(np.int32).astype(np.int64) << 32) | rng.integers(0, 1000, (B, H, W))
    vis = np.full((2, B, H, W), raster.EMPTY, np.int64)
    vis[0] = np.where(empty, raster.EMPTY, keys)
    tiles = np.full((B, raster.tile_entries(W, H)), -1.0, np.float32)
    no_cluster = np.zeros((1, 2), np.int32)  # one cluster of no primitive: none is listed
    pyramid(np.zeros((B, 16), np.float32), np.zeros(layouts.FRAME_TONE_TABLE, np.float32), np.zeros((1, 6), np.float32),
            no_cluster, np.zeros(B, np.int32),
            np.zeros(raster.COUNTERS, np.int32), tiles, vis)
    farthest = np.where(empty, np.float32(1e30), depth)
    first = 0
    for lv in range(raster.TILE_LEVELS):
        side = raster.TILE_PX * 4**lv
        across, down = -(-W // side), -(-H // side)
        want = np.full((B, down, across), -1.0, np.float32)
        for ty in range(down):
            for tx in range(across):
                want[:, ty, tx] = farthest[:, ty * side:(ty + 1) * side, tx * side:(tx + 1) * side].max(axis=(1, 2))
        np.testing.assert_array_equal(tiles[:, first:first + across * down], want.reshape(B, -1), err_msg=f"{lv}")
        first += across * down
    assert (tiles[:, :first] == np.float32(1e30)).any() and (tiles[:, :first] < 9.0).any()  # both kinds of tile


@pytest.mark.slow
def test_the_cuda_grouping_of_the_sensors_kernels_gives_the_cpu_grouping_s_frames(bear_envs, monkeypatch):
    """CUDA's kernels of the all-sensors work read the scene from its two packs (``sensors.occluders_packed_kernel``
    and the rest), the CPU's from its arrays one by one; run here on the CPU, both give the same frames and laser
    scans (miniroom:1, furnished, batched and one camera): colours, classes and instances exactly, depths and ranges
    to within :data:`GROUPING_RTOL` of each other. The two groupings are compiled as separate kernels, and under
    Taichi's fast math LLVM may fuse or order float32 arithmetic differently in each: on an AVX-512 CPU 90 of the
    batch's 20,736 depths differ, by at most 5.96e-7 m (4.5e-7 of the depth, 5 float32 ulps); the rest agree bit for
    bit."""
    from benchbot_sim_taichi.render import sensors
    from benchbot_sim_taichi.backend import trajectory_cameras
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene

    scene = build_scene({**bear_envs["miniroom:1"], "style": "furnished"})
    r = Renderer("cpu", device_buffers=False)
    r.set_scene(scene)
    cams = np.stack(trajectory_cameras(scene)[::5][:3])
    lidars = cams.copy()
    lidars[:, :3, :3] = np.eye(3)
    angles = np.radians(np.arange(-180.0, 180.0, 1.0))
    K = intrinsics(96, 72, 90.0)
    assert len(sensors.sensors_kernels("cpu")) == 4 and len(sensors.sensors_kernels("cuda")) == 4
    cpu = [r.render_sensors(K, cams, 96, 72, lidars, angles), r.render_sensors(K, cams[:1], 96, 72, lidars[:1], angles)]
    cuda_kernels = {rays: sensors.sensors_kernels("cuda", rays) for rays in (True, False)}
    monkeypatch.setattr(sensors, "sensors_kernels", lambda arch, shadow_rays=True: cuda_kernels[shadow_rays])
    cuda = [r.render_sensors(K, cams, 96, 72, lidars, angles),
            r.render_sensors(K, cams[:1], 96, 72, lidars[:1], angles)]
    for a, b in zip(cpu, cuda):
        assert set(a) == set(b) and a["depth"].any()
        for key in a:
            if a[key].dtype.kind == "f":
                np.testing.assert_allclose(a[key], b[key], rtol=GROUPING_RTOL, atol=0, err_msg=key)
            else:
                np.testing.assert_array_equal(a[key], b[key], err_msg=key)


#: Relative difference allowed between the CUDA grouping's depths and ranges and the CPU grouping's (about eight
#: float32 ulps: float rounding, never a different surface hit, which moves a depth by millimetres or more).
GROUPING_RTOL = 1e-6


@pytest.mark.slow  # a subprocess that builds a furnished scene and compiles the kernels with the profiler on
def test_the_sensors_kernels_benchmark_times_each_kernel_and_its_tasks():
    """``benchmarks/sensors_kernels.py --tasks`` (where a frame's time goes, in the docs), tiny: every kernel of the
    CPU grouping timed in order, with its CPU use, and the profiler's tasks named after their kernels."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    from benchbot_sim_taichi.render.sensors import sensors_kernels

    root = Path(__file__).resolve().parents[3]
    proc = subprocess.run([sys.executable, str(root / "benchmarks" / "sensors_kernels.py"), "--env", "miniroom:1",
                           "--width", "32", "--height", "24", "--frames", "2", "--warmup", "1", "--tasks", "--json"],
                          capture_output=True, text=True, timeout=900, cwd=root)
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads(proc.stdout)
    names = [k.__name__ for k in sensors_kernels("cpu", out["shadow_rays"])]
    assert list(out["kernels"]) == names and out["frames"] == 2 and out["fps"] > 0
    assert all(k["ms_per_launch"] > 0 and k["cpu_util"] > 0 for k in out["kernels"].values())
    tasks = out["tasks"]
    assert tasks and {t.split(" #")[0] for t in tasks} == set(names)
    assert all(t.endswith(("(range_for)", "(serial)")) and ms >= 0 for t, ms in tasks.items())
    bad = subprocess.run([sys.executable, str(root / "benchmarks" / "sensors_kernels.py"), "--frames", "0"],
                         capture_output=True, text=True, timeout=120, cwd=root)
    assert bad.returncode == 2 and "must be at least 1" in bad.stderr and "Traceback" not in bad.stderr


@pytest.mark.parametrize("lanes", [0, 7])
def test_lanes_run_every_iteration_of_a_loop_once(monkeypatch, lanes):
    """``sensors._lanes``/``_steps``/``_iteration``: a loop of m iterations over ``_lanes(m)`` lanes meets each of
    0..m−1 once, on the CPU (lanes 0: one iteration a lane) and with a GPU's constant lanes forced on (7 lanes,
    several iterations a lane, some lanes with none)."""
    from benchbot_sim_taichi.render import sensors
    from benchbot_sim_taichi.render.renderer import ensure_taichi

    ensure_taichi("cpu")
    if lanes:
        monkeypatch.setattr(sensors, "_gpu_lanes", lambda: lanes)

    @ti.kernel
    def visits(m: ti.i32, out: ti.types.ndarray(dtype=ti.i32, ndim=1)):
        for lane in range(sensors._lanes(m)):
            for step in range(sensors._steps(lane, m)):
                ti.atomic_add(out[sensors._iteration(lane, step)], 1)

    for m in (0, 1, 6, 7, 8, 50):
        out = np.zeros(m + 1, np.int32)
        visits(m, out)
        assert out[:m].tolist() == [1] * m and out[m] == 0, (lanes, m)


_FORCED_LANES = """
import json, re, sys
import numpy as np
from benchbot_sim_taichi.render import sensors
sensors._gpu_lanes = lambda: 64  # the GPU's loop structure, on the CPU
from benchbot_worlds import bear
from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
from benchbot_worlds.scene.build import build_scene
from taichi.profiler.kernel_profiler import get_default_kernel_profiler
spec = {f"{e['name']}:{e['variant']}": e for e in bear.environment_specs()}["miniroom:1"]
poses = np.load(sys.argv[2])
r = Renderer("cpu", device_buffers=False)
r.set_scene(build_scene(spec))
out = r.render_sensors(intrinsics(96, 72, 90.0), poses["cams"], 96, 72, poses["lidars"], poses["angles"])
np.savez(sys.argv[1], **{k: np.asarray(v) for k, v in out.items()})
profiler = get_default_kernel_profiler()
profiler._update_records()
print(json.dumps(sorted({m.group(1) + " " + m.group(2) for rec in profiler._traced_records
                         if (m := re.fullmatch(r"(.+)_c\\d+_\\d+_kernel_\\d+_(range_for|serial)", rec.name))})))
print(json.dumps([rec.name for rec in profiler._traced_records if rec.name.endswith("_serial")]), file=sys.stderr)
"""


@pytest.mark.slow  # a subprocess that compiles the four CPU kernels with a GPU's loop structure
def test_a_gpus_constant_lanes_give_the_same_frames_with_one_serial_task_for_the_visibility(bear_envs, tmp_path,
                                                                                          monkeypatch):
    """With a GPU's constant lanes (``sensors._gpu_lanes`` forced on, on the CPU, whose offloading is the same):
    the steps before the shading have no serial task but the one that zeroes the counters (none computes a loop's
    bound), and the frames of a batch of three cameras and their scans equal the CPU's own loops' exactly."""
    import json
    import os
    import subprocess
    import sys
    from pathlib import Path

    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene

    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[3] / "benchmarks"))
    from trajectory_views import trajectory_views

    scene = build_scene(bear_envs["miniroom:1"])
    cams, lidars, angles = trajectory_views(scene)
    poses = tmp_path / "poses.npz"
    views = (0, len(cams) // 2, len(cams) - 1)
    np.savez(poses, cams=np.stack([cams[k] for k in views]), lidars=np.stack([lidars[k] for k in views]),
             angles=angles)
    proc = subprocess.run([sys.executable, "-c", _FORCED_LANES, str(tmp_path / "forced.npz"), str(poses)],
                          capture_output=True, text=True, timeout=1200, env={**os.environ, "TI_KERNEL_PROFILER": "1"})
    assert proc.returncode == 0, proc.stderr[-3000:]
    tasks = json.loads(proc.stdout.strip().splitlines()[-1])
    serial = {t for t in tasks if t.endswith("serial")}  # the shading keeps Taichi's own bound (sensors._lanes)
    assert serial in ({"occluders_kernel serial", "shade_kernel serial"},
                      {"occluders_kernel serial", "shade_maps_kernel serial"}), tasks
    assert {t.split()[0] for t in tasks} >= {"occluders_kernel", "clusters_kernel", "primitives_kernel"}
    r = Renderer("cpu", device_buffers=False)
    r.set_scene(scene)
    p = np.load(poses)
    own = r.render_sensors(intrinsics(96, 72, 90.0), p["cams"], 96, 72, p["lidars"], p["angles"])
    forced = np.load(tmp_path / "forced.npz")
    assert set(forced.files) == set(own) and own["depth"].any()
    for key in own:
        np.testing.assert_array_equal(forced[key], np.asarray(own[key]), err_msg=key)
