"""The all-sensors work of ``fast`` mode (:func:`sensors_kernel`): B camera frames (RGB, depth, class and instance
segmentation) and B laser scans in four kernel launches, and :func:`sensors_graph`, the four kernels compiled as
one ``ti.graph``. :class:`~benchbot_sim_taichi.render.renderer.Renderer` prepares their arguments and launches them.

The loops run one after the other (:mod:`benchbot_sim_taichi.render.raster` for the visibility buffer), each step a
kernel (:func:`occluders_kernel`, :func:`clusters_kernel`, :func:`primitives_kernel`, :func:`shade_kernel`):

1. the laser beams (traced through the BVH) beside the occluders (the large triangles, ``raster.OCCLUDER_AREA_M2``),
   which are rasterised into each camera's visibility buffer; their large images are queued in parts, and
   rasterised by the next loop;
2. a pyramid of tiles of the largest depth so far in each camera's image (built from row segments of a tile's
   width); the clusters of the BVH that meet each camera's view and are not hidden behind it are listed;
3. their primitives, but the occluders, each culled against the pyramid the same way, are rasterised (the nearest
   window pane into the buffer's second layer), large images again queued in parts and rasterised by the next loop;
4. the pixels: each reads its closest hit from the visibility buffer (and resets it), then is shaded as
   :func:`~benchbot_sim_taichi.render.kernels._surface` says, lit by the baked light of its triangle
   (:mod:`benchbot_sim_taichi.render.lightmap`) or by :func:`~benchbot_sim_taichi.render.kernels._direct`.

A primitive is culled only when every tile its image covers already holds a hit nearer than its nearest point, so
culling changes no pixel.
"""

import contextlib
import functools
import gc
import sys

with contextlib.redirect_stdout(sys.stderr):
    import taichi as ti

from benchbot_sim_taichi.render import lightmap
from benchbot_sim_taichi.render import raster  # noqa: E402 - after Taichi's banner is redirected
from benchbot_sim_taichi.render.camera_model import TABLE_STEPS  # noqa: E402
from benchbot_sim_taichi.render.kernels import (  # noqa: E402
    PANES_TRACKED, PANES_UNSEEN, _closest_normal, _direct, _glass_reflectance, _ray, _safe_inv, _shadow_origin,
    _surface, _trace, _v3,
)
from benchbot_sim_taichi.render.layouts import (  # noqa: E402
    CAM_R, FRAME_INTRINSICS, FRAME_PARAMS, FRAME_RADIANCE_SCALE, FRAME_TONE_TABLE, FRAME_VIGNETTING, FRAME_WORLD,
    P_SEED, PARAMS_LEN, POSE_LEN, POSE_LIDAR_XYZ, POSE_LIDAR_YAW, WORLD_AMBIENT, WORLD_ROOM_MAX, WORLD_ROOM_MIN,
)
from benchbot_sim_taichi.render.packed_scene import scene_views  # noqa: E402
from benchbot_sim_taichi.render.scene_arrays import annotations, parameters  # noqa: E402

#: Entries of the tone table (``camera_model.tone_table``), which starts at ``FRAME_TONE_TABLE`` of the frame constants.
GAMMA_STEPS = TABLE_STEPS


@ti.func
def _through_pane(col, d, pane, tris: ti.template(), consts: ti.template()):
    """Fast mode's colour ``col`` (linear) seen along camera ray d through pane primitive ``pane``: a slab whose two
    faces pass (1 − F)² of it and reflect F + (1 − F)² F of the environment the ambient term stands for — quality
    mode's sky, ``ambient · (0.8 + 0.3 r_z)`` in the mirror direction r (no traversal, no shadow ray)."""
    v0 = _v3(tris, pane, 0)
    nrm = (_v3(tris, pane, 3) - v0).cross(_v3(tris, pane, 6) - v0).normalized()
    dn = d.normalized()
    c = nrm.dot(dn)
    f = _glass_reflectance(ti.abs(c))
    r = dn - 2.0 * c * nrm
    a = FRAME_WORLD + WORLD_AMBIENT
    sky = ti.Vector([consts[a], consts[a + 1], consts[a + 2]]) * (0.8 + 0.3 * r[2])
    return col * ((1.0 - f) * (1.0 - f)) + sky * (f + (1.0 - f) * (1.0 - f) * f)


@ti.func
def _scan_beam(o, a, nodes: ti.template(), pf: ti.template(), pi: ti.template(),
               tris: ti.template(), world: ti.template()):
    """Range (m) along the horizontal beam from o at map-frame angle a to the first primitive or wall (through
    window panes)."""
    d = ti.Vector([ti.cos(a), ti.sin(a), 0.0])
    best, k, n, _tr, _pt, _pk = _trace(o, d, 1e30, nodes, pf, pi, tris, False, PANES_UNSEEN)
    inv = _safe_inv(d)
    lo = WORLD_ROOM_MIN
    hi = WORLD_ROOM_MAX
    tx = ti.max((world[lo] - o[0]) * inv[0], (world[hi] - o[0]) * inv[0])
    ty = ti.max((world[lo + 1] - o[1]) * inv[1], (world[hi + 1] - o[1]) * inv[1])
    return ti.min(best, ti.min(tx, ty))


@ti.func
def _camera(table: ti.template(), pose0, one, b, consts: ti.template()):
    """Camera b's row for the kernels (:data:`~.layouts.CAM_LEN`: R row-major, origin, fx, fy, cx, cy): a pose row's
    first 12 entries are a camera row's."""
    q = pose0
    if one == 0:
        for k in ti.static(range(CAM_R, POSE_LIDAR_XYZ)):
            q[k] = table[b, k]
    f = FRAME_INTRINSICS
    return ti.Vector([q[0], q[1], q[2], q[3], q[4], q[5], q[6], q[7], q[8], q[9], q[10], q[11],
                      consts[f], consts[f + 1], consts[f + 2], consts[f + 3]])


def _loop_threads() -> int:
    """Threads among which Taichi splits a parallel loop (read when a kernel is compiled): the CPU back end's
    ``cpu_max_num_threads``; 1 on a GPU, where :func:`_spread` leaves the order alone."""
    cfg = ti.lang.impl.current_cfg()
    return 1 if cfg.arch == ti.cuda else max(1, int(cfg.cpu_max_num_threads))


