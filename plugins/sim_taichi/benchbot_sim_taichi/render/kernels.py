"""The Taichi functions of the ray tracer: BVH traversal, primitive intersection, shading with shadow rays or shadow
maps (on triangles: interpolated vertex normals and mip-mapped, bilinearly filtered textures), and the kernels that
trace the lamps' and the sun's shadow maps. The all-sensors kernel that uses them is in
:mod:`benchbot_sim_taichi.render.sensors`, the path tracer in :mod:`benchbot_sim_taichi.render.pathtrace`;
:mod:`benchbot_sim_taichi.render.renderer` prepares their arguments and launches them.

Conventions and formulas: see the renderer's module docstring. Kernels take ``ti.types.ndarray`` arguments (NumPy
arrays or Taichi ndarrays), so they compile once per process, not per scene or image size.
"""

import contextlib
import sys

# Taichi prints its banner on stdout; stdout carries our programs' data (tables, --json), so it goes to stderr.
with contextlib.redirect_stdout(sys.stderr):
    import taichi as ti

from benchbot_sim_taichi.render.bvh import LEAF_SHIFT, TRI_ONLY  # noqa: E402 - after Taichi's banner is redirected
from benchbot_sim_taichi.render.layouts import (  # noqa: E402
    CAM_CX, CAM_CY, CAM_FX, CAM_FY, CAM_ORIGIN, CAM_R, P_LAMP_RADIUS, P_SHADOW_SAMPLES, P_SUN_RADIUS,
    WORLD_BACKGROUND_CLASS, WORLD_ROOM_MAX, WORLD_ROOM_MIN, WORLD_SHELL_ALBEDO,
)

#: Tiny direction component substituted for zero before inverting (avoids 0·inf).
DIR_EPS = 1e-12
#: Minimum hit distance of primary rays and offset of shadow-ray origins (metres).
T_EPS = 1e-4
SHADOW_OFFSET = 1e-3
#: Floor tiles (metres) and their albedo modulation.
TILE_M = 0.6
TILE_CONTRAST = 0.06

#: Relative margin by which a primitive beats the room shell at equal distance (a furnished floor at z = 0 lies on
#: the shell's floor; float32 rounding would otherwise show the shell in rows of pixels).
SHELL_TIE = 1e-5
#: Deepest BVH the renderer accepts (``renderer.pack_scene``): the entries of the traversal's per-ray stack.
STACK = 64
#: Default angular radius (rad) of the sun and radius (m) of the lamps, for soft shadows.
SUN_RADIUS = 0.035
LAMP_RADIUS = 0.15
#: Shadow rays towards a point light stop this far (m) short of it: a lamp's own fixture (a ceiling lamp model is at
#: most 0.5 m tall, its bottom 5 cm above its light) casts no shadow, so a shade does not black out the ceiling
#: around it. A hanging lamp has nothing else that close.
LAMP_FIXTURE_M = 0.6
#: Lamp shadow maps (fast mode, one shadow sample, scenes that ask for them: ``Renderer.shadow_maps``): texels per
#: cube-face side; the lookup point leaves the surface along its normal by ``LAMP_MAP_NORMAL_OFFSET`` texel
#: footprints, and a texel's depth may be exceeded by ``LAMP_MAP_BIAS_M`` (m), so a lit surface does not shadow
#: itself ("shadow acne").
LAMP_MAP_RES = 256
LAMP_MAP_NORMAL_OFFSET = 1.5
LAMP_MAP_BIAS_M = 0.01
#: The light grid of fast mode (lamps with shadow maps, one shadow sample: :func:`_direct`): cells of LIGHT_CELL_M
#: (m) in x and y; :func:`light_grid_kernel` samples each lamp's lit region along the centre rays of blocks of
#: LIGHT_GRID_BLOCK² map texels every LIGHT_GRID_STEP (m).
LIGHT_CELL_M = 0.25
LIGHT_GRID_BLOCK = 4
LIGHT_GRID_STEP = 0.125
#: The sun's shadow map (fast mode, one shadow sample, beside the lamps' maps): an orthographic map along the sun's
#: direction over the scene's primitives, ``SUN_MAP_RES``² texels (a furnished house of 20 m: 1 cm texels), traced
#: once per scene (:func:`sun_map_kernel`). Each texel holds the height, along the direction towards the sun, of the
#: first primitive that the sun's rays meet; a point is lit when it is no lower than that, less ``SUN_MAP_BIAS_M``
#: (m), after leaving its surface along the normal by ``SUN_MAP_NORMAL_OFFSET`` texels (no "shadow acne").
SUN_MAP_RES = 2048
SUN_MAP_NORMAL_OFFSET = 1.5
SUN_MAP_BIAS_M = 0.002
#: Columns of a packed light row: kind, vector xyz, colour rgb, range, shadow-map slot (−1: shadow rays; a lamp's
#: cube-map slot; 0 for the directional light with the sun map), then the sun map's projection a xyz, b xyz, a0,
#: b0: a point p falls at texel coordinates (p·a − a0, p·b − b0) (a, b orthogonal to the light, of length 1/texel).
LIGHT_COLS = 17

#: ``pi`` kind of a window pane: a triangle of clear glass (see the renderer's module docstring). The scene's own
#: kinds are 0 box, 1 ellipsoid, 2 cylinder, 3 triangle.
GLASS = 4
#: Reflectance of glass (index 1.5) at normal incidence, for Schlick's approximation.
GLASS_F0 = 0.04
#: Pane faces a quality-mode path goes through or reflects in; at the next one it ends (two panes of a
#: double-glazed window have four faces).
MAX_GLASS_LAYERS = 8
#: What a ray does with panes (a compile-time argument of the traversal, see :func:`_trace`): PANES_SEEN, a
#: closest-hit ray sees them as surfaces and an any-hit (shadow) ray goes through them weighted by their
#: transmittance (quality mode); PANES_UNSEEN, the ray does not see them (fast mode's shadow rays, the laser, the lamp
#: maps); PANES_TRACKED, a closest-hit ray does not see them but notes the nearest in front of its hit (fast mode's
#: camera rays).
PANES_SEEN = 1
PANES_UNSEEN = 0
PANES_TRACKED = 2

#: Columns of the per-triangle shading rows (``renderer.pack_scene``'s ``shade``): vertex normals (9), UVs (6),
#: texture index (−1: none), texture LOD offset ``0.5·log2(texels per world area)``.
SHADE_COLS = 17

