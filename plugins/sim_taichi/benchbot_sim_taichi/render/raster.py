"""Camera rays' closest hits by rasterisation: a visibility buffer that the all-sensors kernel
(:func:`benchbot_sim_taichi.render.kernels.sensors_kernel`) fills before it shades its pixels.

A camera's primary rays all leave one point, the camera's centre, through the pixel centres; their closest hits can
therefore be found object by object instead of ray by ray. For each primitive the kernel finds the pixels whose rays
may meet it (the primitive's image, clipped to the image and to rays' minimum distance ``T_EPS``), decides for each
such ray whether it meets the primitive and at which distance t, and keeps the nearest per pixel with one atomic
minimum on a 64-bit key ``(t's float bits << 32) | primitive`` (a positive float's bits order like the float, so the
smallest key is the nearest primitive; a tie goes to the lower index). Every primitive is tested against every ray
that may meet it, so the result is the closest hit among all primitives: what the BVH traversal of
:func:`~benchbot_sim_taichi.render.kernels._trace` returns for the same rays, found without a per-ray traversal.

- **Triangles** (and window panes) are tested in the camera's frame with homogeneous edge functions (Olano & Greer,
  "Triangle scan conversion using 2D homogeneous coordinates", 1997): with the vertices q₀, q₁, q₂ relative to the
  camera centre and the pixel's ray direction d = ((u − cx)/fx, (v − cy)/fy, 1), the ray meets the triangle at a
  positive distance iff the three edge functions s·(qᵢ × qⱼ)·d are ≥ 0 (s the sign of q₀·((q₁ − q₀) × (q₂ − q₀))),
  and then at the z-depth ``t = |q₀·N| / |N·d|`` with ``N = (q₁ − q₀) × (q₂ − q₀)``. Each edge function is linear
  in u along a row, so a row's pixels inside the triangle are an interval computed exactly (plus
  :data:`SPAN_MARGIN`), and each of its pixels is confirmed by the three functions themselves.
- **Boxes, ellipsoids, cylinders** are tested with the traversal's own primitive test
  (:func:`~benchbot_sim_taichi.render.kernels._hit_prim`) on every pixel of their bounding box's image.
- **Window panes** go to the buffer's second layer: fast mode's camera rays do not stop at panes but note the nearest one in
  front of their surface (``kernels.PANES_TRACKED``).

Work is spread in three parallel loops of the kernel: the clusters of the BVH (:func:`~benchbot_sim_taichi.render.bvh.clusters`,
at most :data:`CLUSTER_PRIMS` primitives each) whose boxes meet a camera's view are listed; each of their primitives
is set up, and rasterised at once when its image's bounding box is small; a larger one is queued in bands of rows
that the third loop rasterises, so that a wall that fills the image is shared among many threads (when the queue is
full, the primitive's own thread does the work). How finely the work is split depends on the arch (:data:`SPLIT`). The pixel loop that
follows reads each pixel's keys and resets them to :data:`EMPTY` for the next frame.

Keys are deterministic (an atomic minimum does not depend on the order of the writes); the distances agree with
:func:`~benchbot_sim_taichi.render.kernels._hit_tri`'s world-frame Möller–Trumbore test to float32 rounding (a few parts in
a million), and where two surfaces are that close the nearer by either test may win.
"""

import contextlib
import sys

with contextlib.redirect_stdout(sys.stderr):
    import taichi as ti

from benchbot_sim_taichi.render.kernels import GLASS, T_EPS, _hit_prim, _ray, _safe_inv, _v3  # noqa: E402
from benchbot_sim_taichi.render.layouts import CAM_CX, CAM_CY, CAM_FX, CAM_FY, CAM_ORIGIN, CAM_R  # noqa: E402

