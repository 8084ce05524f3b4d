"""Taichi ray tracing of a :class:`~benchbot_sim_taichi.scene.Scene` (boxes, ellipsoids, cylinders and triangles in a
BVH, inside a room shell): RGB-D + segmentation images, planar laser scans, batched rendering of many cameras in one
kernel launch, and two modes: ``fast`` (direct lighting, shadow rays) and ``quality`` (path traced, several samples
per pixel, one diffuse bounce, OpenCV denoiser).

Importing this module imports Taichi but does not initialise it; :func:`ensure_taichi` (called by
:class:`Renderer`) runs ``ti.init`` once per process. Taichi must be used from one thread per process.

One kernel launch computes every sensor of a frame (or of a batch of B frames): the camera pixels (RGB, depth, class
and instance ids) and the laser beams are two parallel loops of :func:`_sensors_kernel`. Kernels take
``ti.types.ndarray`` arguments, so a scene with any number of primitives, or any image size, reuses the compiled
kernels (compiled once per process, not per scene). On CUDA (``device_buffers``) the scene is uploaded once as
``ti.ndarray`` and the outputs stay in reused device buffers; each launch goes through a compiled ``ti.graph`` with the
camera and lidar pose passed by value, so the per-frame cost is one launch plus, when wanted, one copy to the host.
The BVH (:mod:`benchbot_sim_taichi.bvh`) is built once per scene in NumPy and traversed stacklessly (skip pointers).

Conventions: ``map`` frame, metres. Cameras use the OPTICAL frame (z forward, x right, y down); the ray of pixel
(u, v) (column, row; integer pixel centres) is ``R · K⁻¹ [u, v, 1]ᵀ`` so its parameter t is the z-depth.
Lighting: linear radiance = albedo · (ambient·(0.8 + 0.2·n_z) + Σ_lights visibility · colour · max(0, n·l) ·
attenuation), then clamped and gamma-encoded (1/2.2) to uint8 through a table (:func:`gamma_table`). Visibility is the fraction of ``shadow_samples``
shadow rays (stratified over the light's disc — the sun's angular radius, a lamp's radius — with a per-pixel
rotation from a seeded integer hash, so renders are deterministic) that reach the light; one sample is a hard shadow
towards the light's centre.
"""



import contextlib
import functools
import gc
import math
import os
import sys
import threading
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
            the environment variable ``BENCHBOT_TAICHI_ARCH``. On the CPU, ``BENCHBOT_TAICHI_THREADS`` caps the
            threads (default: one per core). A later call asking for another arch keeps the first
            one and warns (Taichi cannot switch without resetting every kernel and field).

    Raises:
        ValueError: an unknown arch name, or a ``BENCHBOT_TAICHI_THREADS`` that is not a positive integer.
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
    if _INIT_ARCH == "cuda" and threading.current_thread() is not threading.main_thread():
        # The CUDA context is current only on this thread: release Taichi here when this thread ends, or the
        # interpreter's exit (on the main thread) would synchronise a context it does not hold and abort.
        _THIS_THREAD.release = _ReleaseTaichiAtThreadExit()
    return "cpu" if _INIT_ARCH.startswith("cpu") else _INIT_ARCH


_THIS_THREAD = threading.local()


class _ReleaseTaichiAtThreadExit:
    """Held in the Taichi thread's thread-local storage; Python drops it on that thread as the thread ends."""

    def __del__(self) -> None:
        global _INIT_ARCH, _SENSORS_GRAPH
        try:
            ti.reset()  # frees every ndarray; after it, dropping an ndarray frees nothing, on any thread
        finally:
            _INIT_ARCH, _SENSORS_GRAPH = None, None
            with _RETIRE_LOCK:
                _DEVICE_ARRAYS.clear()
                _RETIRED.clear()


