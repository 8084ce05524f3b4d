"""Taichi ray tracing of a :class:`~benchbot_sim_taichi.scene.Scene` (boxes, ellipsoids, cylinders and triangles in a
BVH, inside a room shell): RGB-D + segmentation images, planar laser scans, batched rendering of many cameras in one
kernel launch, and two modes: ``fast`` (direct lighting, shadow rays) and ``quality`` (path traced, several samples
per pixel, one diffuse bounce, OpenCV denoiser).

Importing this module imports Taichi but does not initialise it; :func:`ensure_taichi` (called by
:class:`Renderer`) runs ``ti.init`` once per process. Taichi must be used from one thread per process.

Kernels take NumPy arrays (``ti.types.ndarray``), so a scene with any number of primitives, or any image size, reuses
the compiled kernels (they are compiled once per process, not per scene). The BVH (:mod:`benchbot_sim_taichi.bvh`)
is built once per scene in NumPy and traversed in the kernels with a fixed-size stack.

Conventions: ``map`` frame, metres. Cameras use the OPTICAL frame (z forward, x right, y down); the ray of pixel
(u, v) (column, row; integer pixel centres) is ``R · K⁻¹ [u, v, 1]ᵀ`` so its parameter t is the z-depth.
Lighting: linear radiance = albedo · (ambient·(0.8 + 0.2·n_z) + Σ_lights visibility · colour · max(0, n·l) ·
attenuation), then clamped and gamma-encoded (1/2.2) to uint8. Visibility is the fraction of ``shadow_samples``
shadow rays (stratified over the light's disc — the sun's angular radius, a lamp's radius — with a per-pixel
rotation from a seeded integer hash, so renders are deterministic) that reach the light; one sample is a hard shadow
towards the light's centre.
"""



import contextlib
import math
import os
import sys
import warnings

import numpy as np

# Taichi prints its banner on stdout; stdout carries our programs' data (tables, --json), so it goes to stderr.
with contextlib.redirect_stdout(sys.stderr):
    import taichi as ti

#: Tiny direction component substituted for zero before inverting (avoids 0·inf).
DIR_EPS = 1e-12
#: Minimum hit distance of primary rays and offset of shadow-ray origins (metres).
T_EPS = 1e-4
SHADOW_OFFSET = 1e-3
#: Floor tiles (metres) and their albedo modulation.
TILE_M = 0.6
TILE_CONTRAST = 0.06
GAMMA = 1.0 / 2.2

#: Traversal stack size of the kernels (the BVH depth must stay below it).
STACK = 64
#: Default angular radius (rad) of the sun and radius (m) of the lamps, for soft shadows.
SUN_RADIUS = 0.035
LAMP_RADIUS = 0.15
#: Render modes.
MODES = ("fast", "quality")

_INIT_ARCH: str | None = None


def ensure_taichi(arch: str | None = None) -> str:
    """Initialise Taichi once per process and return the arch in use (``'cpu'`` or ``'cuda'``).

    Args:
        arch: ``'cpu'`` (default), ``'gpu'`` or ``'cuda'`` (CUDA if available, else CPU with a warning); ``None`` reads
            the environment variable ``BENCHBOT_TAICHI_ARCH``. A later call asking for another arch keeps the first
            one and warns (Taichi cannot switch without resetting every kernel and field).

    Raises:
        ValueError: an unknown arch name.
    """
    global _INIT_ARCH
    want = (arch or os.environ.get("BENCHBOT_TAICHI_ARCH") or "cpu").strip().lower()
    if want not in ("cpu", "gpu", "cuda"):
        raise ValueError(f"unknown Taichi arch {want!r}: use 'cpu', 'gpu' or 'cuda'")
    if _INIT_ARCH is not None:
        if (want == "cpu") != (_INIT_ARCH == "cpu") and not (want != "cpu" and _INIT_ARCH == "cpu-fallback"):
            warnings.warn(f"Taichi is already initialised on {_INIT_ARCH}; ignoring the request for {want}",
                          RuntimeWarning, stacklevel=2)
        return "cpu" if _INIT_ARCH.startswith("cpu") else _INIT_ARCH
    with contextlib.redirect_stdout(sys.stderr):  # "[Taichi] Starting on arch=..." is printed on stdout
        _INIT_ARCH = _init(want)
    return "cpu" if _INIT_ARCH.startswith("cpu") else _INIT_ARCH


