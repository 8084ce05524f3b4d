"""Taichi ray casting of a box :class:`~benchbot_sim_taichi.scene.Scene`: RGB-D + segmentation images and planar laser
scans.

Importing this module imports Taichi but does not initialise it; :func:`ensure_taichi` (called by
:class:`Renderer`) runs ``ti.init`` once per process. Taichi must be used from one thread per process.

Kernels take NumPy arrays (``ti.types.ndarray``), so a scene with any number of boxes, or any image size, reuses the
compiled kernels (they are compiled once per process, not per scene).

Conventions: ``map`` frame, metres. Cameras use the OPTICAL frame (z forward, x right, y down); the ray of pixel
(u, v) (column, row; integer pixel centres) is ``R · K⁻¹ [u, v, 1]ᵀ`` so its parameter t is the z-depth.
Lighting: linear radiance = albedo · (ambient·(0.8 + 0.2·n_z) + Σ_lights visible · colour · max(0, n·l) ·
attenuation), then clamped and gamma-encoded (1/2.2) to uint8.
"""



import math
import os
import warnings

import numpy as np
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

#: Kind code of point lights in the packed light table (see :mod:`benchbot_sim_taichi.scene`).
LIGHT_POINT_KIND = 1

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
    if want == "cpu":
        ti.init(arch=ti.cpu, default_fp=ti.f32, offline_cache=True, log_level=ti.WARN)
        _INIT_ARCH = "cpu"
    else:
        try:
            ti.init(arch=ti.cuda, default_fp=ti.f32, offline_cache=True, log_level=ti.ERROR)
            got = ti.lang.impl.current_cfg().arch
        except Exception:  # noqa: BLE001 - any CUDA failure means CPU
            got = None
        if got == ti.cuda:
            _INIT_ARCH = "cuda"
        else:
            warnings.warn("CUDA is not available to Taichi; rendering on the CPU", RuntimeWarning, stacklevel=2)
            ti.init(arch=ti.cpu, default_fp=ti.f32, offline_cache=True, log_level=ti.WARN)
            _INIT_ARCH = "cpu-fallback"
    return "cpu" if _INIT_ARCH.startswith("cpu") else _INIT_ARCH


def intrinsics(width: int, height: int, horizontal_fov_deg: float) -> np.ndarray:
    """Pinhole K (3, 3) float64 with square pixels, ``fx = (W/2) / tan(hfov/2)``, principal point at the image
    centre ``((W-1)/2, (H-1)/2)`` (pixel centres are integers)."""
    fx = (width / 2.0) / math.tan(math.radians(horizontal_fov_deg) / 2.0)
    return np.array([[fx, 0.0, (width - 1) / 2.0], [0.0, fx, (height - 1) / 2.0], [0.0, 0.0, 1.0]])


def pack_scene(scene) -> dict[str, np.ndarray]:
    """The scene as the flat float32/int32 arrays the kernels read.

    Returns:
        ``boxes`` (max(N,1), 9) float32 [min xyz, max xyz, linear albedo rgb]; ``ids`` (max(N,1), 2) int32
        [class, instance]; ``lights`` (max(L,1), 8) float32 [kind, vec xyz, colour rgb, range]; ``world`` (19,)
        float32 [room min xyz, room max xyz, floor/wall/ceiling albedo (9), ambient rgb, background class];
        ``n_boxes``, ``n_lights`` ints; ``light_boxes`` (max(L,1), max(N,1)) int32 and ``light_count`` (max(L,1),)
        int32: per light, the boxes that can shadow it; ``corners`` (N, 8, 3) float64 box corners.
    """
    n, nl = scene.n_boxes, int(scene.light_kind.shape[0])
    boxes = np.zeros((max(n, 1), 9), dtype=np.float32)
    ids = np.zeros((max(n, 1), 2), dtype=np.int32)
    if n:
        boxes[:n, 0:3], boxes[:n, 3:6], boxes[:n, 6:9] = scene.box_min, scene.box_max, scene.box_albedo
        ids[:n, 0], ids[:n, 1] = scene.box_class, scene.box_instance
    lights = np.zeros((max(nl, 1), 8), dtype=np.float32)
    if nl:
        lights[:nl, 0] = scene.light_kind
        lights[:nl, 1:4], lights[:nl, 4:7], lights[:nl, 7] = scene.light_vec, scene.light_colour, scene.light_range
    # per light, the boxes that can shadow it: all for directional lights; for point lights the boxes that come
    # within the light's range (points farther than the range get no light from it)
    light_boxes = np.zeros((max(nl, 1), max(n, 1)), dtype=np.int32)
    light_count = np.zeros(max(nl, 1), dtype=np.int32)
    for j in range(nl):
        if scene.light_kind[j] == LIGHT_POINT_KIND and n:
            q = np.clip(scene.light_vec[j], scene.box_min, scene.box_max)
            near = np.nonzero(np.linalg.norm(q - scene.light_vec[j], axis=1) <= scene.light_range[j] + 1e-3)[0]
        else:
            near = np.arange(n)
        light_boxes[j, : near.size] = near
        light_count[j] = near.size
    world = np.concatenate([scene.room_min, scene.room_max, scene.shell_albedo.reshape(-1), scene.ambient,
                            [scene.background_class]]).astype(np.float32)
    return {"boxes": np.ascontiguousarray(boxes), "ids": np.ascontiguousarray(ids),
            "lights": np.ascontiguousarray(lights), "world": world, "n_boxes": n, "n_lights": nl,
            "light_boxes": light_boxes, "light_count": light_count,
            "corners": _corners(boxes[:n, 0:3], boxes[:n, 3:6])}