@ti.func
def _per_thread(n):
    """Items of a loop over n items that each thread's share of :func:`_spread` holds: ⌈n / T⌉."""
    T = ti.static(_loop_threads())
    return (n + T - 1) // T


@ti.func
def _spread_range(n):
    """Iterations of a parallel loop over n items that :func:`_spread` deals out: n rounded up to a whole share for
    each thread (n itself on a GPU)."""
    return ti.static(_loop_threads()) * _per_thread(n)


@ti.func
def _spread(i, n):
    """The item of iteration i of a loop over :func:`_spread_range` (n) iterations (an item ≥ n is none: skip it).
    Taichi 1.7's CPU back end gives each of its T threads one contiguous chunk of a parallel loop, of max(⌈iterations
    / T⌉, 512) iterations (no work stealing): a loop whose costly items are bunched (the image's lower half, full of
    furniture; the laser's beams, first) keeps one core busy while the other waits. Here thread q's chunk holds
    items q, q + T, q + 2T, …. A loop over larger units (an image row of pixels, a cluster's primitives) spreads
    the units: iteration it is unit ``_spread(it // size, units)``, element ``it % size`` of it. On a GPU the items
    keep their order (neighbouring threads on neighbouring items)."""
    item = i
    if ti.static(_loop_threads() > 1):
        per = _per_thread(n)
        item = ti.static(_loop_threads()) * (i % per) + i // per
    return item


#: Lanes of a parallel loop on a GPU (:func:`_lanes`): about the threads Taichi itself gives a long loop there (its
#: saturating grid: on an H200 132 SMs × 32 resident blocks × 2, of 128 threads, 1.08 M).
GPU_LANES = 1 << 20


def _gpu_lanes() -> int:
    """:data:`GPU_LANES` on a GPU, 0 on the CPU (read when a kernel is compiled)."""
    return GPU_LANES if ti.lang.impl.current_cfg().arch == ti.cuda else 0


@ti.func
def _lanes(m: ti.template()):
    """The bound of a parallel loop of m iterations, which runs :func:`_steps` (lane, m) iterations a lane, iteration
    :func:`_iteration` (lane, step). On a GPU the constant :data:`GPU_LANES` (m is not read), lane ℓ taking the
    iterations ℓ, ℓ + GPU_LANES, …: Taichi computes a bound that is not a compile-time constant in a serial task,
    one more GPU kernel to launch before the loop's, and with one camera the host's work to launch a frame is what
    limits its rate (``benchmarks/one_camera.py``); so the counts a loop needs are computed inside it, and m is a
    template: an expression that is never evaluated there (a Taichi function it calls must keep no local variable
    that is assigned twice, or the variable stays behind in a serial task; :func:`_tiles` and the other counts).
    On the CPU m itself (at least 1), one iteration a lane (Taichi's CPU back end deals out the lanes,
    :func:`_spread`). The shading loop keeps Taichi's own bound: its body in a lane's loop took the H200 twice as
    long with 256 cameras a launch (``benchmarks/sensors_kernels.py --tasks``)."""
    if ti.static(_gpu_lanes()):
        return ti.static(_gpu_lanes())
    else:
        return ti.max(m, 1)


@ti.func
def _steps(lane, m):
    """Iterations of lane ``lane`` of a loop of m iterations (:func:`_lanes`)."""
    if ti.static(_gpu_lanes()):
        return (m - lane + ti.static(_gpu_lanes()) - 1) // ti.static(_gpu_lanes())
    else:
        return ti.cast(lane < m, ti.i32)


@ti.func
def _iteration(lane, step):
    """Iteration ``step`` of lane ``lane`` (:func:`_lanes`), in 0..m−1. (On the CPU step is 0, and the iteration is
    lane + step all the same: an item that did not depend on the inner loop would be hoisted above it by Taichi's
    loop-invariant code motion, and an empty loop's item arithmetic can divide by zero, which traps on a CPU.)"""
    if ti.static(_gpu_lanes()):
        return lane + step * ti.static(_gpu_lanes())
    else:
        return lane + step


@ti.func
def _occluders_step(table: ti.template(), pose0: ti.template(), one: ti.template(), images: ti.template(),
                    beams: ti.template(), n_beams: ti.template(), nodes: ti.template(), pf: ti.template(),
                    pi: ti.template(), tris: ti.template(), consts: ti.template(), n_occluders: ti.template(),
                    occluders: ti.template(), queue: ti.template(), counters: ti.template(), tiles: ti.template(),
                    vis: ti.template(), ranges: ti.template()):
    """Step 1: the laser's beams into ``ranges`` beside the occluders (large triangles) rasterised into ``vis``, then
    their queued large images. (Each loop computes the counts it needs itself: :func:`_lanes`.)"""
    counters[0] = 0
    counters[1] = 0
    # 1. The laser's beams, and the occluders (the large triangles) of each camera. A beam is a long ray: beside the
    # occluders the beams run while the loop would otherwise wait on a few (one camera: 360 lone beams after the
    # pixels used to cost the H200 a third of a frame).
    for lane in range(_lanes(_spread_range(_beams_and_occluders(ranges, n_beams, vis, n_occluders, images)))):
        n_items = _beams_and_occluders(ranges, n_beams, vis, n_occluders, images)
        n_scan = ranges.shape[0] * n_beams
        n_occ = n_occluders * images
        for step in range(_steps(lane, _spread_range(n_items))):
            i = _spread(_iteration(lane, step), n_items)
            if i < n_items:
                _occluder_item(i, n_scan, n_occ, table, pose0, one, beams, n_beams, nodes, pf, pi, tris, consts,
                               occluders, queue, counters, tiles, vis, ranges)
    _queued_loop(table, pose0, one, pf, pi, tris, consts, queue, counters, vis, True)