def _init(want: str) -> str:
    """``ti.init`` for ``want`` (``cpu``/``gpu``/``cuda``); returns ``cpu``, ``cuda`` or ``cpu-fallback``."""
    if want == "cpu":
        ti.init(arch=ti.cpu, default_fp=ti.f32, offline_cache=True, log_level=ti.WARN)
        return "cpu"
    try:
        ti.init(arch=ti.cuda, default_fp=ti.f32, offline_cache=True, log_level=ti.ERROR)
        got = ti.lang.impl.current_cfg().arch
    except Exception:  # noqa: BLE001 - any CUDA failure means CPU
        got = None
    if got == ti.cuda:
        return "cuda"
    warnings.warn("CUDA is not available to Taichi; rendering on the CPU", RuntimeWarning, stacklevel=3)
    ti.init(arch=ti.cpu, default_fp=ti.f32, offline_cache=True, log_level=ti.WARN)
    return "cpu-fallback"


def intrinsics(width: int, height: int, horizontal_fov_deg: float) -> np.ndarray:
    """Pinhole K (3, 3) float64 with square pixels, ``fx = (W/2) / tan(hfov/2)``, principal point at the image
    centre ``((W-1)/2, (H-1)/2)`` (pixel centres are integers)."""
    fx = (width / 2.0) / math.tan(math.radians(horizontal_fov_deg) / 2.0)
    return np.array([[fx, 0.0, (width - 1) / 2.0], [0.0, fx, (height - 1) / 2.0], [0.0, 0.0, 1.0]])


def pack_scene(scene) -> dict:
    """The scene as the flat float32/int32 arrays the kernels read (primitives in BVH order).

    Returns:
        ``nodes_f`` (M, 6) float32 / ``nodes_i`` (M, 2) int32 BVH nodes (see :mod:`benchbot_sim_taichi.bvh`);
        ``pf`` (max(P,1), 9) float32 [min xyz, max xyz, linear albedo rgb]; ``pi`` (max(P,1), 4) int32 [kind, axis or
        triangle index, class, instance]; ``tris`` (max(T,1), 9) float32; ``lights`` (max(L,1), 8) float32 [kind,
        vec xyz, colour rgb, range]; ``world`` (19,) float32 [room min xyz, room max xyz, floor/wall/ceiling albedo
        (9), ambient rgb, background class]; ``n_prims``, ``n_lights`` ints; ``order`` (P,) the scene's primitive
        index of each packed primitive.
    """
    from benchbot_sim_taichi.bvh import build_bvh, bvh_depth

    n, nl = int(scene.prim_type.shape[0]), int(scene.light_kind.shape[0])
    nodes_f, nodes_i, order = build_bvh(scene.prim_min, scene.prim_max)
    if bvh_depth(nodes_i) >= STACK:
        raise ValueError(f"BVH too deep ({bvh_depth(nodes_i)} levels, the kernels' stack holds {STACK})")
    pf = np.zeros((max(n, 1), 9), dtype=np.float32)
    pi = np.zeros((max(n, 1), 4), dtype=np.int32)
    if n:
        obj = scene.prim_object[order]
        pf[:n, 0:3], pf[:n, 3:6], pf[:n, 6:9] = scene.prim_min[order], scene.prim_max[order], scene.prim_albedo[order]
        pi[:n, 0], pi[:n, 1] = scene.prim_type[order], scene.prim_axis[order]
        pi[:n, 2], pi[:n, 3] = scene.box_class[obj], scene.box_instance[obj]
    nt = int(scene.tri_v.shape[0])
    tris = np.zeros((max(nt, 1), 9), dtype=np.float32)
    if nt:
        tris[:nt] = scene.tri_v.reshape(nt, 9)
    lights = np.zeros((max(nl, 1), 8), dtype=np.float32)
    if nl:
        lights[:nl, 0] = scene.light_kind
        lights[:nl, 1:4], lights[:nl, 4:7], lights[:nl, 7] = scene.light_vec, scene.light_colour, scene.light_range
    world = np.concatenate([scene.room_min, scene.room_max, scene.shell_albedo.reshape(-1), scene.ambient,
                            [scene.background_class]]).astype(np.float32)
    return {"nodes_f": np.ascontiguousarray(nodes_f), "nodes_i": np.ascontiguousarray(nodes_i), "pf": pf, "pi": pi,
            "tris": tris, "lights": lights, "world": world, "n_prims": n, "n_lights": nl, "order": order}