#: The key of a pixel that no primitive covers (the largest int64).
EMPTY = 0x7FFF_FFFF_FFFF_FFFF
#: Most primitives in a cluster of the BVH (culled against each view as one box).
CLUSTER_PRIMS = 64
#: How the work is split, by arch. A primitive whose image's bounding box holds at most ``direct_pixels`` pixels is
#: rasterised by its own thread; a larger one is queued: on the CPU in bands of ``band_rows`` rows, each done by one
#: thread along the rows' exact spans; on a GPU in chunks of ``chunk_pixels`` consecutive pixels of its bounding box
#: (row-major), each done by ``lanes`` threads that take every ``lanes``-th pixel (32 threads of a warp on
#: neighbouring pixels: their memory accesses coalesce, and no thread walks a long row alone). ``queue_items``: room
#: in the queue for each camera of a launch (items beyond it are done by their primitive's thread).
#: ``surface_once``: the shading step computes a triangle's geometric normal once (in ``kernels._surface``, from the
#: edges it needs anyway) and its shadow-ray origin only where it casts shadow rays (``kernels._shadow_origin``).
#: That is the same image and on the 2-core CPU a faster one (house:1's shading 42.9 → 35.4 ms a frame,
#: ``benchmarks/sensors_kernels.py``), but on an H200 a slower one (43.6 → 57.2 µs a frame at 256 per launch),
#: so CUDA keeps computing the normal first and the origin with the rest of the surface.
SPLIT = {
    "cpu": {"direct_pixels": 64, "band_rows": 8, "lanes": 1, "chunk_pixels": 0, "queue_items": 65536,
            "surface_once": True},
    "cuda": {"direct_pixels": 16, "band_rows": 0, "lanes": 32, "chunk_pixels": 1024, "queue_items": 65536,
             "surface_once": False},
}


def split() -> dict:
    """:data:`SPLIT`'s entry for the arch Taichi runs on (read when a kernel is compiled)."""
    return SPLIT["cuda" if ti.lang.impl.current_cfg().arch == ti.cuda else "cpu"]


#: Margin (pixels) added to each side of a row's interval inside a triangle, and to bounding boxes: the exact
#: test of each pixel decides; the margin only keeps rounding from dropping a pixel on the border.
SPAN_MARGIN = 0.05
#: The tile pyramid of each camera's closest hits so far (after the occluders), against which clusters and
#: primitives are culled: TILE_LEVELS levels of tiles of TILE_PX · 4^level pixels a side. Level 0 is built from the
#: row segments (TILE_PX pixels of a row, one item each) that follow the pyramid in the same array: a loop of many
#: short items, where one item a tile (TILE_PX² pixels) left most of a GPU idle (one H200, 64 cameras: 4.3 µs a
#: frame at 29 % occupancy, ``ncu``).
TILE_PX = 16
TILE_LEVELS = 3
#: A triangle of at least this area (m²) is an occluder: rasterised first, before the rest are culled against it.
OCCLUDER_AREA_M2 = 0.1
#: Columns of a queued item: primitive, camera · H + first row of its image, first column | last column << 16, last
#: row | the item's number (band or chunk) << 16.
QUEUE_COLS = 4
#: Entries of the counters array: [clusters listed, items queued].
COUNTERS = 2


@ti.func
def key_of(t, k):
    """The 64-bit visibility key of a hit at distance t > 0 (float32) of primitive k."""
    return (ti.cast(ti.bit_cast(t, ti.i32), ti.i64) << 32) | ti.cast(k, ti.i64)


@ti.func
def unkey(key):
    """(t, k) of a key; (1e30, −1) for :data:`EMPTY`."""
    t = 1e30
    k = -1
    if key != ti.i64(EMPTY):
        t = ti.bit_cast(ti.cast(key >> 32, ti.i32), ti.f32)
        k = ti.cast(key & ti.i64(0xFFFFFFFF), ti.i32)
    return t, k


@ti.func
def _in_camera(c, p):
    """Point p (map frame) in the camera's optical frame (c: the kernels' camera row, R row-major then origin)."""
    o = CAM_ORIGIN
    w = p - ti.Vector([c[o], c[o + 1], c[o + 2]])
    r = CAM_R  # row-major R (optical into map): its transpose takes map to optical
    return ti.Vector([c[r + 0] * w[0] + c[r + 3] * w[1] + c[r + 6] * w[2],
                      c[r + 1] * w[0] + c[r + 4] * w[1] + c[r + 7] * w[2],
                      c[r + 2] * w[0] + c[r + 5] * w[1] + c[r + 8] * w[2]])