def _corners(bmin: np.ndarray, bmax: np.ndarray) -> np.ndarray:
    """(N, 8, 3) float64 corners of boxes."""
    sel = np.array([[i & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)], dtype=bool)
    return np.where(sel[None], bmax[:, None, :], bmin[:, None, :]).astype(np.float64)


def frustum_boxes(packed: dict, K: np.ndarray, T_map_camera: np.ndarray, width: int, height: int) -> np.ndarray:
    """Indices (M,) int32 of the boxes that may be hit by a camera ray (a box is dropped only when its 8 corners all
    lie outside one side of the view frustum widened by one pixel; the side planes pass through the camera centre, so
    the test is exact for convex boxes, whichever side of the camera they are on)."""
    c = packed["corners"]
    if c.shape[0] == 0:
        return np.zeros(0, dtype=np.int32)
    T = np.asarray(T_map_camera, dtype=np.float64)
    K = np.asarray(K, dtype=np.float64)
    pc = (c - T[:3, 3]) @ T[:3, :3]  # (N, 8, 3) in the optical frame
    x, y, z = pc[..., 0], pc[..., 1], pc[..., 2]
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    u0, u1, v0, v1 = -1.0, width, -1.0, height
    out = (np.all(z <= 0.0, axis=1)
           | np.all(fx * x < (u0 - cx) * z, axis=1) | np.all(fx * x > (u1 - cx) * z, axis=1)
           | np.all(fy * y < (v0 - cy) * z, axis=1) | np.all(fy * y > (v1 - cy) * z, axis=1))
    return np.nonzero(~out)[0].astype(np.int32)


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
def _box_entry(o, inv, boxes: ti.template(), i):
    """(t_near, t_far, entry axis) of the ray with box i."""
    tn = -1e30
    tf = 1e30
    axis = 0
    for k in ti.static(range(3)):
        t1 = (boxes[i, k] - o[k]) * inv[k]
        t2 = (boxes[i, 3 + k] - o[k]) * inv[k]
        lo = ti.min(t1, t2)
        hi = ti.max(t1, t2)
        if lo > tn:
            tn = lo
            axis = k
        tf = ti.min(tf, hi)
    return tn, tf, axis


@ti.func
def _occluded(p, L, dist, boxes: ti.template(), light_boxes: ti.template(), j, count):
    inv = _safe_inv(L)
    hit = 0
    for k in range(count):
        i = light_boxes[j, k]
        tn, tf, axis = _box_entry(p, inv, boxes, i)
        if tn <= tf and tf > T_EPS and tn < dist:
            hit = 1
            break
    return hit