def render_params(shadow_samples: int = 1, seed: int = 0, sun_radius: float = SUN_RADIUS,
                  lamp_radius: float = LAMP_RADIUS, spp: int = 1, bounce_gain: float = 0.0) -> np.ndarray:
    """(8,) float32 [shadow samples, sun angular radius rad, lamp radius m, seed, spp, bounce gain, 0, 0]."""
    return np.array([max(1, int(shadow_samples)), sun_radius, lamp_radius, int(seed) % (1 << 24), max(1, int(spp)),
                     bounce_gain, 0, 0], dtype=np.float32)


def camera_params(K: np.ndarray, T_map_camera: np.ndarray) -> np.ndarray:
    """(16,) float32 [R row-major (9), origin (3), fx, fy, cx, cy] for the kernels."""
    K = np.asarray(K, dtype=np.float64)
    T = np.asarray(T_map_camera, dtype=np.float64)
    return np.concatenate([T[:3, :3].reshape(-1), T[:3, 3], [K[0, 0], K[1, 1], K[0, 2], K[1, 2]]]).astype(np.float32)


# ----------------------------------------------------------------------------------------------------------- kernels
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
def _hit_prim(o, d, inv, pf: ti.template(), pi: ti.template(), tris: ti.template(), k, tmax):
    """(t, normal) of the ray's entry into primitive k if T_EPS < t < tmax, else (tmax, 0)."""
    kind = pi[k, 0]
    lo = _v3(pf, k, 0)
    hi = _v3(pf, k, 3)
    t = tmax
    n = ti.Vector([0.0, 0.0, 0.0])
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
            nl = ti.Vector([0.0, 0.0, -1.0 if D[2] > 0 else 1.0])
            if ts0 > tza:
                q = O + tn * D
                nl = ti.Vector([q[0] / R[0], q[1] / R[1], 0.0])
            n = _unperm(nl, ax).normalized()
    else:  # triangle
        j = pi[k, 1]
        v0 = _v3(tris, j, 0)
        e1 = _v3(tris, j, 3) - v0
        e2 = _v3(tris, j, 6) - v0
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
                        n = e1.cross(e2).normalized()
                        if n.dot(d) > 0:
                            n = -n
    return t, n