@ti.func
def cluster_in_view(c, lo, hi, W, H):
    """Whether the box lo..hi (map frame) may meet the view of camera c (W × H pixels): False when its eight corners
    all lie beyond one side of the view's frustum (grown by a pixel) or before ``T_EPS``."""
    fx = c[CAM_FX]
    fy = c[CAM_FY]
    cx = c[CAM_CX]
    cy = c[CAM_CY]
    # outward planes through the centre: u < −1, u > W, v < −1, v > H; then z < T_EPS
    out = ti.Vector([1, 1, 1, 1, 1])
    for m in ti.static(range(8)):
        q = _in_camera(c, ti.Vector([hi[0] if m & 1 else lo[0], hi[1] if m & 2 else lo[1],
                                     hi[2] if m & 4 else lo[2]]))
        if fx * q[0] + (cx + 1.0) * q[2] >= 0.0:
            out[0] = 0
        if -fx * q[0] + (W - cx) * q[2] >= 0.0:
            out[1] = 0
        if fy * q[1] + (cy + 1.0) * q[2] >= 0.0:
            out[2] = 0
        if -fy * q[1] + (H - cy) * q[2] >= 0.0:
            out[3] = 0
        if q[2] >= T_EPS:
            out[4] = 0
    return out.sum() == 0


@ti.func
def _grow(box, c, a, b):
    """``box`` (umin, umax, vmin, vmax) grown by the image of the segment a..b's part at z ≥ T_EPS (camera frame)."""
    r = box
    for e in ti.static(range(2)):
        p = a if e == 0 else b
        if p[2] >= T_EPS:
            pu = c[CAM_CX] + c[CAM_FX] * p[0] / p[2]
            pv = c[CAM_CY] + c[CAM_FY] * p[1] / p[2]
            r = ti.Vector([ti.min(r[0], pu), ti.max(r[1], pu), ti.min(r[2], pv), ti.max(r[3], pv)])
    if (a[2] - T_EPS) * (b[2] - T_EPS) < 0.0:  # it crosses z = T_EPS: where
        x = a + (b - a) * ((T_EPS - a[2]) / (b[2] - a[2]))
        pu = c[CAM_CX] + c[CAM_FX] * x[0] / T_EPS
        pv = c[CAM_CY] + c[CAM_FY] * x[1] / T_EPS
        r = ti.Vector([ti.min(r[0], pu), ti.max(r[1], pu), ti.min(r[2], pv), ti.max(r[3], pv)])
    return r


@ti.func
def _pixels(box, W, H):
    """The pixel columns and rows (u0, u1, v0, v1) whose centres lie in ``box`` (grown by SPAN_MARGIN), in the
    image; (0, −1, 0, −1) when there is none (an empty box — nothing in front of the camera — or NaN). Decided in
    floating point before any conversion, which would overflow for the empty box's ±1e30."""
    fu0 = ti.max(ti.ceil(box[0] - SPAN_MARGIN), 0.0)
    fu1 = ti.min(ti.floor(box[1] + SPAN_MARGIN), W - 1.0)
    fv0 = ti.max(ti.ceil(box[2] - SPAN_MARGIN), 0.0)
    fv1 = ti.min(ti.floor(box[3] + SPAN_MARGIN), H - 1.0)
    u0 = 0
    u1 = -1
    v0 = 0
    v1 = -1
    if box[0] <= box[1] and box[2] <= box[3] and fu0 <= fu1 and fv0 <= fv1:  # (False for NaN)
        u0 = ti.cast(fu0, ti.i32)
        u1 = ti.cast(fu1, ti.i32)
        v0 = ti.cast(fv0, ti.i32)
        v1 = ti.cast(fv1, ti.i32)
    return u0, u1, v0, v1