@ti.kernel
def _render_kernel(
    cam: ti.types.ndarray(dtype=ti.f32, ndim=1),
    boxes: ti.types.ndarray(dtype=ti.f32, ndim=2),
    ids: ti.types.ndarray(dtype=ti.i32, ndim=2),
    prim: ti.types.ndarray(dtype=ti.i32, ndim=1),
    n_prim: ti.i32,
    lights: ti.types.ndarray(dtype=ti.f32, ndim=2),
    n_lights: ti.i32,
    light_boxes: ti.types.ndarray(dtype=ti.i32, ndim=2),
    light_count: ti.types.ndarray(dtype=ti.i32, ndim=1),
    world: ti.types.ndarray(dtype=ti.f32, ndim=1),
    rgb: ti.types.ndarray(dtype=ti.u8, ndim=3),
    depth: ti.types.ndarray(dtype=ti.f32, ndim=2),
    cls: ti.types.ndarray(dtype=ti.i32, ndim=2),
    inst: ti.types.ndarray(dtype=ti.i32, ndim=2),
):
    H = depth.shape[0]
    W = depth.shape[1]
    for v, u in ti.ndrange(H, W):
        o = ti.Vector([cam[9], cam[10], cam[11]])
        xc = (ti.cast(u, ti.f32) - cam[14]) / cam[12]
        yc = (ti.cast(v, ti.f32) - cam[15]) / cam[13]
        d = ti.Vector([
            cam[0] * xc + cam[1] * yc + cam[2],
            cam[3] * xc + cam[4] * yc + cam[5],
            cam[6] * xc + cam[7] * yc + cam[8],
        ])
        inv = _safe_inv(d)
        best = 1e30
        best_i = -1
        best_axis = 0
        for kk in range(n_prim):
            i = prim[kk]
            tn, tf, axis = _box_entry(o, inv, boxes, i)
            if tn <= tf and tn > T_EPS and tn < best:
                best = tn
                best_i = i
                best_axis = axis
        # room shell: exit face of the room box
        t_exit = 1e30
        exit_axis = 0
        inside = 1
        for k in ti.static(range(3)):
            if o[k] < world[k] or o[k] > world[3 + k]:
                inside = 0
            t1 = (world[k] - o[k]) * inv[k]
            t2 = (world[3 + k] - o[k]) * inv[k]
            hi = ti.max(t1, t2)
            if hi < t_exit:
                t_exit = hi
                exit_axis = k
        albedo = ti.Vector([0.0, 0.0, 0.0])
        n = ti.Vector([0.0, 0.0, 0.0])
        t = 0.0
        c_id = ti.cast(world[18], ti.i32)
        i_id = 0
        hit = 0
        if best_i >= 0 and (inside == 0 or best < t_exit):
            hit = 1
            t = best
            n[best_axis] = -1.0 if d[best_axis] > 0 else 1.0
            albedo = ti.Vector([boxes[best_i, 6], boxes[best_i, 7], boxes[best_i, 8]])
            c_id = ids[best_i, 0]
            i_id = ids[best_i, 1]
        elif inside == 1 and t_exit > T_EPS:
            hit = 1
            t = t_exit
            n[exit_axis] = -1.0 if d[exit_axis] > 0 else 1.0
            surf = 1
            if exit_axis == 2:
                surf = 0 if d[2] < 0 else 2
            albedo = ti.Vector([world[6 + 3 * surf], world[7 + 3 * surf], world[8 + 3 * surf]])
            if surf == 0:
                px = o[0] + t * d[0]
                py = o[1] + t * d[1]
                parity = (ti.cast(ti.floor(px / TILE_M), ti.i32) + ti.cast(ti.floor(py / TILE_M), ti.i32)) & 1
                albedo *= 1.0 + TILE_CONTRAST * (2.0 * parity - 1.0)
        if hit == 1:
            p = o + t * d
            amb = ti.Vector([world[15], world[16], world[17]]) * (0.8 + 0.2 * n[2])
            radiance = amb
            po = p + n * SHADOW_OFFSET
            for j in range(n_lights):
                L = ti.Vector([lights[j, 1], lights[j, 2], lights[j, 3]])
                dist = 1e30
                atten = 1.0
                ok = 1
                if lights[j, 0] > 0.5:
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
                        if _occluded(po, L, dist, boxes, light_boxes, j, light_count[j]) == 0:
                            radiance += ti.Vector([lights[j, 4], lights[j, 5], lights[j, 6]]) * (ndl * atten)
            c = albedo * radiance
            for k in ti.static(range(3)):
                x = ti.min(ti.max(c[k], 0.0), 1.0)
                rgb[v, u, k] = ti.cast(ti.pow(x, GAMMA) * 255.0 + 0.5, ti.u8)
            depth[v, u] = t
        else:
            for k in ti.static(range(3)):
                rgb[v, u, k] = ti.cast(0, ti.u8)
            depth[v, u] = 0.0
        cls[v, u] = c_id
        inst[v, u] = i_id


