"""Baked direct light ("lightmaps") for ``fast`` mode: the light of the sun and the lamps on every triangle, computed
once per scene on a lattice of points, then read by each pixel instead of summing the lights there.

Fast mode's light is diffuse: at a surface point it is ``Σ colour · n·l · attenuation · visibility`` over the lights
(:func:`~benchbot_sim_taichi.render.kernels._direct`), which depends on the point and the side it is seen from, not on the
eye. With shadow maps (lamps' cube maps and the sun's map, one shadow sample), it is therefore the same for every
frame of a scene, and :func:`bake_kernel` evaluates it once, on both sides of each triangle, at the barycentric lattice
points ``(b1, b2) = (i/n, j/n)``, ``i + j ≤ n``, with ``n = ⌈√(2 · area) / LIGHTMAP_SPACING_M⌉`` (at most
:data:`MAX_DIVISIONS`; 1 for a triangle smaller than a lattice cell: its vertices), so that the lattice triangles
have about the area of a right triangle of the spacing's legs whatever the triangle's shape (a long sliver gets
longer cells along its length rather than millions of points). A pixel then interpolates linearly between the three
lattice points of the lattice triangle around its hit (:func:`baked_direct`). house:1's 600,000 triangles (1,700 m²)
take 10 million points (41 MB); the light is stored in the shared-exponent format RGB9E5 (one 32-bit word a point,
9-bit mantissas: 0.2 % of the largest channel).

Against summing the lights at each pixel, the difference is the interpolation's: shadow edges are about as sharp as
the lattice (2.5 cm; the shadow maps' texels are 1–5 cm anyway), and a shading normal that turns away from the eye
is not bent towards it (the bend is the eye's). ``benchmarks/baked_light.py`` measures the
difference on a whole environment. The room shell, boxes, ellipsoids and cylinders keep their per-pixel light.

The lattice point (i, j) of a triangle with n divisions is word ``first + side · points(n) + i(2n + 3 − i)/2 + j``
of the store, with ``points(n) = (n + 1)(n + 2)/2`` and side 0 the front (where the vertex normals point), 1 the back.
"""

import contextlib
import sys

import numpy as np

with contextlib.redirect_stdout(sys.stderr):
    import taichi as ti

from benchbot_sim_taichi.render.kernels import _direct, _triangle_point, _v3  # noqa: E402

#: Spacing (m) of a triangle's lattice along its longest edge.
LIGHTMAP_SPACING_M = 0.025
#: Most divisions of a triangle's edge (a 25 m triangle at the spacing).
MAX_DIVISIONS = 1024