@ti.func
def _safe_inv(d):
    e = ti.Vector([d[0], d[1], d[2]])
    for k in ti.static(range(3)):
        if ti.abs(e[k]) < DIR_EPS:
            e[k] = DIR_EPS
    return 1.0 / e


@ti.func
def _v3(a: ti.template(), i, k0: ti.template()):
    return ti.Vector([a[i, k0], a[i, k0 + 1], a[i, k0 + 2]])


@ti.func
def _slab(o, inv, lo, hi):
    t1 = (lo - o) * inv
    t2 = (hi - o) * inv
    a = ti.min(t1, t2)
    b = ti.max(t1, t2)
    return ti.max(a[0], ti.max(a[1], a[2])), ti.min(b[0], ti.min(b[1], b[2]))


@ti.func
def _perm(v, ax):
    """(v[a+1], v[a+2], v[a]): the axis ``ax`` last."""
    r = v
    if ax == 0:
        r = ti.Vector([v[1], v[2], v[0]])
    elif ax == 1:
        r = ti.Vector([v[2], v[0], v[1]])
    return r


@ti.func
def _unperm(v, ax):
    r = v
    if ax == 0:
        r = ti.Vector([v[2], v[0], v[1]])
    elif ax == 1:
        r = ti.Vector([v[1], v[2], v[0]])
    return r


@ti.func
def _glass_reflectance(cos_i):
    """Schlick's reflectance of one air–glass interface at incidence cosine ``cos_i`` (0..1)."""
    c = 1.0 - ti.min(ti.max(cos_i, 0.0), 1.0)
    c2 = c * c
    return GLASS_F0 + (1.0 - GLASS_F0) * c2 * c2 * c


@ti.func
def _hit_tri(o, d, tris: ti.template(), k, tmax):
    """Distance t along the ray to triangle k (row k of ``tris``) if T_EPS < t < tmax, else tmax (Möller–Trumbore;
    both faces)."""
    t = tmax
    v0 = _v3(tris, k, 0)
    e1 = _v3(tris, k, 3) - v0
    e2 = _v3(tris, k, 6) - v0
    p = d.cross(e2)
    det = e1.dot(p)
    if det != 0.0:
        idet = 1.0 / det
        s = o - v0
        u = s.dot(p) * idet
        if u >= 0.0 and u <= 1.0:
            qv = s.cross(e1)
            w = d.dot(qv) * idet
            if w >= 0.0 and u + w <= 1.0:
                t0 = e2.dot(qv) * idet
                if t0 > T_EPS and t0 < tmax:
                    t = t0
    return t


@ti.func
def _hit_prim(o, d, inv, pf: ti.template(), pi: ti.template(), tris: ti.template(), k, tmax,
              skip_panes: ti.template(), with_normal: ti.template()):
    """(t, normal) of the ray's entry into primitive k if T_EPS < t < tmax, else (tmax, 0). With ``skip_panes``, a
    pane (kind GLASS) is missed. Without ``with_normal`` the normal is not computed (it is 0): the traversal tests
    primitives without it, and :func:`_trace` asks for the closest one's once, at the end."""
    kind = pi[k, 0]
    if ti.static(skip_panes):
        if kind == GLASS:
            kind = -1
    t = tmax
    n = ti.Vector([0.0, 0.0, 0.0])
    lo = ti.Vector([0.0, 0.0, 0.0])
    hi = ti.Vector([0.0, 0.0, 0.0])
    if kind < 3:  # a triangle reads its vertices only
        lo = _v3(pf, k, 0)
        hi = _v3(pf, k, 3)
    if kind == 0:  # box
        tn = -1e30
        tf = 1e30
        axis = 0
        for q in ti.static(range(3)):
            t1 = (lo[q] - o[q]) * inv[q]
            t2 = (hi[q] - o[q]) * inv[q]
            a = ti.min(t1, t2)
            if a > tn:
                tn = a
                axis = q
            tf = ti.min(tf, ti.max(t1, t2))
        if tn <= tf and tn > T_EPS and tn < tmax:
            t = tn
            if ti.static(with_normal):
                for q in ti.static(range(3)):
                    if q == axis:
                        n[q] = -1.0 if d[q] > 0 else 1.0
    elif kind == 1:  # ellipsoid inscribed in the box
        c = (lo + hi) * 0.5
        r = ti.max((hi - lo) * 0.5, 1e-6)
        oc = (o - c) / r
        dd = d / r
        a = dd.dot(dd)
        b = oc.dot(dd)
        cc = oc.dot(oc) - 1.0
        disc = b * b - a * cc
        if disc >= 0.0:
            t0 = (-b - ti.sqrt(disc)) / a
            if t0 > T_EPS and t0 < tmax:
                t = t0
                if ti.static(with_normal):
                    n = ((oc + t0 * dd) / r).normalized()
    elif kind == 2:  # cylinder along axis pi[k, 1], elliptic section inscribed in the box
        ax = pi[k, 1]
        c = (lo + hi) * 0.5
        r = ti.max((hi - lo) * 0.5, 1e-6)
        R = _perm(r, ax)
        O = _perm(o - c, ax) / R
        D = _perm(d, ax) / R
        a = D[0] * D[0] + D[1] * D[1]
        b = O[0] * D[0] + O[1] * D[1]
        cc = O[0] * O[0] + O[1] * O[1] - 1.0
        ts0 = -1e30
        ts1 = 1e30
        ok = 1
        if a < 1e-12:
            if cc > 0.0:
                ok = 0
        else:
            disc = b * b - a * cc
            if disc < 0.0:
                ok = 0
            else:
                s = ti.sqrt(disc)
                ts0 = (-b - s) / a
                ts1 = (-b + s) / a
        dz = D[2]
        if ti.abs(dz) < DIR_EPS:
            dz = DIR_EPS
        tz0 = (-1.0 - O[2]) / dz
        tz1 = (1.0 - O[2]) / dz
        tza = ti.min(tz0, tz1)
        tn = ti.max(ts0, tza)
        tf = ti.min(ts1, ti.max(tz0, tz1))
        if ok == 1 and tn <= tf and tn > T_EPS and tn < tmax:
            t = tn
            if ti.static(with_normal):
                nl = ti.Vector([0.0, 0.0, -1.0 if D[2] > 0 else 1.0])
                if ts0 > tza:
                    q = O + tn * D
                    nl = ti.Vector([q[0] / R[0], q[1] / R[1], 0.0])
                n = _unperm(nl, ax).normalized()
    elif kind >= 3:  # triangle or pane: its vertices are row k of tris
        t = _hit_tri(o, d, tris, k, tmax)
        if ti.static(with_normal):
            if t < tmax:
                v0 = _v3(tris, k, 0)
                n = (_v3(tris, k, 3) - v0).cross(_v3(tris, k, 6) - v0).normalized()
                if n.dot(d) > 0:
                    n = -n
    return t, n