@ti.func
def _trace(o, d, tmax, n_prims, nodes_f: ti.template(), nodes_i: ti.template(), pf: ti.template(),
           pi: ti.template(), tris: ti.template(), any_hit: ti.template()):
    """Closest (or, with ``any_hit``, any) primitive hit with T_EPS < t < tmax: (t, k, normal); k = -1: none.
    Stackless traversal of the BVH with skip pointers."""
    inv = _safe_inv(d)
    best = tmax
    best_k = -1
    best_n = ti.Vector([0.0, 0.0, 0.0])
    n_nodes = nodes_i.shape[0] if n_prims > 0 else 0
    node = 0
    while node < n_nodes:
        a0, a1 = _slab(o, inv, _v3(nodes_f, node, 0), _v3(nodes_f, node, 3))
        if a0 <= a1 and a1 > 0.0 and a0 < best:
            cnt = nodes_i[node, 0]
            if cnt > 0:
                first = nodes_i[node, 1]
                for k in range(first, first + cnt):
                    t, n = _hit_prim(o, d, inv, pf, pi, tris, k, best)
                    if t < best:
                        best = t
                        best_k = k
                        best_n = n
                if ti.static(any_hit):
                    if best_k >= 0:
                        break
                node = nodes_i[node, 2]
            else:
                node += 1
        else:
            node = nodes_i[node, 2]
    return best, best_k, best_n


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
def _shade_hit(o, d, n_prims, nodes_f: ti.template(), nodes_i: ti.template(), pf: ti.template(), pi: ti.template(),
               tris: ti.template(), world: ti.template()):
    """First surface along the ray (objects, else the room shell): (hit, t, normal, albedo, class, instance)."""
    best, k, nb = _trace(o, d, 1e30, n_prims, nodes_f, nodes_i, pf, pi, tris, False)
    inv = _safe_inv(d)
    t_exit = 1e30
    exit_axis = 0
    inside = 1
    for q in ti.static(range(3)):
        if o[q] < world[q] or o[q] > world[3 + q]:
            inside = 0
        hi = ti.max((world[q] - o[q]) * inv[q], (world[3 + q] - o[q]) * inv[q])
        if hi < t_exit:
            t_exit = hi
            exit_axis = q
    albedo = ti.Vector([0.0, 0.0, 0.0])
    n = ti.Vector([0.0, 0.0, 0.0])
    t = 0.0
    c_id = ti.cast(world[18], ti.i32)
    i_id = 0
    hit = 0
    if k >= 0 and (inside == 0 or best < t_exit):
        hit = 1
        t = best
        n = nb
        albedo = _v3(pf, k, 6)
        c_id = pi[k, 2]
        i_id = pi[k, 3]
    elif inside == 1 and t_exit > T_EPS:
        hit = 1
        t = t_exit
        for q in ti.static(range(3)):
            if q == exit_axis:
                n[q] = -1.0 if d[q] > 0 else 1.0
        surf = 1
        if exit_axis == 2:
            surf = 0 if d[2] < 0 else 2
        albedo = ti.Vector([world[6 + 3 * surf], world[7 + 3 * surf], world[8 + 3 * surf]])
        if surf == 0:
            px = o[0] + t * d[0]
            py = o[1] + t * d[1]
            parity = (ti.cast(ti.floor(px / TILE_M), ti.i32) + ti.cast(ti.floor(py / TILE_M), ti.i32)) & 1
            albedo *= 1.0 + TILE_CONTRAST * (2.0 * parity - 1.0)
    return hit, t, n, albedo, c_id, i_id


@ti.func
def _direct(p, n, key, ns, s0, params: ti.template(), lights: ti.template(), n_lights, n_prims,
            nodes_f: ti.template(), nodes_i: ti.template(), pf: ti.template(), pi: ti.template(), tris: ti.template()):
    """Σ lights colour · n·l · attenuation · visibility at p (normal n); visibility from ``ns`` shadow rays
    (strata s0 .. s0+ns-1 of ``params[0]``), hashed from ``key``."""
    radiance = ti.Vector([0.0, 0.0, 0.0])
    po = p + n * SHADOW_OFFSET
    total = ti.cast(params[0], ti.i32)
    for j in range(n_lights):
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
                if total <= 1:
                    if _trace(po, L, dist, n_prims, nodes_f, nodes_i, pf, pi, tris, True)[1] < 0:
                        vis = 1.0
                else:
                    t1, t2 = _frame(L)
                    rot = _rand(key * 977 + j * 131 + 7)
                    for s in range(s0, s0 + ns):
                        rr = ti.sqrt((ti.cast(s, ti.f32) + _rand(key * 31 + j * 7919 + s * 104729 + 3))
                                     / ti.cast(total, ti.f32))
                        th = 6.2831853 * (rot + ti.cast(s, ti.f32) * 0.6180340)
                        off = rr * (ti.cos(th) * t1 + ti.sin(th) * t2)
                        Ls = L
                        ds = dist
                        if point:
                            q = L * dist + off * params[2]  # towards a point of the lamp's disc
                            ds = q.norm()
                            Ls = q / ds
                        else:
                            Ls = (L + off * params[1]).normalized()
                        if _trace(po, Ls, ds, n_prims, nodes_f, nodes_i, pf, pi, tris, True)[1] < 0:
                            vis += 1.0
                    vis /= ti.cast(ns, ti.f32)
                radiance += ti.Vector([lights[j, 4], lights[j, 5], lights[j, 6]]) * (ndl * atten * vis)
    return radiance