def _init(want: str) -> str:
    """``ti.init`` for ``want`` (``cpu``/``gpu``/``cuda``); returns ``cpu``, ``cuda`` or ``cpu-fallback``."""
    if want == "cpu":
        ti.init(arch=ti.cpu, default_fp=ti.f32, offline_cache=True, log_level=ti.WARN, **_cpu_threads())
        return "cpu"
    try:
        ti.init(arch=ti.cuda, default_fp=ti.f32, offline_cache=True, log_level=ti.ERROR)
        got = ti.lang.impl.current_cfg().arch
    except Exception:  # noqa: BLE001 - any CUDA failure means CPU
        got = None
    if got == ti.cuda:
        return "cuda"
    warnings.warn("CUDA is not available to Taichi; rendering on the CPU", RuntimeWarning, stacklevel=3)
    ti.init(arch=ti.cpu, default_fp=ti.f32, offline_cache=True, log_level=ti.WARN, **_cpu_threads())
    return "cpu-fallback"


def _cpu_threads() -> dict:
    """``{'cpu_max_num_threads': n}`` from ``BENCHBOT_TAICHI_THREADS`` (set by batch workers so that N parallel
    episodes share the cores instead of each starting one thread per core), else ``{}`` (Taichi's default: all)."""
    value = os.environ.get("BENCHBOT_TAICHI_THREADS", "").strip()
    if not value:
        return {}
    try:
        n = int(value)
    except ValueError:
        n = 0
    if n < 1:
        raise ValueError(f"BENCHBOT_TAICHI_THREADS={value!r}: use a positive integer (threads per process)")
    return {"cpu_max_num_threads": n}


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


#: Length of one frame's pose row for :func:`_sensors_kernel` (see :func:`sensor_pose`).
POSE_LEN = 16


def sensor_pose(T_map_camera: np.ndarray | None, T_map_lidar: np.ndarray | None) -> np.ndarray:
    """(16,) float32 [camera R row-major (9), camera origin (3), lidar x, y, z, yaw] (map frame; the camera in its
    optical frame; the lidar assumed level, its yaw read from its x axis). A missing sensor's entries are zero."""
    out = np.zeros(POSE_LEN, dtype=np.float64)
    if T_map_camera is not None:
        T = np.asarray(T_map_camera, dtype=np.float64)
        out[:9], out[9:12] = T[:3, :3].reshape(-1), T[:3, 3]
    if T_map_lidar is not None:
        T = np.asarray(T_map_lidar, dtype=np.float64)
        out[12:15], out[15] = T[:3, 3], math.atan2(T[1, 0], T[0, 0])
    return out.astype(np.float32)


#: Entries of the gamma-encoding table and where it starts in :func:`frame_constants`.
GAMMA_STEPS = 4096
FRAME_CONSTS = 31


@functools.lru_cache(maxsize=1)
def gamma_table() -> np.ndarray:
    """(GAMMA_STEPS,) float64 (cached: do not modify): entry i is the 8-bit value of linear radiance (i / (GAMMA_STEPS − 1))², i.e. the
    table is indexed by the square root of the radiance (nearly linear in the output, so the nearest entry is
    within one 8-bit level of ``round(255 · x^(1/2.2))``; a table lookup costs far less than ``pow`` per channel)."""
    s = np.linspace(0.0, 1.0, GAMMA_STEPS)
    return np.floor(np.power(s * s, GAMMA) * 255.0 + 0.5)


def frame_constants(world: np.ndarray, params: np.ndarray, K: np.ndarray | None) -> np.ndarray:
    """(31 + GAMMA_STEPS,) float32 [world (19, see :func:`pack_scene`), render params (8, see
    :func:`render_params`), fx, fy, cx, cy, gamma table (see :func:`gamma_table`)] — what :func:`_sensors_kernel`
    reads besides the scene and the poses (zeros for K when None)."""
    k = np.zeros(4) if K is None else np.asarray(K, dtype=np.float64)[[0, 1, 0, 1], [0, 1, 2, 2]]
    return np.concatenate([world, params, k, gamma_table()]).astype(np.float32)


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
def _ray(c, x, y):
    o = ti.Vector([c[9], c[10], c[11]])
    xc = (x - c[14]) / c[12]
    yc = (y - c[15]) / c[13]
    d = ti.Vector([
        c[0] * xc + c[1] * yc + c[2],
        c[3] * xc + c[4] * yc + c[5],
        c[6] * xc + c[7] * yc + c[8],
    ])
    return o, d