@ti.func
def _occluder_item(i, n_scan, n_occ, table: ti.template(), pose0, one, beams: ti.template(), n_beams,
                   nodes: ti.template(), pf: ti.template(), pi: ti.template(), tris: ti.template(),
                   consts: ti.template(), occluders: ti.template(), queue: ti.template(), counters: ti.template(),
                   tiles: ti.template(), vis: ti.template(), ranges: ti.template()):
    """Item i of step 1's first loop: a laser beam (i < n_scan), else an occluder of one camera."""
    if i < n_scan:
        b = i // n_beams
        beam = i % n_beams
        q = pose0
        if one == 0:
            for m in ti.static(range(POSE_LIDAR_XYZ, POSE_LEN)):
                q[m] = table[b, m]
        lx = POSE_LIDAR_XYZ
        ranges[b, beam] = _scan_beam(ti.Vector([q[lx], q[lx + 1], q[lx + 2]]), beams[beam] + q[POSE_LIDAR_YAW], nodes,
                                     pf, pi, tris, consts)
    else:
        e = i - n_scan
        raster.rasterise_occluder(e, n_occ, _camera(table, pose0, one, e // n_occ, consts), occluders, pf, pi, tris,
                                  vis, queue, counters, tiles)


@ti.func
def _queued_loop(table: ti.template(), pose0: ti.template(), one: ti.template(), pf: ti.template(),
                 pi: ti.template(), tris: ti.template(), consts: ti.template(), queue: ti.template(),
                 counters: ti.template(), vis: ti.template(), occluders: ti.template()):
    """The loop over the parts of the large images queued by the loop before (``counters[1]`` of them; steps 1 and
    3), ``occluders`` (compile-time) as ``raster.rasterise_queued`` takes it."""
    for lane in range(_lanes(_spread_range(_queued(counters, queue)))):
        n_queued = _queued(counters, queue)
        for step in range(_steps(lane, _spread_range(n_queued))):
            t = _spread(_iteration(lane, step), n_queued)
            if t < n_queued:
                j, part = raster.item_lane(t)
                raster.rasterise_queued(j, part, _camera(table, pose0, one, queue[j, 1] // vis.shape[2], consts), pf,
                                        pi, tris, vis, queue, occluders)


# The counts of the loops of steps 1-3, each written once for both the loop's bound (:func:`_lanes`) and its lanes:
# Taichi functions of template parameters with no local variable, which in a bound leave no statement behind on a GPU.


@ti.func
def _beams_and_occluders(ranges: ti.template(), n_beams: ti.template(), vis: ti.template(),
                         n_occluders: ti.template(), images: ti.template()):
    """Items of step 1's first loop: the B scans' beams, then the B cameras' occluders."""
    return ranges.shape[0] * n_beams + vis.shape[1] * n_occluders * images


@ti.func
def _queued(counters: ti.template(), queue: ti.template()):
    """Items of :func:`_queued_loop`: the parts of the queued images (the queue keeps at most its rows)."""
    return ti.min(counters[1], queue.shape[0]) * ti.static(raster.split()["lanes"])


@ti.func
def _listing(vis: ti.template(), cluster_prims: ti.template(), images: ti.template()):
    """Items of step 2's last loop: each camera's clusters."""
    return vis.shape[1] * cluster_prims.shape[0] * images


@ti.func
def _primitive_iterations(counters: ti.template()):
    """Iterations of step 3's first loop: the listed clusters' primitives (a CPU thread's share: whole clusters)."""
    return _spread_range(counters[0]) * raster.CLUSTER_PRIMS


@ti.func
def _tiles(vis: ti.template(), images: ti.template(), lv: ti.template(), rows: ti.template()):
    """Items of a loop of step 2 over the B cameras' tiles of pyramid level ``lv`` (as ``raster.tile_levels``): with
    ``rows``, row segments of a level-0 tile's width; else tiles."""
    side = ti.static(raster.TILE_PX * 4 ** lv)
    return vis.shape[1] * images * ((vis.shape[3] + side - 1) // side) * (
        vis.shape[2] if ti.static(rows) else (vis.shape[2] + side - 1) // side)


@ti.func
def _clusters_step(table: ti.template(), pose0: ti.template(), one: ti.template(), images: ti.template(),
                   consts: ti.template(), cluster_box: ti.template(), cluster_prims: ti.template(),
                   listed: ti.template(), counters: ti.template(), tiles: ti.template(), vis: ti.template()):
    """Step 2: the tile pyramid of the depths in ``vis`` so far, then the clusters in each camera's view and not
    hidden behind it, into ``listed``."""
    for lane in range(_lanes(_tiles(vis, images, 0, True))):
        if lane == 0:  # (here and not before the loop, which would cost a serial task: :func:`_lanes`)
            counters[1] = 0
        for step in range(_steps(lane, _tiles(vis, images, 0, True))):
            raster.segment_depth(_iteration(lane, step), vis, tiles)
    for lv in ti.static(range(raster.TILE_LEVELS)):
        for lane in range(_lanes(_tiles(vis, images, lv, False))):
            for step in range(_steps(lane, _tiles(vis, images, lv, False))):
                raster.tile_depth(_iteration(lane, step), lv, vis, tiles)
    # (the clusters in view are bunched in the BVH's order: dealt out on the CPU)
    for lane in range(_lanes(_spread_range(_listing(vis, cluster_prims, images)))):
        n_clusters = cluster_prims.shape[0] * images
        n_listing = _listing(vis, cluster_prims, images)
        for step in range(_steps(lane, _spread_range(n_listing))):
            i = _spread(_iteration(lane, step), n_listing)
            if i < n_listing:
                raster.list_cluster(i, _camera(table, pose0, one, i // n_clusters, consts), n_clusters, cluster_box,
                                    cluster_prims, listed, counters, tiles, vis.shape[3], vis.shape[2])


@ti.func
def _primitives_step(table: ti.template(), pose0: ti.template(), one: ti.template(), images: ti.template(),
                     pf: ti.template(), pi: ti.template(), tris: ti.template(), consts: ti.template(),
                     cluster_prims: ti.template(), is_occluder: ti.template(), listed: ti.template(),
                     queue: ti.template(), counters: ti.template(), tiles: ti.template(), vis: ti.template()):
    """Step 3: the listed clusters' primitives (but the occluders), each culled against the tile pyramid, into
    ``vis``, then their queued large images."""
    for lane in range(_lanes(_primitive_iterations(counters))):
        n_clusters = cluster_prims.shape[0] * images
        n_listed = counters[0]
        for step in range(_steps(lane, _primitive_iterations(counters))):
            it = _iteration(lane, step)
            e = _spread(it // raster.CLUSTER_PRIMS, n_listed)
            if e < n_listed:
                i = e * raster.CLUSTER_PRIMS + it % raster.CLUSTER_PRIMS
                b, k = raster.listed_primitive(i, n_clusters, cluster_prims, listed)
                if k >= 0 and is_occluder[k] == 0:
                    raster.rasterise_primitive(_camera(table, pose0, one, b, consts), b, k, pf, pi, tris, vis, queue,
                                               counters, tiles, True, False)
    _queued_loop(table, pose0, one, pf, pi, tris, consts, queue, counters, vis, False)


@ti.kernel
def occluders_kernel(
    table: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (B, POSE_LEN) f32 frame b's pose in row b (if one == 0)
    pose0: ti.types.vector(POSE_LEN, ti.f32),
    one: ti.i32,
    images: ti.i32,
    beams: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (≥ n_beams,) f32 the beams' angles (rad, from the lidar's x)
    n_beams: ti.i32,
    nodes: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (I, 16) f32 SceneArrays.nodes
    pf: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (P, 11) f32 SceneArrays.pf
    pi: ti.types.ndarray(dtype=ti.i32, ndim=2),  # (P, 4) i32 SceneArrays.pi
    tris: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (P, 9) f32 SceneArrays.tris
    consts: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (FRAME_TONE_TABLE + GAMMA_STEPS,) f32 frame constants
    n_occluders: ti.i32,
    occluders: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (O,) i32 SceneArrays.occluders
    queue: ti.types.ndarray(dtype=ti.i32, ndim=2),  # (Q, raster.QUEUE_COLS) i32 work: the large images queued in parts
    counters: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (raster.COUNTERS,) i32 work: clusters listed, images queued
    tiles: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (B, raster.tile_entries(W, H)) f32 work: tile pyramids
    vis: ti.types.ndarray(dtype=ti.i64, ndim=4),  # (2, B, H, W) i64 closest hit, nearest pane (work)
    ranges: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (B, ≥ n_beams) f32 out: each frame's laser ranges (m)
):
    """Step 1 alone (the CPU's first kernel). Parameters: those of :func:`sensors_kernel` that it uses."""
    _occluders_step(table, pose0, one, images, beams, n_beams, nodes, pf, pi, tris, consts, n_occluders, occluders,
                    queue, counters, tiles, vis, ranges)


@ti.kernel
def clusters_kernel(
    table: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (B, POSE_LEN) f32 frame b's pose in row b (if one == 0)
    pose0: ti.types.vector(POSE_LEN, ti.f32),
    one: ti.i32,
    images: ti.i32,
    consts: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (FRAME_TONE_TABLE + GAMMA_STEPS,) f32 frame constants
    cluster_box: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (C, 6) f32 SceneArrays.cluster_box
    cluster_prims: ti.types.ndarray(dtype=ti.i32, ndim=2),  # (C, 2) i32 SceneArrays.cluster_prims
    listed: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (≥ B·C,) i32 work: the clusters listed in the cameras' views
    counters: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (raster.COUNTERS,) i32 work: clusters listed, images queued
    tiles: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (B, raster.tile_entries(W, H)) f32 work: tile pyramids
    vis: ti.types.ndarray(dtype=ti.i64, ndim=4),  # (2, B, H, W) i64 closest hit, nearest pane (work)
):
    """Step 2 alone (the CPU's second kernel). Parameters: those of :func:`sensors_kernel` that it uses."""
    _clusters_step(table, pose0, one, images, consts, cluster_box, cluster_prims, listed, counters, tiles, vis)


@ti.kernel
def primitives_kernel(
    table: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (B, POSE_LEN) f32 frame b's pose in row b (if one == 0)
    pose0: ti.types.vector(POSE_LEN, ti.f32),
    one: ti.i32,
    images: ti.i32,
    pf: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (P, 11) f32 SceneArrays.pf
    pi: ti.types.ndarray(dtype=ti.i32, ndim=2),  # (P, 4) i32 SceneArrays.pi
    tris: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (P, 9) f32 SceneArrays.tris
    consts: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (FRAME_TONE_TABLE + GAMMA_STEPS,) f32 frame constants
    cluster_prims: ti.types.ndarray(dtype=ti.i32, ndim=2),  # (C, 2) i32 SceneArrays.cluster_prims
    is_occluder: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (P,) i32 SceneArrays.is_occluder
    listed: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (≥ B·C,) i32 work: the clusters listed in the cameras' views
    queue: ti.types.ndarray(dtype=ti.i32, ndim=2),  # (Q, raster.QUEUE_COLS) i32 work: the large images queued in parts
    counters: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (raster.COUNTERS,) i32 work: clusters listed, images queued
    tiles: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (B, raster.tile_entries(W, H)) f32 work: tile pyramids
    vis: ti.types.ndarray(dtype=ti.i64, ndim=4),  # (2, B, H, W) i64 closest hit, nearest pane (work)
):
    """Step 3 alone (the CPU's third kernel). Parameters: those of :func:`sensors_kernel` that it uses."""
    _primitives_step(table, pose0, one, images, pf, pi, tris, consts, cluster_prims, is_occluder, listed, queue,
                     counters, tiles, vis)


@ti.kernel
def occluders_packed_kernel(
    table: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (B, POSE_LEN) f32 frame b's pose in row b (if one == 0)
    pose0: ti.types.vector(POSE_LEN, ti.f32),
    one: ti.i32,
    images: ti.i32,
    beams: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (≥ n_beams,) f32 the beams' angles (rad, from the lidar's x)
    n_beams: ti.i32,
    scene_f32: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (F,) f32 SceneArrays.scene_f32
    scene_i32: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (J,) i32 SceneArrays.scene_i32
    consts: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (FRAME_TONE_TABLE + GAMMA_STEPS,) f32 frame constants
    n_occluders: ti.i32,
    queue: ti.types.ndarray(dtype=ti.i32, ndim=2),  # (Q, raster.QUEUE_COLS) i32 work: the large images queued in parts
    counters: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (raster.COUNTERS,) i32 work: clusters listed, images queued
    tiles: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (B, raster.tile_entries(W, H)) f32 work: tile pyramids
    vis: ti.types.ndarray(dtype=ti.i64, ndim=4),  # (2, B, H, W) i64 closest hit, nearest pane (work)
    ranges: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (B, ≥ n_beams) f32 out: each frame's laser ranges (m)
):
    """Step 1, the scene packed (CUDA's first kernel): :func:`occluders_kernel` reading the scene's arrays through
    :func:`~benchbot_sim_taichi.render.packed_scene.scene_views`."""
    v = ti.static(scene_views(scene_f32, scene_i32))
    _occluders_step(table, pose0, one, images, beams, n_beams, v.nodes, v.pf, v.pi, v.tris, consts, n_occluders,
                    v.occluders, queue, counters, tiles, vis, ranges)


@ti.kernel
def clusters_packed_kernel(
    table: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (B, POSE_LEN) f32 frame b's pose in row b (if one == 0)
    pose0: ti.types.vector(POSE_LEN, ti.f32),
    one: ti.i32,
    images: ti.i32,
    scene_f32: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (F,) f32 SceneArrays.scene_f32
    scene_i32: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (J,) i32 SceneArrays.scene_i32
    consts: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (FRAME_TONE_TABLE + GAMMA_STEPS,) f32 frame constants
    listed: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (≥ B·C,) i32 work: the clusters listed in the cameras' views
    counters: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (raster.COUNTERS,) i32 work: clusters listed, images queued
    tiles: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (B, raster.tile_entries(W, H)) f32 work: tile pyramids
    vis: ti.types.ndarray(dtype=ti.i64, ndim=4),  # (2, B, H, W) i64 closest hit, nearest pane (work)
):
    """Step 2, the scene packed (CUDA's second kernel): :func:`clusters_kernel` reading the scene's packs."""
    v = ti.static(scene_views(scene_f32, scene_i32))
    _clusters_step(table, pose0, one, images, consts, v.cluster_box, v.cluster_prims, listed, counters, tiles, vis)


@ti.kernel
def primitives_packed_kernel(
    table: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (B, POSE_LEN) f32 frame b's pose in row b (if one == 0)
    pose0: ti.types.vector(POSE_LEN, ti.f32),
    one: ti.i32,
    images: ti.i32,
    scene_f32: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (F,) f32 SceneArrays.scene_f32
    scene_i32: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (J,) i32 SceneArrays.scene_i32
    consts: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (FRAME_TONE_TABLE + GAMMA_STEPS,) f32 frame constants
    listed: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (≥ B·C,) i32 work: the clusters listed in the cameras' views
    queue: ti.types.ndarray(dtype=ti.i32, ndim=2),  # (Q, raster.QUEUE_COLS) i32 work: the large images queued in parts
    counters: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (raster.COUNTERS,) i32 work: clusters listed, images queued
    tiles: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (B, raster.tile_entries(W, H)) f32 work: tile pyramids
    vis: ti.types.ndarray(dtype=ti.i64, ndim=4),  # (2, B, H, W) i64 closest hit, nearest pane (work)
):
    """Step 3, the scene packed (CUDA's third kernel): :func:`primitives_kernel` reading the scene's packs."""
    v = ti.static(scene_views(scene_f32, scene_i32))
    _primitives_step(table, pose0, one, images, v.pf, v.pi, v.tris, consts, v.cluster_prims, v.is_occluder, listed,
                     queue, counters, tiles, vis)


@ti.func
def _shade_step(table: ti.template(), pose0, one, images, nodes: ti.template(), pf: ti.template(),
                pi: ti.template(), tris: ti.template(), shade: ti.template(), texels: ti.template(),
                tex_info: ti.template(), tex_lut: ti.template(), lights: ti.template(), lit, n_always,
                always: ti.template(), light_grid: ti.template(), grid_xform: ti.template(),
                light_of_slot: ti.template(), lamp_maps: ti.template(), sun_map: ti.template(), baked: ti.template(),
                baked_info: ti.template(), consts: ti.template(), vis: ti.template(), rgb: ti.template(),
                depth: ti.template(), cls: ti.template(), inst: ti.template(), shadow_rays: ti.template()):
    """Step 4 of :func:`sensors_kernel`: each pixel of the B frames reads its closest hit (and nearest pane) from
    ``vis``, which the steps before filled, resets it to :data:`raster.EMPTY`, and is shaded into ``rgb``,
    ``depth``, ``cls`` and ``inst``. ``shadow_rays`` (compile-time): whether the code of shadow rays is compiled
    in (:func:`~benchbot_sim_taichi.render.kernels._direct`); without it the kernel takes far fewer registers.
    """
    B = vis.shape[1]
    H = vis.shape[2]
    W = vis.shape[3]
    # The pixels: each reads its closest hit and is shaded (a thread's share on the CPU: every T-th image row).
    rows = B * images * H
    for it in range(_spread_range(rows) * W):
        row = _spread(it // W, rows)
        if row >= rows:
            continue
        b = row // H
        v = row % H
        u = it % W
        c = _camera(table, pose0, one, b, consts)
        params = ti.Vector([consts[FRAME_PARAMS + m] for m in ti.static(range(PARAMS_LEN))])
        o, d = _ray(c, ti.cast(u, ti.f32), ti.cast(v, ti.f32))
        best, k = raster.unkey(vis[0, b, v, u])
        pane_t, pane_k = raster.unkey(vis[1, b, v, u])
        vis[0, b, v, u] = ti.i64(raster.EMPTY)
        vis[1, b, v, u] = ti.i64(raster.EMPTY)
        nb = ti.Vector([0.0, 0.0, 0.0])
        if ti.static(raster.split()["surface_once"]):
            if k >= 0 and pi[k, 0] != 3:  # not a plain triangle (_surface computes a triangle's normal itself)
                nb = _closest_normal(o, d, _safe_inv(d), best, k, pf, pi, tris)
        else:
            nb = _closest_normal(o, d, _safe_inv(d), best, k, pf, pi, tris)
        key = (v * W + u) * 65536 + ti.cast(params[P_SEED], ti.i32)
        hit, t, n, ns, albedo, c_id, i_id, p, prim, pane, tri_pos = _surface(
            o, d, 1.0 / consts[FRAME_INTRINSICS], best, k, nb, pane_t, pane_k, pf, pi, tris, shade, texels, tex_info, tex_lut,
            consts, PANES_TRACKED, ti.static(raster.split()["surface_once"]))
        col = ti.Vector([0.0, 0.0, 0.0])
        if hit == 1:
            a = FRAME_WORLD + WORLD_AMBIENT
            radiance = ti.Vector([consts[a], consts[a + 1], consts[a + 2]]) * (0.8 + 0.2 * ns[2])
            if lit == 1:
                if prim >= 0 and baked_info[prim, 1] > 0:  # a triangle's light, baked once per scene
                    radiance += lightmap.baked_direct(baked, baked_info, prim, tri_pos)
                else:
                    if ti.static(raster.split()["surface_once"]):
                        if prim >= 0 and pi[prim, 0] == 3:  # a triangle's shadow rays leave its shading surface
                            p = _shadow_origin(tris, shade, prim, 1.0 - tri_pos[0] - tri_pos[1], tri_pos[0],
                                               tri_pos[1], tri_pos[2], p)
                    radiance += _direct(p, n, ns, key, params, lights, n_always, always, light_grid, grid_xform,
                                        light_of_slot, nodes, pf, pi, tris, lamp_maps, sun_map, shadow_rays)
            col = albedo * radiance
        if pane >= 0:  # seen through the nearest pane (both faces), which reflects the ambient sky
            col = _through_pane(col, d, pane, tris, consts)
        if hit == 1:
            if consts[FRAME_VIGNETTING] > 0.0:  # the camera model's vignetting (camera_model.py, step 1)
                f = FRAME_INTRINSICS  # fx, fy, cx, cy
                xn = (ti.cast(u, ti.f32) - consts[f + 2]) / consts[f]
                yn = (ti.cast(v, ti.f32) - consts[f + 3]) / consts[f + 1]
                cos2 = 1.0 / (1.0 + xn * xn + yn * yn)
                col *= 1.0 - consts[FRAME_VIGNETTING] * (1.0 - cos2 * cos2)
            col *= consts[FRAME_RADIANCE_SCALE]  # radiance / radiance_max: exposure and tone curve are in the table
            for m in ti.static(range(3)):
                x = ti.min(ti.max(col[m], 0.0), 1.0)
                level = consts[FRAME_TONE_TABLE + ti.cast(ti.sqrt(x) * (GAMMA_STEPS - 1) + 0.5, ti.i32)]
                rgb[b, v, u, m] = ti.cast(level, ti.u8)
            depth[b, v, u] = t
        else:
            for m in ti.static(range(3)):
                rgb[b, v, u, m] = ti.cast(0, ti.u8)
            depth[b, v, u] = 0.0
        cls[b, v, u] = c_id
        inst[b, v, u] = i_id


def _shading_kernel(name: str, shadow_rays: bool, packed: bool, doc: str):
    """A Taichi kernel named ``name`` that runs :func:`_shade_step` with ``shadow_rays`` (compile-time), reading the
    scene's arrays from their packs (``packed``: CUDA, :mod:`~benchbot_sim_taichi.render.packed_scene`) or each its own
    argument (the CPU)."""

    if packed:
        def kernel(
            table: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (B, POSE_LEN) f32 frame b's pose in row b (if one == 0)
            pose0: ti.types.vector(POSE_LEN, ti.f32),
            one: ti.i32,
            images: ti.i32,
            scene_f32: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (F,) f32 SceneArrays.scene_f32
            scene_i32: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (J,) i32 SceneArrays.scene_i32
            lit: ti.i32,
            n_always: ti.i32,
            consts: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (FRAME_TONE_TABLE + GAMMA_STEPS,) f32 frame constants
            vis: ti.types.ndarray(dtype=ti.i64, ndim=4),  # (2, B, H, W) i64 closest hit, nearest pane (work)
            rgb: ti.types.ndarray(dtype=ti.u8, ndim=4),  # (B, H, W, 3) u8 out: sRGB
            depth: ti.types.ndarray(dtype=ti.f32, ndim=3),  # (B, H, W) f32 out: z-depth (m; 0: no hit)
            cls: ti.types.ndarray(dtype=ti.i32, ndim=3),  # (B, H, W) i32 out: class ids
            inst: ti.types.ndarray(dtype=ti.i32, ndim=3),  # (B, H, W) i32 out: class·1000 + instance ids
        ):
            v = ti.static(scene_views(scene_f32, scene_i32))
            _shade_step(table, pose0, one, images, v.nodes, v.pf, v.pi, v.tris, v.shade, v.texels, v.tex_info,
                        v.tex_lut, v.lights, lit, n_always, v.always, v.light_grid, v.grid_xform, v.light_of_slot,
                        v.lamp_maps, v.sun_map, v.baked, v.baked_info, consts, vis, rgb, depth, cls, inst,
                        shadow_rays)

    else:
        def kernel(
            table: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (B, POSE_LEN) f32 frame b's pose in row b (if one == 0)
            pose0: ti.types.vector(POSE_LEN, ti.f32),
            one: ti.i32,
            images: ti.i32,
            nodes: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (I, 16) f32 SceneArrays.nodes
            pf: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (P, 11) f32 SceneArrays.pf
            pi: ti.types.ndarray(dtype=ti.i32, ndim=2),  # (P, 4) i32 SceneArrays.pi
            tris: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (P, 9) f32 SceneArrays.tris
            shade: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (P, 17) f32 SceneArrays.shade
            texels: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (N,) i32 SceneArrays.texels
            tex_info: ti.types.ndarray(dtype=ti.i32, ndim=2),  # (X, 4) i32 SceneArrays.tex_info
            tex_lut: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (256,) f32 SceneArrays.tex_lut
            lights: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (L, 17) f32 SceneArrays.lights
            lit: ti.i32,
            n_always: ti.i32,
            always: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (A,) i32 SceneArrays.always
            light_grid: ti.types.ndarray(dtype=ti.i32, ndim=3),  # (NY, NX, W) i32 SceneArrays.light_grid
            grid_xform: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (4,) f32 SceneArrays.grid_xform
            light_of_slot: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (S,) i32 SceneArrays.light_of_slot
            lamp_maps: ti.types.ndarray(dtype=ti.f32, ndim=3),  # (6·S, R, R) f32 SceneArrays.lamp_maps
            sun_map: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (R, R) f32 SceneArrays.sun_map
            baked: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (Q,) i32 SceneArrays.baked
            baked_info: ti.types.ndarray(dtype=ti.i32, ndim=2),  # (P, 2) i32 SceneArrays.baked_info
            consts: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (FRAME_TONE_TABLE + GAMMA_STEPS,) f32 frame constants
            vis: ti.types.ndarray(dtype=ti.i64, ndim=4),  # (2, B, H, W) i64 closest hit, nearest pane (work)
            rgb: ti.types.ndarray(dtype=ti.u8, ndim=4),  # (B, H, W, 3) u8 out: sRGB
            depth: ti.types.ndarray(dtype=ti.f32, ndim=3),  # (B, H, W) f32 out: z-depth (m; 0: no hit)
            cls: ti.types.ndarray(dtype=ti.i32, ndim=3),  # (B, H, W) i32 out: class ids
            inst: ti.types.ndarray(dtype=ti.i32, ndim=3),  # (B, H, W) i32 out: class·1000 + instance ids
        ):
            _shade_step(table, pose0, one, images, nodes, pf, pi, tris, shade, texels, tex_info, tex_lut, lights, lit,
                        n_always, always, light_grid, grid_xform, light_of_slot, lamp_maps, sun_map, baked, baked_info,
                        consts, vis, rgb, depth, cls, inst, shadow_rays)

    kernel.__name__ = kernel.__qualname__ = name
    kernel.__doc__ = doc + " Parameters: those of :func:`sensors_kernel` that it uses."
    return ti.kernel(kernel)


#: Step 4 of :func:`sensors_kernel` (:func:`_shade_step`) with shadow rays: for any lights.
shade_kernel = _shading_kernel("shade_kernel", True, False,
                               "Step 4 of :func:`sensors_kernel` with shadow rays: any lights.")
#: Step 4 without the code of shadow rays, for frames whose every light takes its shadows from a shadow map (one
#: shadow sample; :func:`sensors_kernels`): fewer registers, so more threads at once on a GPU.
shade_maps_kernel = _shading_kernel("shade_maps_kernel", False, False,
                                    "Step 4 of :func:`sensors_kernel` without the code of shadow rays: every light "
                                    "has a shadow map.")
#: :func:`shade_kernel` and :func:`shade_maps_kernel` reading the scene from its packs (CUDA's: fewer arguments to
#: launch, :mod:`~benchbot_sim_taichi.render.packed_scene`).
shade_packed_kernel = _shading_kernel("shade_packed_kernel", True, True,
                                      "Step 4 of :func:`sensors_kernel` with shadow rays, the scene packed.")
shade_maps_packed_kernel = _shading_kernel("shade_maps_packed_kernel", False, True,
                                           "Step 4 of :func:`sensors_kernel` without the code of shadow rays, the "
                                           "scene packed.")


def sensors_kernel(arch: str, values: dict, timer=None, shadow_rays: bool = True) -> None:
    """The kernels of :func:`sensors_kernels` for ``arch`` (``'cpu'`` or ``'cuda'``), launched one after the other for
    B sensor frames in the ``map`` frame: fast-mode images (when ``images`` is 1) into ``rgb`` (B, H, W, 3) uint8, ``depth`` (B, H, W)
    float32 z-depth metres, ``cls``/``inst`` (B, H, W) int32, and ``n_beams`` laser beams per frame into ``ranges`` (B, ≥ n_beams) float32 metres, beam j at map-frame angle ``beams[j]`` (rad) +
    the lidar's yaw; the lights (``lit`` 1; 0: ambient light only) as :func:`~benchbot_sim_taichi.render.kernels._direct`
    takes them (the renderer's ``_light_grid``). Frame b's pose (``renderer.sensor_pose``) is ``pose0`` (by value:
    no upload) when ``one`` is 1, else row b of ``table`` (B, POSE_LEN). ``consts`` is ``renderer.frame_constants``;
    the scene arrays are ``renderer.pack_scene``'s (``cluster_box`` (C, 6) and ``cluster_prims`` (C, 2): its
    clusters); ``lamp_maps`` (6·S, R, R) the lamps' cube shadow maps
    (:func:`~benchbot_sim_taichi.render.kernels.lamp_map_kernel`; used by lamps whose row has a slot ≥ 0), ``sun_map`` (R,
    R) the sun's, ``baked`` and ``baked_info`` the triangles' baked direct light
    (:mod:`benchbot_sim_taichi.render.lightmap`; a triangle with 0 divisions sums its lights per pixel), ``always``,
    ``light_grid``, ``grid_xform`` and ``light_of_slot`` the light lists (``n_always`` of ``always`` taken). CUDA's
    kernels take all of these packed in ``scene_f32`` and ``scene_i32`` instead
    (:func:`~benchbot_sim_taichi.render.packed_scene.pack`: fewer arguments to launch) and read them through
    :func:`~benchbot_sim_taichi.render.packed_scene.scene_views` under the same names. Work space:
    ``listed`` (≥ B·C,) int32, ``queue`` (Q, raster.QUEUE_COLS) int32, ``counters`` (raster.COUNTERS,) int32, and
    the visibility buffer ``vis`` (2, B, H, W) int64 (layer 0: the closest primitive, 1: the nearest pane), which
    must hold :data:`raster.EMPTY` on entry and does again on return.

    Args:
        arch: the Taichi arch the renderer runs on.
        values: every parameter of the kernels (:func:`launch_parameters`) by name → its value (NumPy arrays or
            Taichi ndarrays, scalars, and ``pose0`` a (POSE_LEN,) float32 array); each kernel takes those it
            declares.
        timer: ``None``, or a callable taking a kernel's name and returning a context manager that each launch runs
            inside (``benchmarks/sensors_kernels.py`` times the kernels one by one with it).
        shadow_rays: False shades with :func:`shade_maps_kernel` (see :func:`sensors_kernels`).
    """
    for kernel in sensors_kernels(arch, shadow_rays):
        args = [values[name] for name in parameters(kernel)]
        if timer is None:
            kernel(*args)
        else:
            with timer(kernel.__name__):
                kernel(*args)


def sensors_kernels(arch: str, shadow_rays: bool = True) -> tuple:
    """The kernels that make up the all-sensors work on ``arch``, in the order they run; the last shades the pixels:
    :func:`shade_kernel`, or with ``shadow_rays`` False :func:`shade_maps_kernel`, which has no code of shadow rays:
    only for frames whose every light has a shadow map and one shadow sample (the renderer's choice,
    ``Renderer.shadow_rays``), where it is faster (fewer registers, so more threads at once on a GPU). One kernel
    per step on either arch: Taichi's compile time grows faster than a kernel's length. On the 2-core CPU the four
    compile in 99 s (``benchmarks/compile_time.py``), steps 1 to 3 as one kernel took 296 s, all four steps as one had
    not finished after 14 minutes. On CUDA steps 1 to 3 were one kernel until 2026-11-26 (one launch for a one-camera
    frame instead of three), whose compile took 62.5 s of a first start; as three kernels they compile in 14.2 + 1.6
    + 10.1 s, and loading miniroom:1 into empty caches fell from 90.7 to 53.0 s, for two more launches a frame: one
    camera 4,938 fps against 5,063 (the host's launch work 208 µs a frame against 166, the GPU's 199 against 195),
    the vector environment's 256 and 512 robots a launch unchanged (one H200; ``benchmarks/cold_start.py``,
    ``benchmarks/one_camera.py``, ``benchmarks/vector_env.py``). CUDA's kernels (:func:`occluders_packed_kernel`,
    :func:`clusters_packed_kernel`, :func:`primitives_packed_kernel`, :func:`shade_packed_kernel` or
    :func:`shade_maps_packed_kernel`) take the scene's arrays packed, :mod:`~benchbot_sim_taichi.render.packed_scene`
    (a one-camera frame is short there, and Taichi's work for each ndarray argument is much of its launch), and
    steps 1 to 3 loop over constant lanes there, :func:`_lanes`, which saves a launch for each loop. The CPU's kernels
    take the scene's arrays one by one: a launch's cost is nothing there beside a frame's tens of milliseconds, and
    the packs would be a second copy of the scene in its memory."""
    if arch == "cuda":
        return (occluders_packed_kernel, clusters_packed_kernel, primitives_packed_kernel,
                shade_packed_kernel if shadow_rays else shade_maps_packed_kernel)
    return (occluders_kernel, clusters_kernel, primitives_kernel, shade_kernel if shadow_rays else shade_maps_kernel)


def launch_parameters(arch: str, shadow_rays: bool = True) -> tuple[str, ...]:
    """The parameters of the kernels of :func:`sensors_kernels` (``arch``, ``shadow_rays``) by name, each once, in
    the order first met: the values a launch (:func:`sensors_kernel`, :func:`sensors_graph`) takes (read on every
    launch; cached). CUDA's kernels take the scene's packs ``scene_f32`` and ``scene_i32``, the CPU's its arrays
    one by one."""
    return _parameters_of(sensors_kernels(arch, shadow_rays))


@functools.cache
def _parameters_of(kernels: tuple) -> tuple[str, ...]:
    return tuple(dict.fromkeys(name for kernel in kernels for name in parameters(kernel)))


def graph_arg(name: str, annotation) -> "ti.graph.Arg":
    """The ``ti.graph.Arg`` of a kernel parameter of annotation ``annotation`` (as the kernel declares it: an
    ndarray type, a vector type or a scalar dtype)."""
    if isinstance(annotation, ti.types.ndarray_type.NdarrayType):
        return ti.graph.Arg(ti.graph.ArgKind.NDARRAY, name, dtype=annotation.dtype, ndim=annotation.ndim)
    if isinstance(annotation, ti.lang.matrix.MatrixType):
        return ti.graph.Arg(ti.graph.ArgKind.MATRIX, name, dtype=annotation)
    return ti.graph.Arg(ti.graph.ArgKind.SCALAR, name, dtype=annotation)


def _type_key(annotation) -> tuple:
    """What makes two kernel parameters' annotations the same type (the objects themselves differ)."""
    if isinstance(annotation, ti.types.ndarray_type.NdarrayType):
        return "ndarray", str(annotation.dtype), annotation.ndim
    if isinstance(annotation, ti.lang.matrix.MatrixType):
        return "matrix", annotation.n, annotation.m, str(annotation.dtype)
    return "scalar", str(annotation)


_SENSORS_GRAPHS: dict = {}


def sensors_graph(arch: str, shadow_rays: bool = True):
    """:func:`sensors_kernels` of ``arch`` (and ``shadow_rays``) as one compiled Taichi compute graph (``ti.graph``),
    built once per process, arch and ``shadow_rays``. Running the graph sets the arguments in C++ and costs a
    fraction of a Python kernel call's per-argument work, which is most of the time of a one-camera frame on a GPU
    (the CPU runs it too). Its arguments (``graph.run({name: value})``) are the kernels' parameters by name
    (:func:`launch_parameters`), each of the type the kernels declare; ndarray arguments must be Taichi ndarrays
    (device buffers).

    Raises:
        TypeError: two of the kernels declare a parameter of the same name with different types.
    """
    if (arch, shadow_rays) not in _SENSORS_GRAPHS:
        kernels = sensors_kernels(arch, shadow_rays)
        declared = {}
        for kernel in kernels:
            for name, annotation in annotations(kernel).items():
                if _type_key(declared.setdefault(name, annotation)) != _type_key(annotation):
                    raise TypeError(f"sensors kernels: {name} is {_type_key(declared[name])} in one, "
                                    f"{_type_key(annotation)} in {kernel.__name__}")
        symbols = {name: graph_arg(name, annotation) for name, annotation in declared.items()}
        builder = ti.graph.GraphBuilder()
        for kernel in kernels:
            builder.dispatch(kernel, *(symbols[name] for name in parameters(kernel)))
        _SENSORS_GRAPHS[arch, shadow_rays] = builder.compile()
        # Compiling made placeholder ndarrays that are left in reference cycles; collect them now, on Taichi's
        # thread: if the collector found them later on another thread, freeing them would abort a CUDA process.
        gc.collect()
    return _SENSORS_GRAPHS[arch, shadow_rays]


def reset_graph() -> None:
    """Forget the compiled graphs (after ``ti.reset``, or to compile them again)."""
    _SENSORS_GRAPHS.clear()