@ti.func
def _hit_leaf(o, d, inv, pf: ti.template(), pi: ti.template(), tris: ti.template(), first, cnt, tri_only, best,
              best_k, trans, pane_t, pane_k, any_hit: ti.template(), panes: ti.template()):
    """The closest of a leaf's primitives ``first .. first + cnt - 1`` nearer than ``best``: the updated
    ``(best, best_k, trans, pane_t, pane_k)`` (unchanged when none is). Panes (``panes``, see :func:`_trace`):
    with PANES_UNSEEN a ray does not see them; with PANES_SEEN an ``any_hit`` ray goes through them, its
    transmittance ``trans`` multiplied by each one's 1 − F (a face's triangles meet the ray at one distance: one of
    them counts), and a closest-hit ray sees them as surfaces; with PANES_TRACKED a closest-hit ray keeps the nearest,
    ``(pane_t, pane_k)``, without seeing it. ``tri_only``: all are plain triangles (no kinds to read)."""
    last_pane_t = -1.0
    if tri_only:
        for k in range(first, first + cnt):
            t = _hit_tri(o, d, tris, k, best)
            if t < best:
                best = t
                best_k = k
        cnt = 0
    for k in range(first, first + cnt):
        t, _n = _hit_prim(o, d, inv, pf, pi, tris, k, best, ti.static(panes == PANES_UNSEEN), False)
        if t < best:
            if ti.static(any_hit and panes == PANES_SEEN):
                if pi[k, 0] == GLASS:
                    if ti.abs(t - last_pane_t) > T_EPS:  # not the same face again (its other triangle, at an edge)
                        v0 = _v3(tris, k, 0)
                        nrm = (_v3(tris, k, 3) - v0).cross(_v3(tris, k, 6) - v0).normalized()
                        trans *= 1.0 - _glass_reflectance(ti.abs(nrm.dot(d)) / d.norm())
                        last_pane_t = t
                else:
                    best = t
                    best_k = k
            elif ti.static(panes == PANES_TRACKED):
                if pi[k, 0] == GLASS:
                    if t < pane_t:
                        pane_t = t
                        pane_k = k
                else:
                    best = t
                    best_k = k
            else:
                best = t
                best_k = k
    return best, best_k, trans, pane_t, pane_k


@ti.func
def _trace(o, d, tmax, nodes: ti.template(), pf: ti.template(), pi: ti.template(), tris: ti.template(),
           any_hit: ti.template(), panes: ti.template()):
    """Closest (or, with ``any_hit``, any) primitive hit with T_EPS < t < tmax: (t, k, normal, transmittance,
    pane_t, pane_k); k = -1: none. Window panes (kind GLASS), by ``panes``: PANES_UNSEEN, the ray does not see them
    (transmittance 1); PANES_SEEN, an any-hit ray (a shadow ray) goes through them, and the transmittance is the
    product of their 1 − F — exact, since such a ray tests every primitive before tmax — and a closest-hit ray sees
    them as surfaces; PANES_TRACKED (closest hit), the ray does not see them but returns the nearest one in front of
    the hit (``pane_k``, −1: none, at ``pane_t``) — exact too, since every primitive nearer than the closest hit is
    tested. (The bookkeeping costs GPU occupancy: fast mode's shadow rays do not see panes, see docs/simulator.md.)

    ``nodes`` is :func:`benchbot_sim_taichi.render.bvh.wide_nodes`'s: each interior node one record with both children's
    boxes. A step reads one record and tests both boxes; where both are hit, a closest-hit ray enters the nearer
    child and pushes the farther, with its entry distance, on a per-ray stack of :data:`STACK` entries (an any-hit
    ray enters the left one); a popped child that begins beyond the closest hit so far is skipped. A leaf's
    primitives are tested where it is met."""
    inv = _safe_inv(d)
    best = tmax
    best_k = -1
    trans = 1.0
    pane_t = 1e30
    pane_k = -1
    stack = ti.Vector([0] * STACK, dt=ti.i32)
    entry = ti.Vector([0.0] * STACK, dt=ti.f32)
    sp = 0
    ref = 0  # the root's record
    going = True
    while going:
        found = False
        nxt = 0
        if ref >= 0:  # an interior node: both children's boxes
            l0, l1 = _slab(o, inv, _v3(nodes, ref, 0), _v3(nodes, ref, 3))
            r0, r1 = _slab(o, inv, _v3(nodes, ref, 6), _v3(nodes, ref, 9))
            hit_l = l0 <= l1 and l1 > 0.0 and l0 < best
            hit_r = r0 <= r1 and r1 > 0.0 and r0 < best
            left = ti.bit_cast(nodes[ref, 12], ti.i32)
            right = ti.bit_cast(nodes[ref, 13], ti.i32)
            if hit_l and hit_r:
                near, far, far_t = left, right, r0
                if ti.static(not any_hit):
                    if r0 < l0:
                        near, far, far_t = right, left, l0
                stack[sp] = far
                entry[sp] = far_t
                sp += 1
                nxt = near
                found = True
            elif hit_l:
                nxt = left
                found = True
            elif hit_r:
                nxt = right
                found = True
        else:  # a leaf: its primitives
            code = ~ref
            best, best_k, trans, pane_t, pane_k = _hit_leaf(
                o, d, inv, pf, pi, tris, code >> LEAF_SHIFT, code & (TRI_ONLY - 1), (code & TRI_ONLY) != 0, best,
                best_k, trans, pane_t, pane_k, any_hit, panes)
            if ti.static(any_hit):
                if best_k >= 0:
                    going = False
        while going and not found and sp > 0:
            sp -= 1
            if entry[sp] < best:
                nxt = stack[sp]
                found = True
        if not found:
            going = False
        ref = nxt
    if ti.static(panes == PANES_TRACKED):
        if pane_t >= best:
            pane_k = -1
    return best, best_k, _closest_normal(o, d, inv, best, best_k, pf, pi, tris), trans, pane_t, pane_k