@ti.func
def _scan_beam(o, a, n_prims, nodes_f: ti.template(), nodes_i: ti.template(), pf: ti.template(), pi: ti.template(),
               tris: ti.template(), world: ti.template()):
    """Range (m) along the horizontal beam from o at map-frame angle a to the first primitive or wall."""
    d = ti.Vector([ti.cos(a), ti.sin(a), 0.0])
    best, k, n = _trace(o, d, 1e30, n_prims, nodes_f, nodes_i, pf, pi, tris, False)
    inv = _safe_inv(d)
    tx = ti.max((world[0] - o[0]) * inv[0], (world[3] - o[0]) * inv[0])
    ty = ti.max((world[1] - o[1]) * inv[1], (world[4] - o[1]) * inv[1])
    return ti.min(best, ti.min(tx, ty))


@ti.kernel
def _sensors_kernel(
    table: ti.types.ndarray(dtype=ti.f32, ndim=2),
    pose0: ti.types.vector(POSE_LEN, ti.f32),
    one: ti.i32,
    images: ti.i32,
    beams: ti.types.ndarray(dtype=ti.f32, ndim=1),
    n_beams: ti.i32,
    nodes_f: ti.types.ndarray(dtype=ti.f32, ndim=2),
    nodes_i: ti.types.ndarray(dtype=ti.i32, ndim=2),
    pf: ti.types.ndarray(dtype=ti.f32, ndim=2),
    pi: ti.types.ndarray(dtype=ti.i32, ndim=2),
    tris: ti.types.ndarray(dtype=ti.f32, ndim=2),
    n_prims: ti.i32,
    lights: ti.types.ndarray(dtype=ti.f32, ndim=2),
    n_lights: ti.i32,
    consts: ti.types.ndarray(dtype=ti.f32, ndim=1),
    rgb: ti.types.ndarray(dtype=ti.u8, ndim=4),
    depth: ti.types.ndarray(dtype=ti.f32, ndim=3),
    cls: ti.types.ndarray(dtype=ti.i32, ndim=3),
    inst: ti.types.ndarray(dtype=ti.i32, ndim=3),
    ranges: ti.types.ndarray(dtype=ti.f32, ndim=2),
):
    """One launch (two parallel loops) for B sensor frames: fast-mode images (when ``images`` is 1) into rgb/depth/cls/inst (B, H, W)
    and ``n_beams`` laser beams per frame into ``ranges`` (B, ≥ n_beams), beam j at map-frame angle
    ``beams[j] + yaw``. Frame b's pose (see :func:`sensor_pose`) is ``pose0`` (by value: no upload) when ``one``
    is 1, else row b of ``table`` (B, POSE_LEN). ``consts`` is :func:`frame_constants`."""
    B = depth.shape[0]
    H = depth.shape[1]
    W = depth.shape[2]
    for b, v, u in ti.ndrange(B * images, H, W):
        q = pose0
        if one == 0:
            for k in ti.static(range(12)):
                q[k] = table[b, k]
        c = ti.Vector([q[0], q[1], q[2], q[3], q[4], q[5], q[6], q[7], q[8], q[9], q[10], q[11],
                       consts[27], consts[28], consts[29], consts[30]])
        params = ti.Vector([consts[19 + k] for k in ti.static(range(8))])
        o, d = _ray(c, ti.cast(u, ti.f32), ti.cast(v, ti.f32))
        hit, t, n, albedo, c_id, i_id = _shade_hit(o, d, n_prims, nodes_f, nodes_i, pf, pi, tris, consts)
        if hit == 1:
            p = o + t * d
            key = (v * W + u) * 65536 + ti.cast(params[3], ti.i32)
            radiance = ti.Vector([consts[15], consts[16], consts[17]]) * (0.8 + 0.2 * n[2])
            radiance += _direct(p, n, key, ti.cast(params[0], ti.i32), 0, params, lights, n_lights, n_prims,
                                nodes_f, nodes_i, pf, pi, tris)
            col = albedo * radiance
            for k in ti.static(range(3)):
                x = ti.min(ti.max(col[k], 0.0), 1.0)
                rgb[b, v, u, k] = ti.cast(consts[FRAME_CONSTS + ti.cast(ti.sqrt(x) * (GAMMA_STEPS - 1) + 0.5, ti.i32)],
                                          ti.u8)
            depth[b, v, u] = t
        else:
            for k in ti.static(range(3)):
                rgb[b, v, u, k] = ti.cast(0, ti.u8)
            depth[b, v, u] = 0.0
        cls[b, v, u] = c_id
        inst[b, v, u] = i_id
    for b, k in ti.ndrange(B, n_beams):
        q = pose0
        if one == 0:
            for m in ti.static(range(12, POSE_LEN)):
                q[m] = table[b, m]
        ranges[b, k] = _scan_beam(ti.Vector([q[12], q[13], q[14]]), beams[k] + q[15], n_prims, nodes_f, nodes_i,
                                  pf, pi, tris, consts)