@ti.func
def _ray(cams: ti.template(), b, x, y):
    o = ti.Vector([cams[b, 9], cams[b, 10], cams[b, 11]])
    xc = (x - cams[b, 14]) / cams[b, 12]
    yc = (y - cams[b, 15]) / cams[b, 13]
    d = ti.Vector([
        cams[b, 0] * xc + cams[b, 1] * yc + cams[b, 2],
        cams[b, 3] * xc + cams[b, 4] * yc + cams[b, 5],
        cams[b, 6] * xc + cams[b, 7] * yc + cams[b, 8],
    ])
    return o, d


@ti.kernel
def _render_kernel(
    cams: ti.types.ndarray(dtype=ti.f32, ndim=2),
    nodes_f: ti.types.ndarray(dtype=ti.f32, ndim=2),
    nodes_i: ti.types.ndarray(dtype=ti.i32, ndim=2),
    pf: ti.types.ndarray(dtype=ti.f32, ndim=2),
    pi: ti.types.ndarray(dtype=ti.i32, ndim=2),
    tris: ti.types.ndarray(dtype=ti.f32, ndim=2),
    n_prims: ti.i32,
    lights: ti.types.ndarray(dtype=ti.f32, ndim=2),
    n_lights: ti.i32,
    world: ti.types.ndarray(dtype=ti.f32, ndim=1),
    params: ti.types.ndarray(dtype=ti.f32, ndim=1),
    rgb: ti.types.ndarray(dtype=ti.u8, ndim=4),
    depth: ti.types.ndarray(dtype=ti.f32, ndim=3),
    cls: ti.types.ndarray(dtype=ti.i32, ndim=3),
    inst: ti.types.ndarray(dtype=ti.i32, ndim=3),
):
    B = depth.shape[0]
    H = depth.shape[1]
    W = depth.shape[2]
    for b, v, u in ti.ndrange(B, H, W):
        o, d = _ray(cams, b, ti.cast(u, ti.f32), ti.cast(v, ti.f32))
        hit, t, n, albedo, c_id, i_id = _shade_hit(o, d, n_prims, nodes_f, nodes_i, pf, pi, tris, world)
        if hit == 1:
            p = o + t * d
            key = (v * W + u) * 65536 + ti.cast(params[3], ti.i32)
            radiance = ti.Vector([world[15], world[16], world[17]]) * (0.8 + 0.2 * n[2])
            radiance += _direct(p, n, key, ti.cast(params[0], ti.i32), 0, params, lights, n_lights, n_prims,
                                nodes_f, nodes_i, pf, pi, tris)
            c = albedo * radiance
            for k in ti.static(range(3)):
                x = ti.min(ti.max(c[k], 0.0), 1.0)
                rgb[b, v, u, k] = ti.cast(ti.pow(x, GAMMA) * 255.0 + 0.5, ti.u8)
            depth[b, v, u] = t
        else:
            for k in ti.static(range(3)):
                rgb[b, v, u, k] = ti.cast(0, ti.u8)
            depth[b, v, u] = 0.0
        cls[b, v, u] = c_id
        inst[b, v, u] = i_id