@ti.func
def _closest_normal(o, d, inv, best, best_k, pf: ti.template(), pi: ti.template(), tris: ti.template()):
    """The geometric normal, facing the ray, of primitive ``best_k`` met at distance ``best`` (0 when best_k < 0):
    a triangle's is its plane's; another primitive's comes from its test, run again (the same entry point)."""
    best_n = ti.Vector([0.0, 0.0, 0.0])
    if best_k >= 0:
        if pi[best_k, 0] >= 3:
            v0 = _v3(tris, best_k, 0)
            best_n = (_v3(tris, best_k, 3) - v0).cross(_v3(tris, best_k, 6) - v0).normalized()
            if best_n.dot(d) > 0:
                best_n = -best_n
        else:
            t_again, best_n = _hit_prim(o, d, inv, pf, pi, tris, best_k, best * (1.0 + 1e-5) + T_EPS, False, True)
            if t_again >= best * (1.0 + 1e-5) + T_EPS:  # missed on a grazing edge: face the ray
                best_n = -d.normalized()
    return best_n


@ti.func
def _hash(x):
    h = ti.cast(x, ti.u32)
    h ^= h >> ti.u32(16)
    h *= ti.u32(0x7FEB352D)
    h ^= h >> ti.u32(15)
    h *= ti.u32(0x846CA68B)
    h ^= h >> ti.u32(16)
    return h


@ti.func
def _rand(key):
    """Uniform [0, 1) from an integer key (24 bits)."""
    return ti.cast(_hash(key) >> ti.u32(8), ti.f32) * (1.0 / 16777216.0)


@ti.func
def _frame(n):
    """Two unit vectors orthogonal to unit n."""
    a = ti.Vector([1.0, 0.0, 0.0])
    if ti.abs(n[0]) > 0.9:
        a = ti.Vector([0.0, 1.0, 0.0])
    t1 = n.cross(a).normalized()
    return t1, n.cross(t1)


@ti.func
def _texel(texels: ti.template(), lut: ti.template(), i):
    """Linear RGB of packed sRGB texel i (``r | g << 8 | b << 16``)."""
    c = texels[i]
    return ti.Vector([lut[c & 255], lut[(c >> 8) & 255], lut[(c >> 16) & 255]])


@ti.func
def _bilinear(texels: ti.template(), lut: ti.template(), base, w, h, u, v):
    """Bilinear sample (linear light, repeating) of the w × h level starting at texel ``base``; u, v in [0, 1],
    v = 0 the bottom row."""
    x = u * w - 0.5
    y = (1.0 - v) * h - 0.5
    xf = ti.floor(x)
    yf = ti.floor(y)
    fx = x - xf
    fy = y - yf
    x0 = ti.cast(xf, ti.i32)
    y0 = ti.cast(yf, ti.i32)
    if x0 < 0:
        x0 += w
    if y0 < 0:
        y0 += h
    x0 = ti.min(x0, w - 1)
    y0 = ti.min(y0, h - 1)
    x1 = x0 + 1
    y1 = y0 + 1
    if x1 >= w:
        x1 -= w
    if y1 >= h:
        y1 -= h
    r0 = base + y0 * w
    r1 = base + y1 * w
    top = _texel(texels, lut, r0 + x0) * (1.0 - fx) + _texel(texels, lut, r0 + x1) * fx
    bot = _texel(texels, lut, r1 + x0) * (1.0 - fx) + _texel(texels, lut, r1 + x1) * fx
    return top * (1.0 - fy) + bot * fy


@ti.func
def _texture(texels: ti.template(), tex_info: ti.template(), lut: ti.template(), tex, u, v, lod):
    """Trilinear (mip-mapped) sample of texture ``tex`` at (u, v) (repeating) and level of detail ``lod``."""
    base = tex_info[tex, 0]
    w = tex_info[tex, 1]
    h = tex_info[tex, 2]
    levels = tex_info[tex, 3]
    uu = u - ti.floor(u)
    vv = v - ti.floor(v)
    lam = ti.min(ti.max(lod, 0.0), ti.cast(levels - 1, ti.f32))
    l0 = ti.cast(ti.floor(lam), ti.i32)
    f = lam - ti.cast(l0, ti.f32)
    for _ in range(l0):
        base += w * h
        w = ti.max(1, w >> 1)
        h = ti.max(1, h >> 1)
    c = _bilinear(texels, lut, base, w, h, uu, vv)
    if f > 1e-3 and l0 + 1 < levels:
        c = c * (1.0 - f) + _bilinear(texels, lut, base + w * h, ti.max(1, w >> 1), ti.max(1, h >> 1), uu, vv) * f
    return c


@ti.func
def _shade_hit(o, d, spread, nodes: ti.template(), pf: ti.template(),
               pi: ti.template(), tris: ti.template(), shade: ti.template(), texels: ti.template(),
               tex_info: ti.template(), lut: ti.template(), world: ti.template(), panes: ti.template()):
    """First surface along the ray (objects, else the room shell): (hit, t, geometric normal, shading normal,
    albedo, class, instance, shadow-ray origin, primitive index: −1 for the shell, the nearest pane in front of it:
    −1 for none or unless ``panes`` is PANES_TRACKED, and on a triangle (b1, b2, side): the hit's barycentrics of
    vertices 1 and 2 and the side seen, 1 the front (where the vertex normals point) or −1). Both normals face the
    ray. On a triangle the shading normal interpolates its vertex normals (:func:`_triangle_point`), bent towards the
    eye where it turns away from it, the albedo is multiplied by its texture, sampled
    at the mip level of the ray footprint (``spread`` · t wide, divided by the cosine of incidence: the long axis of
    the footprint on the surface, so grazing surfaces blur rather than alias), and the shadow-ray origin is the hit
    point moved onto the vertices' tangent planes (Hanika's shadow-terminator fix) so that smooth low-poly surfaces
    do not shadow themselves in facets; elsewhere both normals are equal and the origin is the hit point. Window
    panes are surfaces with ``panes`` PANES_SEEN (a pane's hit is returned unshaded: its normals, its primitive
    index), invisible with PANES_UNSEEN and PANES_TRACKED (see :func:`_trace`)."""
    best, k, nb, _tr, pane_t, pane_k = _trace(o, d, 1e30, nodes, pf, pi, tris, False, panes)
    return _surface(o, d, spread, best, k, nb, pane_t, pane_k, pf, pi, tris, shade, texels, tex_info, lut, world,
                    panes, False)