@ti.kernel
def _quality_kernel(
    cam: ti.types.vector(16, ti.f32),
    nodes_f: ti.types.ndarray(dtype=ti.f32, ndim=2),
    nodes_i: ti.types.ndarray(dtype=ti.i32, ndim=2),
    pf: ti.types.ndarray(dtype=ti.f32, ndim=2),
    pi: ti.types.ndarray(dtype=ti.i32, ndim=2),
    tris: ti.types.ndarray(dtype=ti.f32, ndim=2),
    n_prims: ti.i32,
    lights: ti.types.ndarray(dtype=ti.f32, ndim=2),
    n_lights: ti.i32,
    world: ti.types.ndarray(dtype=ti.f32, ndim=1),
    params: ti.types.vector(8, ti.f32),
    out: ti.types.ndarray(dtype=ti.f32, ndim=4),
):
    """Path-traced linear radiance (B, H, W, 3) of camera ``cam`` (B = 1): ``params[4]`` samples per pixel (jittered in the pixel), each with
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
            o, d = _ray(cam, ti.cast(u, ti.f32) + _rand(key + 1) - 0.5, ti.cast(v, ti.f32) + _rand(key + 2) - 0.5)
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


#: Parameters of :func:`_sensors_kernel`, in order: (name, kind, dtype, ndim) with kind ``nd`` (ndarray), ``sc``
#: (scalar) or ``vec`` (by-value vector of POSE_LEN).
_SENSORS_ARGS = (
    ("table", "nd", "f32", 2), ("pose0", "vec", "f32", 0), ("one", "sc", "i32", 0), ("images", "sc", "i32", 0),
    ("beams", "nd", "f32", 1), ("n_beams", "sc", "i32", 0), ("nodes_f", "nd", "f32", 2), ("nodes_i", "nd", "i32", 2),
    ("pf", "nd", "f32", 2), ("pi", "nd", "i32", 2), ("tris", "nd", "f32", 2), ("n_prims", "sc", "i32", 0),
    ("lights", "nd", "f32", 2), ("n_lights", "sc", "i32", 0), ("consts", "nd", "f32", 1), ("rgb", "nd", "u8", 4),
    ("depth", "nd", "f32", 3), ("cls", "nd", "i32", 3), ("inst", "nd", "i32", 3), ("ranges", "nd", "f32", 2),
)
_SENSORS_GRAPH = None


def _sensors_graph():
    """:func:`_sensors_kernel` as a compiled Taichi compute graph (``ti.graph``), built once per process. Running
    the graph sets the arguments in C++ and costs a fraction of a Python kernel call's per-argument work, which is
    most of the time of a one-camera frame on a GPU. Graph arguments must be Taichi ndarrays (device buffers)."""
    global _SENSORS_GRAPH
    if _SENSORS_GRAPH is None:
        kinds = {"nd": ti.graph.ArgKind.NDARRAY, "sc": ti.graph.ArgKind.SCALAR, "vec": ti.graph.ArgKind.MATRIX}
        dtypes = {"f32": ti.f32, "i32": ti.i32, "u8": ti.u8}
        symbols = []
        for name, kind, dtype, ndim in _SENSORS_ARGS:
            extra = {"ndim": ndim} if kind == "nd" else {}
            dt = ti.types.vector(POSE_LEN, ti.f32) if kind == "vec" else dtypes[dtype]
            symbols.append(ti.graph.Arg(kinds[kind], name, dtype=dt, **extra))
        builder = ti.graph.GraphBuilder()
        builder.dispatch(_sensors_kernel, *symbols)
        _SENSORS_GRAPH = builder.compile()
        # Compiling made placeholder ndarrays that are left in reference cycles; collect them now, on Taichi's
        # thread: if the collector found them later on another thread, freeing them would abort a CUDA process.
        gc.collect()
    return _SENSORS_GRAPH


# ---------------------------------------------------------------------------------------------------------- renderer
#: Keys of the packed scene that the kernels read (uploaded once per scene when buffers live on the device).
_SCENE_ARRAYS = ("nodes_f", "nodes_i", "pf", "pi", "tris", "lights", "world")


# Taichi ndarrays must be freed on Taichi's thread: on CUDA the context is current only there, and freeing GPU
# memory from any other thread aborts the process (CUDA_ERROR_INVALID_CONTEXT). A Renderer may be dropped on any
# thread (or collected there by the cyclic garbage collector), so the ndarrays it makes are also held here; a dropped
# Renderer's arrays are retired, and retired arrays are released by :func:`_free_retired` on Taichi's thread once
# nothing else refers to them.
_DEVICE_ARRAYS: dict[int, object] = {}
_RETIRED: list = []
_RETIRE_LOCK = threading.Lock()


def _new_device_array(dtype, shape: tuple):
    """A new Taichi ndarray of ``dtype`` (NumPy dtype: uint8, int32 or float32) and ``shape`` (zeroed), in the arch's
    memory (GPU memory on CUDA), held until :func:`_retire`. Call on Taichi's thread."""
    arr = ti.ndarray(dtype={np.dtype(np.uint8): ti.u8, np.dtype(np.float32): ti.f32,
                            np.dtype(np.int32): ti.i32}[np.dtype(dtype)], shape=tuple(shape))
    _DEVICE_ARRAYS[id(arr)] = arr
    return arr