@ti.kernel
def _quality_kernel(
    cams: ti.types.ndarray(dtype=ti.f32, ndim=2),
    nodes_f: ti.types.ndarray(dtype=ti.f32, ndim=2),
    nodes_i: ti.types.ndarray(dtype=ti.i32, ndim=2),
    pf: ti.types.ndarray(dtype=ti.f32, ndim=2),
    pi: ti.types.ndarray(dtype=ti.i32, ndim=2),
    tris: ti.types.ndarray(dtype=ti.f32, ndim=2),
    n_prims: ti.i32,
    lights: ti.types.ndarray(dtype=ti.f32, ndim=2),
    n_lights: ti.i32,
    world: ti.types.ndarray(dtype=ti.f32, ndim=1),
    params: ti.types.ndarray(dtype=ti.f32, ndim=1),
    out: ti.types.ndarray(dtype=ti.f32, ndim=4),
):
    """Path-traced linear radiance (B, H, W, 3): ``params[4]`` samples per pixel (jittered in the pixel), each with
    one stratum of the soft-shadow samples per light, and one cosine-sampled diffuse bounce (direct light and
    ambient at the bounce point, scaled by ``params[5]``)."""
    B = out.shape[0]
    H = out.shape[1]
    W = out.shape[2]
    spp = ti.cast(params[4], ti.i32)
    for b, v, u in ti.ndrange(B, H, W):
        acc = ti.Vector([0.0, 0.0, 0.0])
        base = (v * W + u) * 65536 + ti.cast(params[3], ti.i32)
        for s in range(spp):
            key = base * 131 + s * 7
            o, d = _ray(cams, b, ti.cast(u, ti.f32) + _rand(key + 1) - 0.5, ti.cast(v, ti.f32) + _rand(key + 2) - 0.5)
            hit, t, n, albedo, c_id, i_id = _shade_hit(o, d, n_prims, nodes_f, nodes_i, pf, pi, tris, world)
            if hit == 1:
                p = o + t * d
                amb = ti.Vector([world[15], world[16], world[17]]) * (0.8 + 0.2 * n[2])
                rad = amb * (1.0 - 0.5 * params[5]) + _direct(p, n, base, 1, s % ti.max(1, ti.cast(params[0], ti.i32)),
                                                              params, lights, n_lights, n_prims, nodes_f, nodes_i,
                                                              pf, pi, tris)
                # one diffuse bounce (cosine-weighted hemisphere)
                t1, t2 = _frame(n)
                r1 = _rand(key + 3)
                r2 = _rand(key + 4)
                rr = ti.sqrt(r1)
                dn = (rr * ti.cos(6.2831853 * r2) * t1 + rr * ti.sin(6.2831853 * r2) * t2
                      + ti.sqrt(ti.max(0.0, 1.0 - r1)) * n)
                po = p + n * SHADOW_OFFSET
                h2, t_2, n2, alb2, c2, i2 = _shade_hit(po, dn, n_prims, nodes_f, nodes_i, pf, pi, tris, world)
                if h2 == 1:
                    p2 = po + t_2 * dn
                    amb2 = ti.Vector([world[15], world[16], world[17]]) * (0.8 + 0.2 * n2[2])
                    rad += params[5] * alb2 * (amb2 + _direct(p2, n2, key + 5, 1, s % ti.max(1, ti.cast(params[0], ti.i32)),
                                                              params, lights, n_lights, n_prims, nodes_f, nodes_i,
                                                              pf, pi, tris))
                acc += albedo * rad
        acc /= ti.cast(spp, ti.f32)
        for k in ti.static(range(3)):
            out[b, v, u, k] = acc[k]