def layout(tris: np.ndarray, kinds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where each triangle's lattice lies in the store.

    Args:
        tris: float32 vertices of the packed primitives (``renderer.pack_scene``'s ``tris``: row k is primitive
            k's when it is a triangle). kinds: (P,) int32 their kinds (``pi[:, 0]``; 3 a triangle).

    Returns:
        ``(info (max(P, 1), 2) int32 [first word, divisions n] (n = 0: not baked — not a triangle, or a window pane),
        starts (P + 1,) int64 the first word of each primitive, ascending, the last the store's size)``.

    Raises:
        ValueError: the store would exceed 2³¹ words.
    """
    n_prims = kinds.shape[0]
    n = np.zeros(n_prims, np.int64)
    tri = np.flatnonzero(np.asarray(kinds) == 3)  # (a scene without triangles has a single row of zeros in tris)
    if tri.size:
        v = np.asarray(tris, np.float64)[tri].reshape(-1, 3, 3)
        area = 0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)
        n[tri] = np.clip(np.ceil(np.sqrt(2.0 * area) / LIGHTMAP_SPACING_M), 1, MAX_DIVISIONS)
    words = np.where(n > 0, (n + 1) * (n + 2), 0)  # both sides
    starts = np.concatenate([[0], np.cumsum(words)])
    if starts[-1] >= 2**31:
        raise ValueError(f"lightmap: {starts[-1]} lattice points exceed the store's 2^31 words")
    info = np.zeros((max(n_prims, 1), 2), np.int32)
    info[:n_prims, 0], info[:n_prims, 1] = starts[:-1], n
    return info, starts


@ti.func
def encode_rgb9e5(c):
    """Linear RGB c (≥ 0) as one int32 of the shared-exponent format RGB9E5 (three 9-bit mantissas, a 5-bit exponent
    with bias 15: OpenGL's EXT_texture_shared_exponent)."""
    mx = ti.max(ti.max(c[0], c[1]), ti.max(c[2], 1e-30))
    mx = ti.min(mx, 65408.0)
    e = ti.max(-16, ti.cast(ti.floor(ti.log(mx) * 1.4426950408889634), ti.i32)) + 1  # ⌊log2⌋ + 1
    scale = _power_of_two(9 - e)
    if ti.cast(ti.floor(mx * scale + 0.5), ti.i32) == 512:  # rounding reached the next power of two
        e += 1
        scale *= 0.5
    word = ti.min(e + 15, 31) << 27
    for q in ti.static(range(3)):
        m = ti.cast(ti.floor(ti.min(ti.max(c[q], 0.0), 65408.0) * scale + 0.5), ti.i32)
        word |= ti.min(ti.max(m, 0), 511) << (9 * q)
    return word


@ti.func
def _power_of_two(e):
    """2^e as float32 for an integer −126 ≤ e ≤ 127, built from its bits (no call to pow)."""
    return ti.bit_cast((e + 127) << 23, ti.f32)


@ti.func
def decode_rgb9e5(word):
    """The linear RGB of an RGB9E5 word (:func:`encode_rgb9e5`)."""
    scale = _power_of_two(((word >> 27) & 31) - 15 - 9)
    return ti.Vector([ti.cast((word >> (9 * q)) & 511, ti.f32) for q in ti.static(range(3))]) * scale


@ti.func
def _point_index(n, i, j):
    """Word of lattice point (i, j) within one side of a triangle with n divisions."""
    return i * (2 * n + 3 - i) // 2 + j


@ti.func
def _lattice_point(n, idx):
    """(i, j) of word idx within one side (the inverse of :func:`_point_index`)."""
    a = ti.cast(2 * n + 3, ti.f32)
    i = ti.cast(ti.floor((a - ti.sqrt(ti.max(a * a - 8.0 * ti.cast(idx, ti.f32), 0.0))) * 0.5), ti.i32)
    i = ti.min(ti.max(i, 0), n)
    while i > 0 and _point_index(n, i, 0) > idx:  # float rounding: settle the row exactly
        i -= 1
    while i < n and _point_index(n, i + 1, 0) <= idx:
        i += 1
    return i, idx - _point_index(n, i, 0)


@ti.kernel
def bake_kernel(
    starts: ti.types.ndarray(dtype=ti.i64, ndim=1),  # (P + 1,) i64 the first word of each primitive in baked (layout)
    baked_info: ti.types.ndarray(dtype=ti.i32, ndim=2),  # (P, 2) i32 SceneArrays.baked_info
    params: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (PARAMS_LEN,) f32 the render parameters (renderer.render_params)
    lights: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (L, 17) f32 SceneArrays.lights
    n_always: ti.i32,
    always: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (A,) i32 SceneArrays.always
    light_grid: ti.types.ndarray(dtype=ti.i32, ndim=3),  # (NY, NX, W) i32 SceneArrays.light_grid
    grid_xform: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (4,) f32 SceneArrays.grid_xform
    light_of_slot: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (S,) i32 SceneArrays.light_of_slot
    nodes: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (I, 16) f32 SceneArrays.nodes
    pf: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (P, 11) f32 SceneArrays.pf
    pi: ti.types.ndarray(dtype=ti.i32, ndim=2),  # (P, 4) i32 SceneArrays.pi
    tris: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (P, 9) f32 SceneArrays.tris
    shade: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (P, 17) f32 SceneArrays.shade
    lamp_maps: ti.types.ndarray(dtype=ti.f32, ndim=3),  # (6·S, R, R) f32 SceneArrays.lamp_maps
    sun_map: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (R, R) f32 SceneArrays.sun_map
    baked: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (Q,) i32 out: SceneArrays.baked
):
    """Every lattice point of the store ``baked`` (:func:`layout`'s ``starts`` and ``info``, here ``baked_info``): the
    direct light (:func:`~benchbot_sim_taichi.render.kernels._direct`, with the render params ``params`` and the
    light lists as the all-sensors kernel takes them) at the triangle's point, seen from that side, encoded
    RGB9E5."""
    P = starts.shape[0] - 1
    for w in range(baked.shape[0]):
        lo = 0  # the primitive whose words hold w: the last start ≤ w
        hi = P
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if starts[mid] <= w:
                lo = mid
            else:
                hi = mid
        k = lo
        n = baked_info[k, 1]
        per_side = (n + 1) * (n + 2) // 2
        local = ti.cast(w - starts[k], ti.i32)
        side = local // per_side
        i, j = _lattice_point(n, local - side * per_side)
        b1 = ti.cast(i, ti.f32) / ti.cast(n, ti.f32)
        b2 = ti.cast(j, ti.f32) / ti.cast(n, ti.f32)
        b0 = 1.0 - b1 - b2
        v0 = _v3(tris, k, 0)
        v1 = _v3(tris, k, 3)
        v2 = _v3(tris, k, 6)
        p = b0 * v0 + b1 * v1 + b2 * v2
        ng = (v1 - v0).cross(v2 - v0).normalized()
        sn = b0 * _v3(shade, k, 0) + b1 * _v3(shade, k, 3) + b2 * _v3(shade, k, 6)
        if sn.dot(ng) < 0.0:  # the front: where the vertex normals point
            ng = -ng
        if side == 1:
            ng = -ng
        ns, _sgn, ps = _triangle_point(tris, shade, k, b0, b1, b2, ng, p, True)
        baked[w] = encode_rgb9e5(_direct(ps, ng, ns, 0, params, lights, n_always, always, light_grid, grid_xform,
                                         light_of_slot, nodes, pf, pi, tris, lamp_maps, sun_map, True))


@ti.func
def baked_direct(store: ti.template(), info: ti.template(), k, tri_pos):
    """The baked direct light at the hit ``tri_pos`` = (b1, b2, side ±1) of triangle k (which must have n > 0):
    linear between the three lattice points of the lattice triangle around it."""
    n = info[k, 1]
    nf = ti.cast(n, ti.f32)
    x = ti.min(ti.max(tri_pos[0], 0.0), 1.0) * nf
    y = ti.min(ti.max(tri_pos[1], 0.0), 1.0) * nf
    i = ti.min(ti.cast(ti.floor(x), ti.i32), n - 1)
    j = ti.min(ti.cast(ti.floor(y), ti.i32), n - 1 - i)
    fx = ti.min(x - ti.cast(i, ti.f32), 1.0)
    fy = ti.min(y - ti.cast(j, ti.f32), 1.0)
    base = info[k, 0] + (0 if tri_pos[2] > 0.0 else (n + 1) * (n + 2) // 2)
    c = ti.Vector([0.0, 0.0, 0.0])
    if fx + fy <= 1.0 or i + j + 1 >= n:  # the lower lattice triangle (i, j), (i + 1, j), (i, j + 1)
        w0 = ti.max(1.0 - fx - fy, 0.0)  # (beyond the hypotenuse by rounding: the nearest point of its edge)
        c = (decode_rgb9e5(store[base + _point_index(n, i, j)]) * w0
             + decode_rgb9e5(store[base + _point_index(n, i + 1, j)]) * fx
             + decode_rgb9e5(store[base + _point_index(n, i, j + 1)]) * fy) / (w0 + fx + fy)
    else:  # the upper one (i + 1, j + 1), (i, j + 1), (i + 1, j)
        c = (decode_rgb9e5(store[base + _point_index(n, i + 1, j + 1)]) * (fx + fy - 1.0)
             + decode_rgb9e5(store[base + _point_index(n, i, j + 1)]) * (1.0 - fx)
             + decode_rgb9e5(store[base + _point_index(n, i + 1, j)]) * (1.0 - fy))
    return c