@ti.kernel
def _scan_kernel(
    origin: ti.types.ndarray(dtype=ti.f32, ndim=1),
    angles: ti.types.ndarray(dtype=ti.f32, ndim=1),
    boxes: ti.types.ndarray(dtype=ti.f32, ndim=2),
    n_boxes: ti.i32,
    world: ti.types.ndarray(dtype=ti.f32, ndim=1),
    ranges: ti.types.ndarray(dtype=ti.f32, ndim=1),
):
    for b in range(angles.shape[0]):
        a = angles[b]
        d = ti.Vector([ti.cos(a), ti.sin(a)])
        inv = ti.Vector([0.0, 0.0])
        for k in ti.static(range(2)):
            e = d[k]
            if ti.abs(e) < DIR_EPS:
                e = DIR_EPS
            inv[k] = 1.0 / e
        ox = origin[0]
        oy = origin[1]
        oz = origin[2]
        best = 1e30
        for i in range(n_boxes):
            if boxes[i, 2] <= oz and oz <= boxes[i, 5]:
                tx1 = (boxes[i, 0] - ox) * inv[0]
                tx2 = (boxes[i, 3] - ox) * inv[0]
                ty1 = (boxes[i, 1] - oy) * inv[1]
                ty2 = (boxes[i, 4] - oy) * inv[1]
                tn = ti.max(ti.min(tx1, tx2), ti.min(ty1, ty2))
                tf = ti.min(ti.max(tx1, tx2), ti.max(ty1, ty2))
                if tn <= tf and tn > T_EPS and tn < best:
                    best = tn
        tx = ti.max((world[0] - ox) * inv[0], (world[3] - ox) * inv[0])
        ty = ti.max((world[1] - oy) * inv[1], (world[4] - oy) * inv[1])
        best = ti.min(best, ti.min(tx, ty))
        ranges[b] = best


# ---------------------------------------------------------------------------------------------------------- renderer
class Renderer:
    """Renders one scene at a time with Taichi. Use from a single thread.

    Args:
        arch: see :func:`ensure_taichi` (``None``: ``BENCHBOT_TAICHI_ARCH`` or ``'cpu'``).
    """

    def __init__(self, arch: str | None = None) -> None:
        self.arch = ensure_taichi(arch)
        self._packed: dict | None = None

    def set_scene(self, scene) -> None:
        """Upload ``scene`` (a :class:`~benchbot_sim_taichi.scene.Scene`); later renders and scans use it."""
        self._packed = pack_scene(scene)

    def _need_scene(self) -> dict:
        if self._packed is None:
            raise RuntimeError("Renderer.set_scene() has not been called")
        return self._packed

    def render(self, K: np.ndarray, T_map_camera: np.ndarray, width: int, height: int) -> dict[str, np.ndarray]:
        """Render one view.

        Args:
            K: (3, 3) pinhole intrinsics (pixels). T_map_camera: (4, 4) pose of the camera's OPTICAL frame in ``map``.
            width, height: image size in pixels.

        Returns:
            ``{'rgb': (H, W, 3) uint8 RGB, 'depth': (H, W) float32 z-depth metres (0 = no hit), 'class': (H, W)
            int32 class ids (background where the shell or nothing is hit), 'instance': (H, W) int32
            ``class*1000+instance`` ids (0 = background)}``.
        """
        s = self._need_scene()
        H, W = int(height), int(width)
        rgb = np.zeros((H, W, 3), dtype=np.uint8)
        depth = np.zeros((H, W), dtype=np.float32)
        cls = np.zeros((H, W), dtype=np.int32)
        inst = np.zeros((H, W), dtype=np.int32)
        prim = frustum_boxes(s, K, T_map_camera, W, H)
        n_prim = int(prim.shape[0])
        if n_prim == 0:
            prim = np.zeros(1, dtype=np.int32)
        _render_kernel(camera_params(K, T_map_camera), s["boxes"], s["ids"], prim, n_prim, s["lights"],
                       s["n_lights"], s["light_boxes"], s["light_count"], s["world"], rgb, depth, cls, inst)
        return {"rgb": rgb, "depth": depth, "class": cls, "instance": inst}

    def scan(self, T_map_lidar: np.ndarray, angles: np.ndarray) -> np.ndarray:
        """Planar laser ranges.

        Args:
            T_map_lidar: (4, 4) lidar pose (x forward, z up); beams lie in the map's horizontal plane at its height,
                at ``angles`` (rad, about the lidar's z from its +x; the lidar is assumed level).
            angles: (N,) beam angles, radians.

        Returns:
            (N,) float64 distances (metres) to the first box or wall hit (no clipping).
        """
        s = self._need_scene()
        T = np.asarray(T_map_lidar, dtype=np.float64)
        yaw = math.atan2(T[1, 0], T[0, 0])
        world_angles = (np.asarray(angles, dtype=np.float64) + yaw).astype(np.float32)
        out = np.zeros(world_angles.shape[0], dtype=np.float32)
        if out.size:
            _scan_kernel(T[:3, 3].astype(np.float32), world_angles, s["boxes"], s["n_boxes"], s["world"], out)
        return out.astype(np.float64)