@ti.func
def _surface(o, d, spread, best, k, nb, pane_t, pane_k, pf: ti.template(), pi: ti.template(), tris: ti.template(),
             shade: ti.template(), texels: ti.template(), tex_info: ti.template(), lut: ti.template(),
             world: ti.template(), panes: ti.template(), fast: ti.template()):
    """What :func:`_shade_hit` returns, given the closest primitive hit along the ray (distance ``best``, primitive
    ``k``, −1 for none, its geometric normal ``nb`` facing the ray) and the nearest pane before it (``pane_t``,
    ``pane_k``): the room shell is tested here, then the surface met is shaded. ``fast`` (compile-time), for the
    all-sensors shading: on a triangle ``nb`` is not given but computed here (from the edges this function needs
    anyway), and the shadow-ray origin returned is the hit point itself, which the caller moves with
    :func:`_shadow_origin` only where it casts shadow rays; the values returned are otherwise the same."""
    inv = _safe_inv(d)
    t_exit = 1e30
    exit_axis = 0
    inside = 1
    for q in ti.static(range(3)):
        if o[q] < world[WORLD_ROOM_MIN + q] or o[q] > world[WORLD_ROOM_MAX + q]:
            inside = 0
        hi = ti.max((world[WORLD_ROOM_MIN + q] - o[q]) * inv[q], (world[WORLD_ROOM_MAX + q] - o[q]) * inv[q])
        if hi < t_exit:
            t_exit = hi
            exit_axis = q
    albedo = ti.Vector([0.0, 0.0, 0.0])
    n = ti.Vector([0.0, 0.0, 0.0])
    ns = ti.Vector([0.0, 0.0, 0.0])
    ps = ti.Vector([0.0, 0.0, 0.0])
    t = 0.0
    c_id = ti.cast(world[WORLD_BACKGROUND_CLASS], ti.i32)
    i_id = 0
    hit = 0
    prim = -1
    tri_pos = ti.Vector([0.0, 0.0, 0.0])
    if k >= 0 and (inside == 0 or best < t_exit * (1.0 + SHELL_TIE)):  # geometry on the shell's faces wins
        hit = 1
        prim = k
        t = best
        n = nb
        ns = nb
        ps = o + t * d
        albedo = _v3(pf, k, 6)
        c_id = pi[k, 2]
        i_id = pi[k, 3]
        if pi[k, 0] == 3:  # triangle: barycentrics of the hit (the traversal's own test, repeated once)
            j = k  # its rows of tris and shade
            v0 = _v3(tris, j, 0)
            v1 = _v3(tris, j, 3)
            v2 = _v3(tris, j, 6)
            e1 = v1 - v0
            e2 = v2 - v0
            if ti.static(fast):  # the geometric normal, facing the ray, as _closest_normal computes it
                nb = e1.cross(e2).normalized()
                if nb.dot(d) > 0:
                    nb = -nb
                n = nb
            pv = d.cross(e2)
            idet = 1.0 / e1.dot(pv)
            sv = o - v0
            b1 = sv.dot(pv) * idet
            b2 = d.dot(sv.cross(e1)) * idet
            b0 = 1.0 - b1 - b2
            ns, sgn, ps = _triangle_point(tris, shade, j, b0, b1, b2, nb, ps, ti.static(not fast))
            dl = d.norm()
            cos_v = ns.dot(d) / dl
            if cos_v > -0.02:  # a shading normal turned away from the eye: bend it back towards the eye
                ns = (ns - (cos_v + 0.02) * d / dl).normalized()
            tri_pos = ti.Vector([b1, b2, sgn])
            tex = ti.cast(shade[j, 15], ti.i32)
            if tex >= 0:
                u = b0 * shade[j, 9] + b1 * shade[j, 11] + b2 * shade[j, 13]
                v = b0 * shade[j, 10] + b1 * shade[j, 12] + b2 * shade[j, 14]
                cos_g = ti.max(ti.abs(nb.dot(d)) / dl, 1e-3)
                lod = shade[j, 16] + ti.log(ti.max(t * spread, 1e-12) / cos_g) * 1.4426950408889634
                albedo *= _texture(texels, tex_info, lut, tex, u, v, lod)
    elif inside == 1 and t_exit > T_EPS:
        hit = 1
        t = t_exit
        for q in ti.static(range(3)):
            if q == exit_axis:
                n[q] = -1.0 if d[q] > 0 else 1.0
        ns = n
        ps = o + t * d
        surf = 1
        if exit_axis == 2:
            surf = 0 if d[2] < 0 else 2
        a0 = WORLD_SHELL_ALBEDO + 3 * surf
        albedo = ti.Vector([world[a0], world[a0 + 1], world[a0 + 2]])
        if surf == 0:
            px = o[0] + t * d[0]
            py = o[1] + t * d[1]
            parity = (ti.cast(ti.floor(px / TILE_M), ti.i32) + ti.cast(ti.floor(py / TILE_M), ti.i32)) & 1
            albedo *= 1.0 + TILE_CONTRAST * (2.0 * parity - 1.0)
    pane = -1
    if ti.static(panes == PANES_TRACKED):
        if hit == 1 and pane_t < t:
            pane = pane_k
    return hit, t, n, ns, albedo, c_id, i_id, ps, prim, pane, tri_pos


@ti.func
def _triangle_point(tris: ti.template(), shade: ti.template(), k, b0, b1, b2, nb, p, moved: ti.template()):
    """The shading of triangle k's point p at barycentrics (b0, b1, b2), seen from the side its geometric normal nb
    faces: (shading normal ns, side sgn, shadow-ray origin ps). ns interpolates the vertex normals, turned to nb's
    side (sgn = 1 when the vertex normals point that way, the front; −1 from the back); ps is
    :func:`_shadow_origin` when ``moved`` (compile-time), else p itself."""
    n0 = _v3(shade, k, 0)
    n1 = _v3(shade, k, 3)
    n2 = _v3(shade, k, 6)
    sn = b0 * n0 + b1 * n1 + b2 * n2
    sgn = 1.0
    if sn.dot(nb) < 0.0:  # the vertex normals point to the other side: the back
        sgn = -1.0
    ns = nb
    ln = sn.norm()
    if ln > 1e-12:
        ns = sgn * sn / ln
    ps = p
    if ti.static(moved):
        ps = _shadow_origin(tris, shade, k, b0, b1, b2, sgn, p)
    return ns, sgn, ps


