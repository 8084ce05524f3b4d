"""A straightforward NumPy implementation of the renderer's ray casting and laser scan (same rays, same shading), used
to test the Taichi kernels. Slow; float64. Shapes and units as in :meth:`Renderer.render` / :meth:`Renderer.scan`.
"""

from __future__ import annotations

import math

import numpy as np

from benchbot_sim_taichi.renderer import DIR_EPS, GAMMA, SHADOW_OFFSET, T_EPS, TILE_CONTRAST, TILE_M, pack_scene


def _safe(d: np.ndarray) -> np.ndarray:
    d = d.copy()
    d[np.abs(d) < DIR_EPS] = DIR_EPS
    return d


def _entry(o, inv, bmin, bmax):
    t1 = (bmin - o) * inv
    t2 = (bmax - o) * inv
    lo, hi = np.minimum(t1, t2), np.maximum(t1, t2)
    axis = np.argmax(lo, axis=-1)  # first maximum, as the kernel's strict '>' keeps the first
    return lo.max(axis=-1), hi.min(axis=-1), axis


def render_reference(scene, K: np.ndarray, T_map_camera: np.ndarray, width: int, height: int) -> dict:
    """Same outputs as :meth:`benchbot_sim_taichi.renderer.Renderer.render`, computed with NumPy."""
    s = pack_scene(scene)
    boxes, ids, lights, world = (s["boxes"].astype(np.float64), s["ids"], s["lights"].astype(np.float64),
                                 s["world"].astype(np.float64))
    nb, nl = s["n_boxes"], s["n_lights"]
    K = np.asarray(K, dtype=np.float64)
    T = np.asarray(T_map_camera, dtype=np.float64)
    v, u = np.mgrid[0:height, 0:width]
    xc = (u.ravel() - K[0, 2]) / K[0, 0]
    yc = (v.ravel() - K[1, 2]) / K[1, 1]
    d = np.stack([xc, yc, np.ones_like(xc)], axis=1) @ T[:3, :3].T
    o = T[:3, 3]
    P = d.shape[0]
    inv = 1.0 / _safe(d)
    best = np.full(P, 1e30)
    best_i = np.full(P, -1)
    best_axis = np.zeros(P, dtype=int)
    for i in range(nb):
        tn, tf, ax = _entry(o, inv, boxes[i, 0:3], boxes[i, 3:6])
        m = (tn <= tf) & (tn > T_EPS) & (tn < best)
        best[m], best_i[m], best_axis[m] = tn[m], i, ax[m]
    th = np.maximum((world[0:3] - o) * inv, (world[3:6] - o) * inv)
    exit_axis = np.argmin(th, axis=1)
    t_exit = th.min(axis=1)
    inside = bool(np.all(o >= world[0:3]) and np.all(o <= world[3:6]))
    use_box = (best_i >= 0) & ((not inside) | (best < t_exit))
    use_shell = (~use_box) & inside & (t_exit > T_EPS)
    hit = use_box | use_shell
    t = np.where(use_box, best, np.where(use_shell, t_exit, 0.0))
    axis = np.where(use_box, best_axis, exit_axis)
    n = np.zeros((P, 3))
    n[np.arange(P), axis] = np.where(d[np.arange(P), axis] > 0, -1.0, 1.0)
    albedo = np.zeros((P, 3))
    cls = np.full(P, int(world[18]), dtype=np.int32)
    inst = np.zeros(P, dtype=np.int32)
    bi = np.where(use_box, best_i, 0)
    albedo[use_box] = boxes[bi[use_box], 6:9]
    cls[use_box] = ids[bi[use_box], 0]
    inst[use_box] = ids[bi[use_box], 1]
    surf = np.where(exit_axis == 2, np.where(d[:, 2] < 0, 0, 2), 1)
    shell_alb = world[6:15].reshape(3, 3)[surf]
    p = o + t[:, None] * d
    parity = (np.floor(p[:, 0] / TILE_M).astype(int) + np.floor(p[:, 1] / TILE_M).astype(int)) & 1
    floor_mod = np.where(surf == 0, 1.0 + TILE_CONTRAST * (2.0 * parity - 1.0), 1.0)
    albedo[use_shell] = (shell_alb * floor_mod[:, None])[use_shell]
    radiance = world[15:18][None, :] * (0.8 + 0.2 * n[:, 2:3])
    po = p + n * SHADOW_OFFSET
    for j in range(nl):
        if lights[j, 0] > 0.5:
            Lv = lights[j, 1:4] - p
            dist = np.linalg.norm(Lv, axis=1)
            rng = lights[j, 7]
            ok = (dist <= rng) & (dist >= 1e-6)
            L = Lv / np.maximum(dist, 1e-12)[:, None]
            f = 1.0 - (dist / rng) ** 2
            atten = f * f / np.maximum(dist * dist, 0.25)
        else:
            L = np.broadcast_to(lights[j, 1:4], (P, 3))
            dist = np.full(P, 1e30)
            ok = np.ones(P, dtype=bool)
            atten = np.ones(P)
        ndl = np.einsum("ij,ij->i", n, L)
        lit = ok & (ndl > 0) & hit
        inv_l = 1.0 / _safe(np.array(L, dtype=np.float64))
        occ = np.zeros(P, dtype=bool)
        for i in range(nb):
            tn, tf, _ = _entry(po, inv_l, boxes[i, 0:3], boxes[i, 3:6])
            occ |= (tn <= tf) & (tf > T_EPS) & (tn < dist)
        lit &= ~occ
        radiance = radiance + np.where(lit, ndl * atten, 0.0)[:, None] * lights[j, 4:7][None, :]
    c = np.clip(albedo * radiance, 0.0, 1.0)
    rgb = np.where(hit[:, None], np.floor(np.power(c, GAMMA) * 255.0 + 0.5), 0).astype(np.uint8)
    return {
        "rgb": rgb.reshape(height, width, 3),
        "depth": np.where(hit, t, 0.0).astype(np.float32).reshape(height, width),
        "class": cls.reshape(height, width),
        "instance": inst.reshape(height, width),
    }


def scan_reference(scene, T_map_lidar: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Same output as :meth:`benchbot_sim_taichi.renderer.Renderer.scan`, computed with NumPy."""
    s = pack_scene(scene)
    boxes, world = s["boxes"].astype(np.float64), s["world"].astype(np.float64)
    T = np.asarray(T_map_lidar, dtype=np.float64)
    a = np.asarray(angles, dtype=np.float64) + math.atan2(T[1, 0], T[0, 0])
    d = _safe(np.stack([np.cos(a), np.sin(a)], axis=1))
    inv = 1.0 / d
    o = T[:3, 3]
    best = np.full(a.shape[0], 1e30)
    for i in range(s["n_boxes"]):
        if not (boxes[i, 2] <= o[2] <= boxes[i, 5]):
            continue
        tn, tf, _ = _entry(o[:2], inv, boxes[i, 0:2], boxes[i, 3:5])
        m = (tn <= tf) & (tn > T_EPS) & (tn < best)
        best[m] = tn[m]
    th = np.maximum((world[0:2] - o[:2]) * inv, (world[3:5] - o[:2]) * inv).min(axis=1)
    return np.minimum(best, th)