@ti.kernel
def _scan_kernel(
    origin: ti.types.ndarray(dtype=ti.f32, ndim=1),
    angles: ti.types.ndarray(dtype=ti.f32, ndim=1),
    nodes_f: ti.types.ndarray(dtype=ti.f32, ndim=2),
    nodes_i: ti.types.ndarray(dtype=ti.i32, ndim=2),
    pf: ti.types.ndarray(dtype=ti.f32, ndim=2),
    pi: ti.types.ndarray(dtype=ti.i32, ndim=2),
    tris: ti.types.ndarray(dtype=ti.f32, ndim=2),
    n_prims: ti.i32,
    world: ti.types.ndarray(dtype=ti.f32, ndim=1),
    ranges: ti.types.ndarray(dtype=ti.f32, ndim=1),
):
    for b in range(angles.shape[0]):
        a = angles[b]
        d = ti.Vector([ti.cos(a), ti.sin(a), 0.0])
        o = ti.Vector([origin[0], origin[1], origin[2]])
        best, k, n = _trace(o, d, 1e30, n_prims, nodes_f, nodes_i, pf, pi, tris, False)
        inv = _safe_inv(d)
        tx = ti.max((world[0] - o[0]) * inv[0], (world[3] - o[0]) * inv[0])
        ty = ti.max((world[1] - o[1]) * inv[1], (world[4] - o[1]) * inv[1])
        ranges[b] = ti.min(best, ti.min(tx, ty))