@ti.func
def _shadow_origin(tris: ti.template(), shade: ti.template(), k, b0, b1, b2, sgn, p):
    """Triangle k's point p at barycentrics (b0, b1, b2), seen from side sgn (:func:`_triangle_point`), moved onto
    the vertices' tangent planes, outwards only (Hanika's shadow-terminator fix): the origin of its shadow rays, so
    that smooth low-poly surfaces do not shadow themselves in facets."""
    n0 = _v3(shade, k, 0)
    n1 = _v3(shade, k, 3)
    n2 = _v3(shade, k, 6)
    q0 = p - _v3(tris, k, 0)
    q1 = p - _v3(tris, k, 3)
    q2 = p - _v3(tris, k, 6)
    return p - sgn * (b0 * ti.min(0.0, sgn * q0.dot(n0)) * n0 + b1 * ti.min(0.0, sgn * q1.dot(n1)) * n1
                      + b2 * ti.min(0.0, sgn * q2.dot(n2)) * n2)


@ti.func
def _lamp_map_visibility(maps: ti.template(), slot, L, q):
    """Fraction (0..1) of the four nearest texels of lamp-map ``slot`` (bilinear weights) whose depth (distance
    from the lamp L to the first occluder) reaches the point q: percentage-closer filtering of a cube shadow map."""
    R = maps.shape[1]
    w = q - L
    aw = ti.abs(w)
    ax = 0
    if aw[1] > aw[0] and aw[1] >= aw[2]:
        ax = 1
    elif aw[2] > aw[0] and aw[2] > aw[1]:
        ax = 2
    pw = _perm(w, ax)  # (u, v, major)
    m = ti.max(ti.abs(pw[2]), 1e-12)
    face = slot * 6 + 2 * ax + (1 if pw[2] < 0.0 else 0)
    fx = (pw[0] / m + 1.0) * 0.5 * R - 0.5
    fy = (pw[1] / m + 1.0) * 0.5 * R - 0.5
    x0 = ti.cast(ti.floor(fx), ti.i32)
    y0 = ti.cast(ti.floor(fy), ti.i32)
    ax_ = fx - x0
    ay_ = fy - y0
    dist = w.norm() - LAMP_MAP_BIAS_M
    vis = 0.0
    for k in ti.static(range(4)):
        xi = ti.min(ti.max(x0 + (k & 1), 0), R - 1)
        yi = ti.min(ti.max(y0 + (k >> 1), 0), R - 1)
        wgt = (ax_ if (k & 1) else 1.0 - ax_) * (ay_ if (k >> 1) else 1.0 - ay_)
        if dist <= maps[face, yi, xi]:
            vis += wgt
    return vis


@ti.func
def _sun_map_visibility(sun_map: ti.template(), lights: ti.template(), j, q):
    """Fraction (0..1) of the four nearest texels of the sun map (bilinear weights) whose first occluder is no
    higher, along the direction towards the sun (light j's vector), than the point q plus ``SUN_MAP_BIAS_M``:
    percentage-closer filtering of an orthographic shadow map. Outside the map (beyond every primitive): lit."""
    R = sun_map.shape[0]
    a = ti.Vector([lights[j, 9], lights[j, 10], lights[j, 11]])
    b = ti.Vector([lights[j, 12], lights[j, 13], lights[j, 14]])
    fx = q.dot(a) - lights[j, 15] - 0.5
    fy = q.dot(b) - lights[j, 16] - 0.5
    x0 = ti.cast(ti.floor(fx), ti.i32)
    y0 = ti.cast(ti.floor(fy), ti.i32)
    ax_ = fx - x0
    ay_ = fy - y0
    h = q.dot(ti.Vector([lights[j, 1], lights[j, 2], lights[j, 3]])) + SUN_MAP_BIAS_M
    vis = 0.0
    for k in ti.static(range(4)):
        xi = x0 + (k & 1)
        yi = y0 + (k >> 1)
        wgt = (ax_ if (k & 1) else 1.0 - ax_) * (ay_ if (k >> 1) else 1.0 - ay_)
        if xi < 0 or yi < 0 or xi >= R or yi >= R:
            vis += wgt
        elif h >= sun_map[yi, xi]:
            vis += wgt
    return vis


@ti.func
def _next_light(taken, w, m, n_always, always: ti.template(), grid: ti.template(), gx, gy, words,
                light_of_slot: ti.template()):
    """The next light of a point's list: ``always[taken]`` while taken < n_always, then the lamps whose bits are set
    in the point's cell (gx, gy) of the light grid (word w of ``grid``, m its bits not yet taken; gx < 0: none).
    Returns (the light, or −1 at the end; taken, w, m for the next call)."""
    j = -1
    if taken < n_always:
        j = always[taken]
        taken += 1
    elif gx >= 0:
        while m == 0 and w + 1 < words:
            w += 1
            m = grid[gy, gx, w]
        if m != 0:
            low = m & (-m)
            m ^= low
            j = light_of_slot[w * 32 + 31 - ti.math.clz(low)]
    return j, taken, w, m