def _retire(arrays) -> None:
    """Mark ``arrays`` (ndarrays from :func:`_new_device_array`) as no longer used; any thread may call this."""
    with _RETIRE_LOCK:
        for arr in arrays:
            held = _DEVICE_ARRAYS.pop(id(arr), None)
            if held is not None:
                _RETIRED.append(held)


def _references(obj) -> int:
    return sys.getrefcount(obj)


#: What :func:`_references` reports, in the comprehension of :func:`_free_retired`, for an object that only a list
#: refers to (measured, as it differs between Python versions).
_ONLY_LISTED = [_references(obj) for obj in [object()]][0]


def _free_retired() -> int:
    """Release the retired ndarrays that only the retired list still refers to (call on Taichi's thread); returns
    how many remain retired because something else still refers to them."""
    if not _RETIRED:
        return 0
    with _RETIRE_LOCK:
        keep = [arr for arr in _RETIRED if _references(arr) > _ONLY_LISTED]
        freed, _RETIRED[:] = list(_RETIRED), keep
    del freed  # the last references of the others go here, on this thread
    return len(keep)


def _empty_outputs(B: int, H: int, W: int) -> dict:
    return {"rgb": np.zeros((B, H, W, 3), np.uint8), "depth": np.zeros((B, H, W), np.float32),
            "class": np.zeros((B, H, W), np.int32), "instance": np.zeros((B, H, W), np.int32)}