@ti.func
def _aabb_image(c, lo, hi, W, H):
    """(u0, u1, v0, v1, zmin): the pixels holding the image of the box lo..hi (map frame) in camera c (its twelve
    edges clipped at z = T_EPS), and the least z-depth of its corners (at least T_EPS)."""
    box = ti.Vector([1e30, -1e30, 1e30, -1e30])
    zmin = 1e30
    for e in range(12):
        ax = e // 4
        a = lo
        b = lo
        for q in ti.static(range(3)):  # the edge along axis ax at corner (e & 1, e & 2) of the other two
            r = (q - ax + 3) % 3  # 0: the edge's axis, 1 and 2: the others
            if r == 0:
                b[q] = hi[q]
            elif (r == 1 and (e & 1) != 0) or (r == 2 and (e & 2) != 0):
                a[q] = hi[q]
                b[q] = hi[q]
        qa = _in_camera(c, a)
        qb = _in_camera(c, b)
        zmin = ti.min(zmin, ti.min(qa[2], qb[2]))
        box = _grow(box, c, qa, qb)
    u0, u1, v0, v1 = _pixels(box, W, H)
    return u0, u1, v0, v1, ti.max(zmin, T_EPS)


@ti.func
def _image_box(c, k, pf: ti.template(), pi: ti.template(), tris: ti.template(), W, H):
    """(u0, u1, v0, v1, zmin): the pixel box that holds primitive k's image in camera c (empty: u0 > u1 or
    v0 > v1), and the least z-depth of its points (at least T_EPS)."""
    u0 = 0
    u1 = -1
    v0 = 0
    v1 = -1
    zmin = T_EPS
    if pi[k, 0] >= 3:
        box = ti.Vector([1e30, -1e30, 1e30, -1e30])
        q0 = _in_camera(c, _v3(tris, k, 0))
        q1 = _in_camera(c, _v3(tris, k, 3))
        q2 = _in_camera(c, _v3(tris, k, 6))
        box = _grow(box, c, q0, q1)
        box = _grow(box, c, q1, q2)
        box = _grow(box, c, q2, q0)
        u0, u1, v0, v1 = _pixels(box, W, H)
        zmin = ti.max(ti.min(q0[2], ti.min(q1[2], q2[2])), T_EPS)
    else:
        u0, u1, v0, v1, zmin = _aabb_image(c, _v3(pf, k, 0), _v3(pf, k, 3), W, H)
    return u0, u1, v0, v1, zmin