@ti.func
def _direct(p, ng, n, key, params: ti.template(), lights: ti.template(), n_always, always: ti.template(),
            grid: ti.template(), grid_xform: ti.template(), light_of_slot: ti.template(),
            nodes: ti.template(), pf: ti.template(), pi: ti.template(), tris: ti.template(),
            maps: ti.template(), sun_map: ti.template(), shadow_rays: ti.template()):
    """Σ lights colour · n·l · attenuation · visibility at p (shading normal n; shadow rays leave from p offset
    along the geometric normal ng); visibility from ``params[P_SHADOW_SAMPLES]`` shadow rays (stratified over the light's disc),
    hashed from ``key`` — or, with one sample and a light with a map slot: a lamp's from its cube shadow map
    (:func:`_lamp_map_visibility`), the sun's from the sun map (:func:`_sun_map_visibility`). Window panes do not
    stop shadow rays, nor dim them.

    The lights summed are the ``n_always`` lights ``always`` (every light that has no shadow map, and the sun),
    then the lamps that the light grid lists for p's cell: ``grid`` (NY, NX, words) int32 holds, for each cell of
    ``grid_xform`` = [x0, y0, 1/cell (1/m), words] (cell (i, j) spans x0 + j·cell, y0 + i·cell), a bit for each
    lamp shadow-map slot s (word s // 32, bit s % 32; ``light_of_slot[s]`` its light) whose map may let it light a
    point of that cell (:func:`light_grid_kernel`); a lamp that is not listed would add exactly 0 there. Words = 0:
    no grid (the renderer then puts every light in ``always``).

    ``shadow_rays`` (compile-time): False leaves the shadow rays' code out (a BVH traversal with its per-ray stack,
    which costs a kernel that inlines it many registers), for callers whose every light has a shadow map and
    ``params[P_SHADOW_SAMPLES]`` is 1: a light that would need rays then adds nothing."""
    radiance = ti.Vector([0.0, 0.0, 0.0])
    po = p + ng * SHADOW_OFFSET
    total = ti.cast(params[P_SHADOW_SAMPLES], ti.i32)
    words = ti.cast(grid_xform[3], ti.i32)
    gx = ti.cast(ti.floor((p[0] - grid_xform[0]) * grid_xform[2]), ti.i32)
    gy = ti.cast(ti.floor((p[1] - grid_xform[1]) * grid_xform[2]), ti.i32)
    if words == 0 or gx < 0 or gy < 0 or gx >= grid.shape[1] or gy >= grid.shape[0]:
        gx = -1
    taken = 0  # of the always-lit lights
    gw = -1  # the grid word being read, and its bits not yet taken
    gm = 0
    while True:
        j, taken, gw, gm = _next_light(taken, gw, gm, n_always, always, grid, gx, gy, words, light_of_slot)
        if j < 0:
            break
        L = ti.Vector([lights[j, 1], lights[j, 2], lights[j, 3]])
        dist = 1e30
        atten = 1.0
        ok = 1
        point = lights[j, 0] > 0.5
        if point:
            Lv = L - p
            dist = Lv.norm()
            rng = lights[j, 7]
            if dist > rng or dist < 1e-6:
                ok = 0
            else:
                L = Lv / dist
                f = 1.0 - (dist / rng) ** 2
                atten = f * f / ti.max(dist * dist, 0.25)
        if ok == 1:
            ndl = n.dot(L)
            if ndl > 0:
                vis = 0.0
                reach = dist
                if point:
                    reach = ti.max(dist - LAMP_FIXTURE_M, 0.0)
                slot = -1
                if total <= 1:
                    slot = ti.cast(lights[j, 8], ti.i32)
                if slot >= 0:
                    if point:
                        texel = dist * 2.0 / ti.cast(maps.shape[1], ti.f32)  # a texel's footprint at p (m)
                        vis = _lamp_map_visibility(maps, slot,
                                                   ti.Vector([lights[j, 1], lights[j, 2], lights[j, 3]]),
                                                   po + ng * (LAMP_MAP_NORMAL_OFFSET * texel))
                    else:
                        texel = 1.0 / ti.Vector([lights[j, 9], lights[j, 10], lights[j, 11]]).norm()
                        vis = _sun_map_visibility(sun_map, lights, j, po + ng * (SUN_MAP_NORMAL_OFFSET * texel))
                if ti.static(not shadow_rays):
                    pass  # (the callers' lights all have maps)
                elif slot < 0:  # shadow rays (window panes unseen): one towards the centre, or `total` over the disc
                    rays = ti.max(total, 1)
                    t1 = ti.Vector([0.0, 0.0, 0.0])
                    t2 = ti.Vector([0.0, 0.0, 0.0])
                    rot = 0.0
                    if total > 1:
                        t1, t2 = _frame(L)
                        rot = _rand(key * 977 + j * 131 + 7)
                    for s in range(rays):
                        Ls = L
                        ds = reach
                        if total > 1:
                            rr = ti.sqrt((ti.cast(s, ti.f32) + _rand(key * 31 + j * 7919 + s * 104729 + 3))
                                         / ti.cast(total, ti.f32))
                            th = 6.2831853 * (rot + ti.cast(s, ti.f32) * 0.6180340)
                            off = rr * (ti.cos(th) * t1 + ti.sin(th) * t2)
                            if point:
                                q = L * dist + off * params[P_LAMP_RADIUS]  # towards a point of the lamp's disc
                                ds = q.norm()
                                Ls = q / ds
                                ds = ti.max(ds - LAMP_FIXTURE_M, 0.0)
                            else:
                                Ls = (L + off * params[P_SUN_RADIUS]).normalized()
                        # one traversal in the code for both cases (each call site inlines a whole traversal)
                        _t, k_sh, _n, _tr, _pt, _pk = _trace(po, Ls, ds, nodes, pf, pi, tris,
                                                             True, PANES_UNSEEN)
                        if k_sh < 0:
                            vis += 1.0
                    vis /= ti.cast(rays, ti.f32)
                radiance += ti.Vector([lights[j, 4], lights[j, 5], lights[j, 6]]) * (ndl * atten * vis)
    return radiance


@ti.func
def _ray(c, x, y):
    """The ray of pixel (x, y) of camera row c (:data:`~.layouts.CAM_LEN`): origin, unnormalised direction (map)."""
    o = ti.Vector([c[CAM_ORIGIN], c[CAM_ORIGIN + 1], c[CAM_ORIGIN + 2]])
    xc = (x - c[CAM_CX]) / c[CAM_FX]
    yc = (y - c[CAM_CY]) / c[CAM_FY]
    d = ti.Vector([
        c[CAM_R + 0] * xc + c[CAM_R + 1] * yc + c[CAM_R + 2],
        c[CAM_R + 3] * xc + c[CAM_R + 4] * yc + c[CAM_R + 5],
        c[CAM_R + 6] * xc + c[CAM_R + 7] * yc + c[CAM_R + 8],
    ])
    return o, d