# ---------------------------------------------------------------------------------------------------------- renderer
class Renderer:
    """Renders one scene at a time with Taichi. Use from a single thread.

    Args:
        arch: see :func:`ensure_taichi` (``None``: ``BENCHBOT_TAICHI_ARCH`` or ``'cpu'``).
        shadow_samples: shadow rays per light and pixel in ``fast`` mode (1: hard shadows; more: soft shadows over
            the light's disc).
        seed: seeds the sampling patterns (same seed → bit-identical images).
    """

    def __init__(self, arch: str | None = None, *, shadow_samples: int = 1, seed: int = 0) -> None:
        self.arch = ensure_taichi(arch)
        self._packed: dict | None = None
        self.shadow_samples = int(shadow_samples)
        self.seed = int(seed)

    def set_scene(self, scene) -> None:
        """Upload ``scene`` (a :class:`~benchbot_sim_taichi.scene.Scene`); builds its BVH. Later renders and scans
        use it."""
        self._packed = pack_scene(scene)

    def _need_scene(self) -> dict:
        if self._packed is None:
            raise RuntimeError("Renderer.set_scene() has not been called")
        return self._packed

    def _args(self):
        s = self._need_scene()
        return (s["nodes_f"], s["nodes_i"], s["pf"], s["pi"], s["tris"], s["n_prims"], s["lights"], s["n_lights"],
                s["world"])

    def render_batch(self, K: np.ndarray, T_map_cameras, width: int, height: int) -> dict[str, np.ndarray]:
        """Render B views of the scene in ONE kernel launch (``fast`` mode).

        Args:
            K: (3, 3) intrinsics shared by the views. T_map_cameras: (B, 4, 4) optical-frame poses.

        Returns:
            as :meth:`render` with a leading batch axis: ``rgb`` (B, H, W, 3) uint8, ``depth`` (B, H, W) float32,
            ``class``/``instance`` (B, H, W) int32.
        """
        return self._render_fast(K, T_map_cameras, width, height, lit=True)

    def _render_fast(self, K, T_map_cameras, width: int, height: int, *, lit: bool) -> dict[str, np.ndarray]:
        """:meth:`render_batch`; ``lit=False`` skips the lights (no shadow rays: RGB is ambient only) for callers
        that only keep depth and segmentation, which do not depend on the lights."""
        Ts = np.asarray(T_map_cameras, dtype=np.float64).reshape(-1, 4, 4)
        B, H, W = Ts.shape[0], int(height), int(width)
        cams = np.ascontiguousarray(np.stack([camera_params(K, T) for T in Ts]).reshape(B, 16))
        rgb = np.zeros((B, H, W, 3), dtype=np.uint8)
        depth = np.zeros((B, H, W), dtype=np.float32)
        cls = np.zeros((B, H, W), dtype=np.int32)
        inst = np.zeros((B, H, W), dtype=np.int32)
        if B:
            args = list(self._args())
            if not lit:
                args[7] = 0  # n_lights
            _render_kernel(cams, *args, render_params(self.shadow_samples, self.seed), rgb, depth, cls, inst)
        return {"rgb": rgb, "depth": depth, "class": cls, "instance": inst}

    def render(self, K: np.ndarray, T_map_camera: np.ndarray, width: int, height: int,
               mode: str = "fast", spp: int = 16, denoise: bool = True) -> dict[str, np.ndarray]:
        """Render one view.

        Args:
            K: (3, 3) pinhole intrinsics (pixels). T_map_camera: (4, 4) pose of the camera's OPTICAL frame in ``map``.
            width, height: image size in pixels.
            mode: ``'fast'`` (default) or ``'quality'`` (RGB path traced with ``spp`` samples per pixel, soft
                shadows, one diffuse bounce, then OpenCV's non-local-means denoiser if ``denoise``; depth and
                segmentation as in ``fast``).

        Returns:
            ``{'rgb': (H, W, 3) uint8 RGB, 'depth': (H, W) float32 z-depth metres (0 = no hit), 'class': (H, W)
            int32 class ids (background where the shell or nothing is hit), 'instance': (H, W) int32
            ``class*1000+instance`` ids (0 = background)}``.
        """
        if mode not in MODES:
            raise ValueError(f"unknown render mode {mode!r}: use one of {MODES}")
        # quality mode replaces the RGB, so its fast pass only needs depth and segmentation: no lights
        batch = self._render_fast(K, np.asarray(T_map_camera)[None], width, height, lit=mode == "fast")
        out = {k: v[0] for k, v in batch.items()}
        if mode == "quality":
            H, W = int(height), int(width)
            lin = np.zeros((1, H, W, 3), dtype=np.float32)
            params = render_params(max(spp, 1), self.seed, spp=spp, bounce_gain=0.6)
            _quality_kernel(camera_params(K, T_map_camera)[None].copy(), *self._args(), params, lin)
            img = np.floor(np.power(np.clip(lin[0], 0.0, 1.0), GAMMA) * 255.0 + 0.5).astype(np.uint8)
            if denoise:
                import cv2

                img = cv2.cvtColor(cv2.fastNlMeansDenoisingColored(cv2.cvtColor(img, cv2.COLOR_RGB2BGR), None, 3, 3,
                                                                   5, 15), cv2.COLOR_BGR2RGB)
            out["rgb"] = img
        return out

    def scan(self, T_map_lidar: np.ndarray, angles: np.ndarray) -> np.ndarray:
        """Planar laser ranges.

        Args:
            T_map_lidar: (4, 4) lidar pose (x forward, z up); beams lie in the map's horizontal plane at its height,
                at ``angles`` (rad, about the lidar's z from its +x; the lidar is assumed level).
            angles: (N,) beam angles, radians.

        Returns:
            (N,) float64 distances (metres) to the first primitive or wall hit (no clipping).
        """
        s = self._need_scene()
        T = np.asarray(T_map_lidar, dtype=np.float64)
        yaw = math.atan2(T[1, 0], T[0, 0])
        world_angles = (np.asarray(angles, dtype=np.float64) + yaw).astype(np.float32)
        out = np.zeros(world_angles.shape[0], dtype=np.float32)
        if out.size:
            _scan_kernel(T[:3, 3].astype(np.float32), world_angles, s["nodes_f"], s["nodes_i"], s["pf"], s["pi"],
                         s["tris"], s["n_prims"], s["world"], out)
        return out.astype(np.float64)