class Renderer:
    """Renders one scene at a time with Taichi. Use from a single thread.

    Args:
        arch: see :func:`ensure_taichi` (``None``: ``BENCHBOT_TAICHI_ARCH`` or ``'cpu'``).
        shadow_samples: shadow rays per light and pixel in ``fast`` mode (1: hard shadows; more: soft shadows over
            the light's disc).
        seed: seeds the sampling patterns (same seed → bit-identical images).
        device_buffers: keep the scene and the output images in Taichi ndarrays, i.e. in GPU memory on CUDA, so a
            launch copies nothing between host and device (``None``: on CUDA only). On the CPU, NumPy arrays are
            already shared with the kernels, so the default there passes them directly.
    """

    def __init__(self, arch: str | None = None, *, shadow_samples: int = 1, seed: int = 0,
                 device_buffers: bool | None = None) -> None:
        self.arch = ensure_taichi(arch)
        self._packed: dict | None = None
        self._scene_args: tuple | None = None
        self.shadow_samples = int(shadow_samples)
        self.seed = int(seed)
        self.device_buffers = (self.arch == "cuda") if device_buffers is None else bool(device_buffers)
        self._buffers: dict = {}
        self._uploaded: dict = {}
        self._consts_key: tuple | None = None
        self._consts = None
        self._scene_arrays: list = []

    def __del__(self) -> None:
        # may run on any thread: the device arrays are only retired here, and freed later on Taichi's thread
        try:
            _retire(list(getattr(self, "_buffers", {}).values()) + getattr(self, "_scene_arrays", []))
        except (TypeError, AttributeError):  # at interpreter exit this module's globals may already be None
            pass

    def close(self) -> None:
        """Release the GPU memory of this renderer now (call on the thread that renders); it cannot render
        afterwards until :meth:`set_scene` is called again."""
        _retire(list(self._buffers.values()) + self._scene_arrays)
        self._buffers, self._uploaded, self._scene_arrays = {}, {}, []
        self._packed = self._scene_args = self._consts = self._consts_key = None
        _free_retired()

    def set_scene(self, scene) -> None:
        """Upload ``scene`` (a :class:`~benchbot_sim_taichi.scene.Scene`); builds its BVH. Later renders and scans
        use it. With device buffers, this is the only host-to-device copy of the scene."""
        _free_retired()
        self._packed = pack_scene(scene)
        _retire(self._scene_arrays)
        arrays = {k: self._packed[k] for k in _SCENE_ARRAYS}
        if self.device_buffers:
            for k, a in arrays.items():
                arrays[k] = _new_device_array(a.dtype, a.shape)
                arrays[k].from_numpy(np.ascontiguousarray(a))
        self._scene_arrays = [arrays[k] for k in _SCENE_ARRAYS] if self.device_buffers else []
        self._scene_args = (arrays["nodes_f"], arrays["nodes_i"], arrays["pf"], arrays["pi"], arrays["tris"],
                            self._packed["n_prims"], arrays["lights"], self._packed["n_lights"], arrays["world"])

    def _need_scene(self) -> dict:
        if self._packed is None:
            raise RuntimeError("Renderer.set_scene() has not been called")
        return self._packed

    def _args(self) -> tuple:
        self._need_scene()
        return self._scene_args

    def _buffer(self, name: str, shape: tuple, dtype) -> object:
        """The output/input buffer ``name`` of ``shape``: a reused Taichi ndarray with device buffers, else a new
        NumPy array."""
        if not self.device_buffers:
            return np.zeros(shape, dtype=dtype)
        key = (name, shape)
        if key not in self._buffers:
            self._buffers[key] = _new_device_array(dtype, shape)
        return self._buffers[key]

    def _upload(self, name: str, a: np.ndarray, *, cached: bool = False) -> object:
        """``a`` where the kernels read it: copied into a reused device buffer, or ``a`` itself. ``cached``: skip
        the copy when the buffer already holds these values (beam angles, which rarely change)."""
        a = np.ascontiguousarray(a)
        if not self.device_buffers:
            return a
        buf = self._buffer(name, a.shape, a.dtype.type)
        if cached and np.array_equal(self._uploaded.get(name), a):
            return buf
        buf.from_numpy(a)
        self._uploaded[name] = a.copy() if cached else None
        return buf

    def _frame_constants(self, K) -> object:
        """:func:`frame_constants` for ``K`` and the current render settings, rebuilt (and uploaded) only when they
        change."""
        key = (None if K is None else np.asarray(K, dtype=np.float64).tobytes(), self.shadow_samples, self.seed,
               id(self._packed))
        if self._consts_key != key:
            params = render_params(self.shadow_samples, self.seed)
            self._consts = self._upload("consts", frame_constants(self._packed["world"], params, K))
            self._consts_key = key
        return self._consts

    def sync(self) -> None:
        """Wait for every launched kernel to finish (launches on CUDA are asynchronous; copies to the host wait
        by themselves)."""
        ti.sync()

    def render_sensors(self, K: np.ndarray, T_map_cameras, width: int, height: int, T_map_lidars=None,
                       angles: np.ndarray | None = None, *, to_host: bool = True) -> dict:
        """Render B camera views (``fast`` mode) and, optionally, B planar laser scans, all in ONE kernel launch.

        Args:
            K: (3, 3) intrinsics shared by the views. T_map_cameras: (B, 4, 4) optical-frame poses in ``map``.
            width, height: image size, pixels.
            T_map_lidars: (B, 4, 4) lidar poses (x forward, z up, assumed level), or ``None`` for no scans.
            angles: (N,) beam angles (rad, about each lidar's z from its +x); required with ``T_map_lidars``.
            to_host: return NumPy arrays (copied from the GPU on CUDA). ``False`` leaves the outputs where the
                kernel wrote them — Taichi ndarrays in GPU memory with device buffers (``.to_numpy()`` copies one),
                NumPy arrays otherwise — and returns without waiting for the GPU (see :meth:`sync`); such device
                outputs are overwritten by the next call of the same sizes.

        Returns:
            ``rgb`` (B, H, W, 3) uint8, ``depth`` (B, H, W) float32 z-depth metres, ``class``/``instance``
            (B, H, W) int32 (as :meth:`render`), and with lidars ``ranges`` (B, N) float32 metres.

        Raises:
            ValueError: lidars without angles, or a lidar count different from the camera count.
        """
        Ts = np.asarray(T_map_cameras, dtype=np.float64).reshape(-1, 4, 4)
        Tl = None
        if T_map_lidars is not None:
            if angles is None:
                raise ValueError("render_sensors: T_map_lidars needs angles")
            Tl = np.asarray(T_map_lidars, dtype=np.float64).reshape(-1, 4, 4)
            if Tl.shape[0] != Ts.shape[0]:
                raise ValueError(f"render_sensors: {Tl.shape[0]} lidar poses for {Ts.shape[0]} camera poses")
        out = self._launch(K, Ts, int(width), int(height), Tl, angles, lit=True)
        if to_host and self.device_buffers:
            out = {k: (v if isinstance(v, np.ndarray) else v.to_numpy()) for k, v in out.items()}
        return out

    def render_batch(self, K: np.ndarray, T_map_cameras, width: int, height: int) -> dict[str, np.ndarray]:
        """Render B views of the scene in ONE kernel launch (``fast`` mode).

        Args:
            K: (3, 3) intrinsics shared by the views. T_map_cameras: (B, 4, 4) optical-frame poses.

        Returns:
            as :meth:`render` with a leading batch axis: ``rgb`` (B, H, W, 3) uint8, ``depth`` (B, H, W) float32,
            ``class``/``instance`` (B, H, W) int32 (NumPy arrays).
        """
        return self.render_sensors(K, T_map_cameras, width, height)

    def _launch(self, K, Ts, W: int, H: int, Tl, angles, *, lit: bool) -> dict:
        """One :func:`_sensors_kernel` launch: images for the (B, 4, 4) camera poses ``Ts`` (none if ``K`` is None),
        scans for the lidar poses ``Tl`` (none if None) at beam ``angles``. Outputs stay in the renderer's buffers.
        ``lit=False`` skips the lights (no shadow rays: RGB is ambient only) for callers that only keep depth and
        segmentation, which do not depend on the lights."""
        packed = self._need_scene()
        if _RETIRED:
            _free_retired()
        images = K is not None
        B = Ts.shape[0] if images else Tl.shape[0]
        n_beams = 0 if Tl is None else int(np.asarray(angles).size)
        if B == 0 or (Tl is not None and n_beams == 0):  # nothing to launch: empty NumPy outputs
            out = _empty_outputs(B, H, W) if images else {}
            if Tl is not None:
                out["ranges"] = np.zeros((B, 0), np.float32)
            return out
        shape = (B, H, W) if images else (1, 1, 1)
        out = {"rgb": self._buffer("rgb", shape + (3,), np.uint8), "depth": self._buffer("depth", shape, np.float32),
               "class": self._buffer("class", shape, np.int32), "instance": self._buffer("instance", shape, np.int32)}
        ranges = self._buffer("ranges", (B, max(n_beams, 1)), np.float32)
        poses = [sensor_pose(Ts[b] if images else None, None if Tl is None else Tl[b]) for b in range(B)]
        if B == 1:  # the pose travels by value: no upload (an upload costs a device round trip on CUDA)
            table, pose0, one = self._buffer("no_table", (1, POSE_LEN), np.float32), poses[0], 1
        else:
            table, pose0, one = self._upload("poses", np.stack(poses)), np.zeros(POSE_LEN, np.float32), 0
        beams = self._upload("beams", np.asarray(angles if n_beams else [0.0], dtype=np.float32).reshape(-1),
                             cached=True)
        consts = self._frame_constants(K)
        s = self._args()
        values = (table, pose0, one, int(images), beams, n_beams, s[0], s[1], s[2], s[3], s[4], s[5], s[6],
                  s[7] if lit else 0, consts, out["rgb"], out["depth"], out["class"], out["instance"], ranges)
        if self.device_buffers:  # every array is a Taichi ndarray: launch through the compiled graph
            values = (ti.Vector(v.tolist()) if name == "pose0" else v for (name, *_), v in zip(_SENSORS_ARGS, values))
            _sensors_graph().run(dict(zip((a[0] for a in _SENSORS_ARGS), values)))
        else:
            _sensors_kernel(*values)
        if not images:
            out = {}
        if Tl is not None:
            out["ranges"] = ranges
        return out

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
        batch = self._launch(K, np.asarray(T_map_camera, dtype=np.float64)[None], int(width), int(height), None, None,
                             lit=mode == "fast")
        out = {k: (v if isinstance(v, np.ndarray) else v.to_numpy())[0] for k, v in batch.items()}
        if mode == "quality":
            H, W = int(height), int(width)
            lin = self._buffer("quality", (1, H, W, 3), np.float32)
            params = render_params(max(spp, 1), self.seed, spp=spp, bounce_gain=0.6)
            _quality_kernel(camera_params(K, T_map_camera), *self._args(), params, lin)
            lin = lin.to_numpy() if self.device_buffers else lin
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
        angles = np.asarray(angles, dtype=np.float64).reshape(-1)
        ranges = self._launch(None, None, 1, 1, np.asarray(T_map_lidar, dtype=np.float64)[None], angles,
                              lit=False)["ranges"]
        return (ranges if isinstance(ranges, np.ndarray) else ranges.to_numpy())[0, :angles.size].astype(np.float64)