@ti.kernel
def lamp_map_kernel(
    lights: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (L, 17) f32 SceneArrays.lights
    light_of_slot: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (S,) i32 SceneArrays.light_of_slot
    nodes: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (I, 16) f32 SceneArrays.nodes
    pf: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (P, 11) f32 SceneArrays.pf
    pi: ti.types.ndarray(dtype=ti.i32, ndim=2),  # (P, 4) i32 SceneArrays.pi
    tris: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (P, 9) f32 SceneArrays.tris
    lamp_maps: ti.types.ndarray(dtype=ti.f32, ndim=3),  # (6·S, R, R) f32 out: SceneArrays.lamp_maps
):
    """Cube shadow maps of point lights into ``lamp_maps`` (6·S, R, R) float32: texel (x, y) of face 2·a + (0: +a,
    1: −a) of slot s (light ``light_of_slot[s]``) holds the distance (m) from the light to the first primitive along
    the direction whose components are ``(2(x + ½)/R − 1, 2(y + ½)/R − 1, ±1)`` on the axes (a+1, a+2, a) (mod 3),
    counting only primitives beyond ``LAMP_FIXTURE_M`` (a lamp's own fixture casts no shadow, as with shadow rays)
    and within the light's range; 1e30 where there is none. The room shell and window panes cast no shadow."""
    R = lamp_maps.shape[1]
    for z, y, x in ti.ndrange(lamp_maps.shape[0], R, R):
        j = light_of_slot[z // 6]
        face = z % 6
        ax = face // 2
        sign = 1.0 - 2.0 * ti.cast(face % 2, ti.f32)
        d = _unperm(ti.Vector([(2.0 * x + 1.0) / R - 1.0, (2.0 * y + 1.0) / R - 1.0, sign]), ax).normalized()
        L = ti.Vector([lights[j, 1], lights[j, 2], lights[j, 3]])
        reach = lights[j, 7] - LAMP_FIXTURE_M
        depth = 1e30
        if reach > 0.0:
            t, k, nrm, _tr, _pt, _pk = _trace(L + d * LAMP_FIXTURE_M, d, reach, nodes, pf, pi,
                                              tris, False, PANES_UNSEEN)
            if k >= 0:
                depth = LAMP_FIXTURE_M + t
        lamp_maps[z, y, x] = depth


@ti.kernel
def light_grid_kernel(
    lights: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (L, 17) f32 SceneArrays.lights
    light_of_slot: ti.types.ndarray(dtype=ti.i32, ndim=1),  # (S,) i32 SceneArrays.light_of_slot
    lamp_maps: ti.types.ndarray(dtype=ti.f32, ndim=3),  # (6·S, R, R) f32 out: SceneArrays.lamp_maps
    grid_xform: ti.types.ndarray(dtype=ti.f32, ndim=1),  # (4,) f32 SceneArrays.grid_xform
    block: ti.i32,
    step: ti.f32,
    grid: ti.types.ndarray(dtype=ti.i32, ndim=3),  # (NY, NX, W) i32 out: the cells marked (zeros on entry)
):
    """Mark in ``grid`` (NY, NX, words) int32 (zeros on entry; cells as :func:`_direct` reads them) each cell that a
    sample of a lamp's lit region falls in: for each block of ``block`` × ``block`` texels of a cube map (:func:`
    lamp_map_kernel`'s layout), points every ``step`` m along the block's centre ray from the lamp out to the
    largest depth of the block's texels and their neighbours (plus ``LAMP_MAP_BIAS_M``), at most the lamp's range.
    A point that the map lets the lamp light lies within the block's cone up to that depth, so it lies within
    ``step / 2`` plus the cone's width there, plus the lookup's offset along the normal, of a sample: the renderer
    grows the marked cells by that much (``renderer._light_grid``)."""
    R = lamp_maps.shape[1]
    nb = (R + block - 1) // block
    for z, by, bx in ti.ndrange(lamp_maps.shape[0], nb, nb):
        slot = z // 6
        j = light_of_slot[slot]
        face = z % 6
        ax = face // 2
        sign = 1.0 - 2.0 * ti.cast(face % 2, ti.f32)
        depth = 0.0
        for y, x in ti.ndrange((ti.max(by * block - 1, 0), ti.min(by * block + block + 1, R)),
                               (ti.max(bx * block - 1, 0), ti.min(bx * block + block + 1, R))):
            depth = ti.max(depth, lamp_maps[z, y, x])
        cu = (ti.cast(bx * block, ti.f32) + 0.5 * block) * 2.0 / R - 1.0
        cv = (ti.cast(by * block, ti.f32) + 0.5 * block) * 2.0 / R - 1.0
        d = _unperm(ti.Vector([cu, cv, sign]), ax).normalized()
        L = ti.Vector([lights[j, 1], lights[j, 2], lights[j, 3]])
        reach = ti.min(depth + LAMP_MAP_BIAS_M, lights[j, 7])
        n = ti.cast(reach / step, ti.i32) + 1
        for i in range(n + 1):
            q = L + d * ti.min(ti.cast(i, ti.f32) * step, reach)
            gx = ti.cast(ti.floor((q[0] - grid_xform[0]) * grid_xform[2]), ti.i32)
            gy = ti.cast(ti.floor((q[1] - grid_xform[1]) * grid_xform[2]), ti.i32)
            if gx >= 0 and gy >= 0 and gx < grid.shape[1] and gy < grid.shape[0]:
                ti.atomic_or(grid[gy, gx, slot // 32], 1 << (slot % 32))


@ti.kernel
def sun_map_kernel(
    lights: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (L, 17) f32 SceneArrays.lights
    j: ti.i32,
    top: ti.f32,
    nodes: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (I, 16) f32 SceneArrays.nodes
    pf: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (P, 11) f32 SceneArrays.pf
    pi: ti.types.ndarray(dtype=ti.i32, ndim=2),  # (P, 4) i32 SceneArrays.pi
    tris: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (P, 9) f32 SceneArrays.tris
    sun_map: ti.types.ndarray(dtype=ti.f32, ndim=2),  # (R, R) f32 out: SceneArrays.sun_map
):
    """The orthographic shadow map of directional light j (its row's projection columns, see :data:`LIGHT_COLS`)
    into ``sun_map`` (R, R) float32: texel (x, y) holds the height ``p·l`` (l: the unit vector towards the light) of
    the first primitive p met by the ray that comes from the light through the point at texel coordinates
    (x + ½, y + ½) on the plane ``p·l = top`` (above every primitive); −1e30 where there is none. The room shell and
    window panes cast no shadow, as with shadow rays."""
    R = sun_map.shape[0]
    for y, x in ti.ndrange(R, R):
        a = ti.Vector([lights[j, 9], lights[j, 10], lights[j, 11]])
        b = ti.Vector([lights[j, 12], lights[j, 13], lights[j, 14]])
        l = ti.Vector([lights[j, 1], lights[j, 2], lights[j, 3]])
        # a / |a|² is the world vector of one texel step along a (a has length 1/texel), likewise b
        o = (x + 0.5 + lights[j, 15]) * a / a.dot(a) + (y + 0.5 + lights[j, 16]) * b / b.dot(b) + top * l
        t, k, nrm, _tr, _pt, _pk = _trace(o, -l, 1e30, nodes, pf, pi, tris, False, PANES_UNSEEN)
        height = -1e30
        if k >= 0:
            height = top - t
        sun_map[y, x] = height