def tile_entries(W: int, H: int) -> int:
    """Entries of one camera's tile pyramid and its row segments for W × H images (what :func:`tile_levels` counts,
    plus H · ⌈W / TILE_PX⌉; on the host)."""
    pyramid = sum(-(-W // (TILE_PX * 4**lv)) * -(-H // (TILE_PX * 4**lv)) for lv in range(TILE_LEVELS))
    return pyramid + H * -(-W // TILE_PX)


@ti.func
def tile_levels(W, H):
    """Per level of the tile pyramid (pixels per tile side TILE_PX · 4^level): (tiles across, tiles down, first
    entry), as three Vectors of TILE_LEVELS, and the entries of one camera's pyramid."""
    across = ti.Vector([0] * TILE_LEVELS)
    down = ti.Vector([0] * TILE_LEVELS)
    first = ti.Vector([0] * TILE_LEVELS)
    total = 0
    for lv in ti.static(range(TILE_LEVELS)):
        side = TILE_PX * (4 ** lv)
        across[lv] = (W + side - 1) // side
        down[lv] = (H + side - 1) // side
        first[lv] = total
        total += across[lv] * down[lv]
    return across, down, first, total


@ti.func
def segment_depth(i, vis: ti.template(), tiles: ti.template()):
    """Item i = camera · (H · tiles across) + row · (tiles across) + tile column of the row segments' loop: the
    largest z-depth of the closest hits so far (layer 0 of ``vis``; 1e30 where a pixel has none) in the row's
    TILE_PX pixels under that tile, into the segments after the pyramid in ``tiles``."""
    H = vis.shape[2]
    W = vis.shape[3]
    across, _down, _first, total = tile_levels(W, H)
    b = i // (H * across[0])
    r = i % (H * across[0])
    y = r // across[0]
    tx = r % across[0]
    deepest = 0.0
    for x in range(tx * TILE_PX, ti.min(tx * TILE_PX + TILE_PX, W)):
        z, k = unkey(vis[0, b, y, x])
        deepest = ti.max(deepest, z if k >= 0 else 1e30)
    tiles[b, total + r] = deepest


@ti.func
def tile_depth(i, level, vis: ti.template(), tiles: ti.template()):
    """Item i = camera · (tiles of ``level``) + tile of the pyramid's loop for ``level``: the largest z-depth in the
    tile of the closest hits so far (layer 0 of ``vis``; 1e30 where a pixel has none): from the tile's TILE_PX row
    segments (:func:`segment_depth`, which must have run) for level 0, from the 4 × 4 tiles below for the others."""
    H = vis.shape[2]
    W = vis.shape[3]
    across, down, first, total = tile_levels(W, H)
    n = across[level] * down[level]
    b = i // n
    t = i % n
    tx = t % across[level]
    ty = t // across[level]
    deepest = 0.0
    if level == 0:
        for y in range(ty * TILE_PX, ti.min(ty * TILE_PX + TILE_PX, H)):
            deepest = ti.max(deepest, tiles[b, total + y * across[0] + tx])
    else:
        for y, x in ti.ndrange((ty * 4, ti.min(ty * 4 + 4, down[level - 1])),
                               (tx * 4, ti.min(tx * 4 + 4, across[level - 1]))):
            deepest = ti.max(deepest, tiles[b, first[level - 1] + y * across[level - 1] + x])
    tiles[b, first[level] + t] = deepest


@ti.func
def occluded(b, u0, u1, v0, v1, zmin, tiles: ti.template(), W, H):
    """Whether every pixel of u0..u1 × v0..v1 of camera b already has a hit nearer than ``zmin`` (z-depth): every
    tile of the pyramid's finest level that covers at most 4 × 4 tiles of the box holds a largest depth below it."""
    across, down, first, _total = tile_levels(W, H)
    lv = 0
    side = TILE_PX
    while lv + 1 < TILE_LEVELS and (u1 // side - u0 // side > 3 or v1 // side - v0 // side > 3):
        lv += 1
        side *= 4
    hidden = True
    for y, x in ti.ndrange((v0 // side, v1 // side + 1), (u0 // side, u1 // side + 1)):
        if tiles[b, first[lv] + y * across[lv] + x] >= zmin:
            hidden = False
    return hidden


@ti.func
def _edges(c, k, tris: ti.template()):
    """Triangle k's edge functions in camera c: (n0, n1, n2, nn, |D|): the ray d meets it iff nᵢ·d ≥ 0 for all
    three, then at t = |D| / (nn·d) (see the module docstring)."""
    q0 = _in_camera(c, _v3(tris, k, 0))
    q1 = _in_camera(c, _v3(tris, k, 3))
    q2 = _in_camera(c, _v3(tris, k, 6))
    nrm = (q1 - q0).cross(q2 - q0)
    dd = q0.dot(nrm)
    s = 1.0 if dd > 0.0 else -1.0
    return q1.cross(q2) * s, q2.cross(q0) * s, q0.cross(q1) * s, nrm * s, ti.abs(dd)


@ti.func
def _span(c, v, u0, u1, n0, n1, n2):
    """The columns [ua, ub] of row v, within u0..u1, where the three edge functions may be ≥ 0 (exact interval,
    grown by SPAN_MARGIN); ua > ub when there is none."""
    yc = (ti.cast(v, ti.f32) - c[CAM_CY]) / c[CAM_FY]
    lo = -1e30
    hi = 1e30
    ok = True
    for e in ti.static(range(3)):
        n = n0 if e == 0 else (n1 if e == 1 else n2)
        a = n[0]
        b = n[1] * yc + n[2]  # the function along the row: a·xc + b ≥ 0
        if a == 0.0:
            if b < 0.0:
                ok = False
        elif a > 0.0:
            lo = ti.max(lo, -b / a)
        else:
            hi = ti.min(hi, -b / a)
    ua = u0
    ub = u1
    if not ok:
        ub = u0 - 1
    else:
        fu_lo = c[CAM_CX] + c[CAM_FX] * lo - SPAN_MARGIN
        fu_hi = c[CAM_CX] + c[CAM_FX] * hi + SPAN_MARGIN
        if fu_lo > ti.cast(u0, ti.f32):
            ua = ti.cast(ti.min(ti.ceil(fu_lo), 1e9), ti.i32)
        if fu_hi < ti.cast(u1, ti.f32):
            ub = ti.cast(ti.max(ti.floor(fu_hi), -1e9), ti.i32)
    return ua, ub


@ti.func
def _keep(buf: ti.template(), layer, b, v, u, key):
    """Keep ``key`` in pixel (v, u) of camera b's layer when it is the smallest so far: an atomic minimum, always.
    Reading the key first and skipping the atomic when it would change nothing lost a nearer hit now and then on
    CUDA, so a pose did not always render the same image: in 32 processes rendering miniroom:3's frames 40-55 over
    and over on two H100s, 17 of 79,200 renders had a pixel on the edge between two triangles of one mesh take the
    farther one, and 0 of 80,000 with the atomic alone (``benchmarks/results/gpu_2026-11-27_render_determinism/``).
    On the 2-core CPU the read saved nothing measurable (house:1, ``benchmarks/render.py``: 24.6-27.8 fps with it,
    25.8-28.7 without, in turns)."""
    ti.atomic_min(buf[layer, b, v, u], key)


@ti.func
def _triangle_row(c, b, v, ua, ub, k, n0, n1, n2, nn, dd, buf: ti.template(), layer):
    """Keep triangle k's hits on pixels ua..ub of row v of camera b in layer ``layer`` of ``buf``."""
    yc = (ti.cast(v, ti.f32) - c[CAM_CY]) / c[CAM_FY]
    ifx = 1.0 / c[CAM_FX]
    b0 = n0[1] * yc + n0[2]
    b1 = n1[1] * yc + n1[2]
    b2 = n2[1] * yc + n2[2]
    bn = nn[1] * yc + nn[2]
    for u in range(ua, ub + 1):
        xc = (ti.cast(u, ti.f32) - c[CAM_CX]) * ifx
        if n0[0] * xc + b0 >= 0.0 and n1[0] * xc + b1 >= 0.0 and n2[0] * xc + b2 >= 0.0:
            den = nn[0] * xc + bn
            if den > 0.0:
                t = dd / den
                if t > T_EPS:
                    _keep(buf, layer, b, v, u, key_of(t, k))


@ti.func
def _triangle_rows(c, b, k, u0, u1, va, vb, pi: ti.template(), tris: ti.template(), vis: ti.template()):
    """Rasterise rows va..vb (columns u0..u1) of triangle k's image in camera b, along each row's exact span."""
    n0, n1, n2, nn, dd = _edges(c, k, tris)
    layer = 1 if pi[k, 0] == GLASS else 0
    for v in range(va, vb + 1):
        ua, ub = _span(c, v, u0, u1, n0, n1, n2)
        _triangle_row(c, b, v, ua, ub, k, n0, n1, n2, nn, dd, vis, layer)


@ti.func
def _rows(c, b, k, u0, u1, va, vb, pf: ti.template(), pi: ti.template(), tris: ti.template(), vis: ti.template(),
          triangles: ti.template()):
    """Rasterise rows va..vb (columns u0..u1) of primitive k's image in camera b, along each row's exact span for a
    triangle. ``triangles`` (compile-time): k is known to be a triangle (no code for the other kinds)."""
    if ti.static(triangles):
        _triangle_rows(c, b, k, u0, u1, va, vb, pi, tris, vis)
    elif pi[k, 0] >= 3:
        _triangle_rows(c, b, k, u0, u1, va, vb, pi, tris, vis)
    else:
        _box_pixels(c, b, k, u0, u1, va, 0, (vb - va + 1) * (u1 - u0 + 1), 0, 1, pf, pi, tris, vis, False)


@ti.func
def _triangle_pixels(c, b, k, u0, u1, v0, p0, p1, lane, lanes, pi: ti.template(), tris: ti.template(),
                     vis: ti.template()):
    """:func:`_box_pixels` for triangle k: each pixel tested by the triangle's edge functions."""
    w = u1 - u0 + 1
    n0, n1, n2, nn, dd = _edges(c, k, tris)
    layer = 1 if pi[k, 0] == GLASS else 0
    ifx = 1.0 / c[CAM_FX]
    ify = 1.0 / c[CAM_FY]
    p = p0 + lane
    while p < p1:
        u = u0 + p % w
        v = v0 + p // w
        d = ti.Vector([(ti.cast(u, ti.f32) - c[CAM_CX]) * ifx, (ti.cast(v, ti.f32) - c[CAM_CY]) * ify, 1.0])
        if n0.dot(d) >= 0.0 and n1.dot(d) >= 0.0 and n2.dot(d) >= 0.0:
            den = nn.dot(d)
            if den > 0.0:
                t = dd / den
                if t > T_EPS:
                    _keep(vis, layer, b, v, u, key_of(t, k))
        p += lanes


@ti.func
def _box_pixels(c, b, k, u0, u1, v0, p0, p1, lane, lanes, pf: ti.template(), pi: ti.template(), tris: ti.template(),
                vis: ti.template(), triangles: ti.template()):
    """Pixels p0 + lane, p0 + lane + lanes, … < p1 of the rows from v0 on, columns u0..u1, numbered row-major, tested
    for primitive k in camera b: a triangle by its edge functions, another primitive by the traversal's own test.
    ``triangles`` (compile-time): k is known to be a triangle (no code for the other kinds: Taichi's compile time
    grows faster than a kernel's length)."""
    w = u1 - u0 + 1
    if ti.static(triangles):
        _triangle_pixels(c, b, k, u0, u1, v0, p0, p1, lane, lanes, pi, tris, vis)
    elif pi[k, 0] >= 3:
        _triangle_pixels(c, b, k, u0, u1, v0, p0, p1, lane, lanes, pi, tris, vis)
    else:  # box, ellipsoid, cylinder
        p = p0 + lane
        while p < p1:
            u = u0 + p % w
            v = v0 + p // w
            o, d = _ray(c, ti.cast(u, ti.f32), ti.cast(v, ti.f32))
            t, _n = _hit_prim(o, d, _safe_inv(d), pf, pi, tris, k, 1e30, False, False)
            if t < 1e30:
                _keep(vis, 0, b, v, u, key_of(t, k))
            p += lanes


@ti.func
def rasterise_primitive(c, b, k, pf: ti.template(), pi: ti.template(), tris: ti.template(), vis: ti.template(),
                        queue: ti.template(), counters: ti.template(), tiles: ti.template(), cull: ti.template(),
                        triangles: ti.template()):
    """Primitive k in camera b (row c): nothing when its image is empty or, with ``cull``, hidden behind the tile
    pyramid's depths (:func:`occluded`); else rasterised now when its image is small (or the queue is full), or
    queued (:data:`SPLIT`): in bands of rows on the CPU, in chunks of its bounding box's pixels on a GPU.
    ``cull`` and ``triangles`` (k is known to be a triangle) are compile-time flags."""
    H = vis.shape[2]
    W = vis.shape[3]
    u0, u1, v0, v1, zmin = _image_box(c, k, pf, pi, tris, W, H)
    hidden = False
    if ti.static(cull):
        hidden = occluded(b, u0, u1, v0, v1, zmin, tiles, W, H)
    if u0 <= u1 and v0 <= v1 and not hidden:
        area = (u1 - u0 + 1) * (v1 - v0 + 1)
        if area <= ti.static(split()["direct_pixels"]):
            _box_pixels(c, b, k, u0, u1, v0, 0, area, 0, 1, pf, pi, tris, vis, triangles)
        else:
            per = ti.static(split()["band_rows"] or split()["chunk_pixels"])  # rows of a band, or pixels of a chunk
            n = (v1 - v0 + per) // per if ti.static(split()["band_rows"] > 0) else (area + per - 1) // per
            j = ti.atomic_add(counters[1], n)
            for m in range(n):
                if j + m < queue.shape[0]:
                    queue[j + m, 0] = k
                    queue[j + m, 1] = b * H + v0
                    queue[j + m, 2] = u0 | (u1 << 16)
                    queue[j + m, 3] = v1 | (m << 16)
                else:  # the queue is full: this thread does the item
                    _queued_item(c, b, k, u0, u1, v0, v1, m, 0, 1, pf, pi, tris, vis, triangles)


@ti.func
def _queued_item(c, b, k, u0, u1, v0, v1, m, lane, lanes, pf: ti.template(), pi: ti.template(), tris: ti.template(),
                 vis: ti.template(), triangles: ti.template()):
    """Item m of primitive k's image (u0..u1 × v0..v1): band m of rows (CPU) or chunk m of pixels (GPU); this lane's
    share."""
    if ti.static(split()["band_rows"] > 0):
        va = v0 + m * ti.static(split()["band_rows"])
        _rows(c, b, k, u0, u1, va, ti.min(va + ti.static(split()["band_rows"]) - 1, v1), pf, pi, tris, vis,
              triangles)
    else:
        p0 = m * ti.static(split()["chunk_pixels"])
        _box_pixels(c, b, k, u0, u1, v0, p0, ti.min(p0 + ti.static(split()["chunk_pixels"]),
                                                     (u1 - u0 + 1) * (v1 - v0 + 1)), lane, lanes, pf, pi, tris, vis,
                    triangles)


@ti.func
def item_lane(t):
    """(queued item, lane) of item t of the queue's loop, which runs ``lanes`` items per queued item."""
    return t // ti.static(split()["lanes"]), t % ti.static(split()["lanes"])


@ti.func
def rasterise_queued(j, lane, c, pf: ti.template(), pi: ti.template(), tris: ti.template(), vis: ti.template(),
                     queue: ti.template(), triangles: ti.template()):
    """Lane ``lane``'s share of queued item j (camera row c: that of camera ``queue[j, 1] // H``); ``triangles``
    (compile-time): every queued item is a triangle's."""
    H = vis.shape[2]
    _queued_item(c, queue[j, 1] // H, queue[j, 0], queue[j, 2] & 0xFFFF, queue[j, 2] >> 16, queue[j, 1] % H,
                 queue[j, 3] & 0xFFFF, queue[j, 3] >> 16, lane, ti.static(split()["lanes"]), pf, pi, tris, vis,
                 triangles)


@ti.func
def list_cluster(i, c, n_clusters, cluster_box: ti.template(), cluster_prims: ti.template(), listed: ti.template(),
                 counters: ti.template(), tiles: ti.template(), W, H):
    """Item i = b · n_clusters + cluster of the clusters' loop: list it when the cluster's box meets camera b's view
    (row c) and is not hidden behind the tile pyramid's depths (:func:`occluded`)."""
    ci = i % n_clusters
    lo = _v3(cluster_box, ci, 0)
    hi = _v3(cluster_box, ci, 3)
    if cluster_prims[ci, 1] > 0 and cluster_in_view(c, lo, hi, W, H):
        u0, u1, v0, v1, zmin = _aabb_image(c, lo, hi, W, H)
        if u0 <= u1 and v0 <= v1 and not occluded(i // n_clusters, u0, u1, v0, v1, zmin, tiles, W, H):
            listed[ti.atomic_add(counters[0], 1)] = i


@ti.func
def listed_primitive(i, n_clusters, cluster_prims: ti.template(), listed: ti.template()):
    """(camera, primitive) of item i of the second loop (primitive −1: past the end of its cluster)."""
    e = listed[i // CLUSTER_PRIMS]
    ci = e % n_clusters
    m = i % CLUSTER_PRIMS
    k = -1
    if m < cluster_prims[ci, 1]:
        k = cluster_prims[ci, 0] + m
    return e // n_clusters, k


@ti.func
def rasterise_occluder(i, n_occluders, c, occluders: ti.template(), pf: ti.template(), pi: ti.template(),
                       tris: ti.template(), vis: ti.template(), queue: ti.template(), counters: ti.template(),
                       tiles: ti.template()):
    """Item i = camera · n_occluders + occluder (a triangle) of the occluders' loop (camera row c): rasterised, never
    culled."""
    rasterise_primitive(c, i // n_occluders, occluders[i % n_occluders], pf, pi, tris, vis, queue, counters, tiles,
                        False, True)
