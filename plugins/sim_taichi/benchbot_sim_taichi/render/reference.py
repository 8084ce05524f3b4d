"""A straightforward NumPy implementation of the renderer's ray casting and laser scan (same rays, same shading with
hard shadows, brute force over every primitive — no BVH), used to test the Taichi kernels. Slow; float64. Shapes and
units as in :meth:`Renderer.render` / :meth:`Renderer.scan`.
"""

from __future__ import annotations

import math

import numpy as np

from benchbot_sim_taichi.render.camera_model import GAMMA
from benchbot_sim_taichi.render.kernels import (DIR_EPS, LAMP_FIXTURE_M, SHADOW_OFFSET, SHELL_TIE, T_EPS, TILE_CONTRAST,
                                        TILE_M)
from benchbot_worlds.scene.model import PRIM_BOX, PRIM_CYLINDER, PRIM_ELLIPSOID

_INF = 1e30


def _safe(d: np.ndarray) -> np.ndarray:
    d = d.copy()
    d[np.abs(d) < DIR_EPS] = DIR_EPS
    return d


def hit_primitive(scene, i: int, o: np.ndarray, d: np.ndarray, tmax: np.ndarray):
    """Entry ``(t (R,), normal (R, 3))`` of rays ``o`` (R, 3) / ``d`` (R, 3) into primitive ``i`` of ``scene``
    where ``T_EPS < t < tmax``, else ``t = tmax``."""
    R = d.shape[0]
    o = np.broadcast_to(o, (R, 3))
    lo, hi = scene.prim_min[i].astype(np.float64), scene.prim_max[i].astype(np.float64)
    kind = int(scene.prim_type[i])
    t = np.full(R, _INF)
    n = np.zeros((R, 3))
    if kind == PRIM_BOX:
        inv = 1.0 / _safe(d)
        t1, t2 = (lo - o) * inv, (hi - o) * inv
        a, b = np.minimum(t1, t2), np.maximum(t1, t2)
        axis = np.argmax(a, axis=1)
        tn, tf = a.max(axis=1), b.min(axis=1)
        m = (tn <= tf) & (tn > T_EPS)
        t[m] = tn[m]
        idx = np.nonzero(m)[0]
        n[idx, axis[idx]] = np.where(d[idx, axis[idx]] > 0, -1.0, 1.0)
    elif kind == PRIM_ELLIPSOID:
        c, r = (lo + hi) / 2, np.maximum((hi - lo) / 2, 1e-6)
        oc, dd = (o - c) / r, d / r
        a = (dd * dd).sum(1)
        b = (oc * dd).sum(1)
        cc = (oc * oc).sum(1) - 1
        disc = b * b - a * cc
        ok = disc >= 0
        t0 = np.where(ok, (-b - np.sqrt(np.maximum(disc, 0))) / a, _INF)
        m = ok & (t0 > T_EPS)
        t[m] = t0[m]
        q = (oc + t0[:, None] * dd) / r
        n[m] = q[m] / np.linalg.norm(q[m], axis=1, keepdims=True)
    elif kind == PRIM_CYLINDER:
        ax = int(scene.prim_axis[i])
        perm = [(ax + 1) % 3, (ax + 2) % 3, ax]
        c, r = (lo + hi) / 2, np.maximum((hi - lo) / 2, 1e-6)
        R3 = r[perm]
        O, D = (o - c)[:, perm] / R3, d[:, perm] / R3
        a = D[:, 0] ** 2 + D[:, 1] ** 2
        b = O[:, 0] * D[:, 0] + O[:, 1] * D[:, 1]
        cc = O[:, 0] ** 2 + O[:, 1] ** 2 - 1
        disc = b * b - a * cc
        par = a < 1e-12
        ok = np.where(par, cc <= 0, disc >= 0)
        s = np.sqrt(np.maximum(disc, 0))
        with np.errstate(divide="ignore", invalid="ignore"):
            ts0 = np.where(par, -_INF, (-b - s) / np.where(par, 1, a))
            ts1 = np.where(par, _INF, (-b + s) / np.where(par, 1, a))
        dz = _safe(D[:, 2:3])[:, 0]
        tz0, tz1 = (-1 - O[:, 2]) / dz, (1 - O[:, 2]) / dz
        tza = np.minimum(tz0, tz1)
        tn, tf = np.maximum(ts0, tza), np.minimum(ts1, np.maximum(tz0, tz1))
        m = ok & (tn <= tf) & (tn > T_EPS)
        t[m] = tn[m]
        q = O + tn[:, None] * D
        nl = np.where((ts0 > tza)[:, None], np.stack([q[:, 0] / R3[0], q[:, 1] / R3[1], np.zeros(R)], 1),
                      np.stack([np.zeros(R), np.zeros(R), np.where(D[:, 2] > 0, -1.0, 1.0)], 1))
        nw = np.zeros((R, 3))
        nw[:, perm] = nl
        nn = np.linalg.norm(nw, axis=1, keepdims=True)
        n[m] = (nw / np.maximum(nn, 1e-30))[m]
    else:
        v0, v1, v2 = scene.tri_v[int(scene.prim_axis[i])].astype(np.float64)
        e1, e2 = v1 - v0, v2 - v0
        p = np.cross(d, e2)
        det = p @ e1
        with np.errstate(divide="ignore", invalid="ignore"):
            idet = 1.0 / det
            s = o - v0
            u = (s * p).sum(1) * idet
            qv = np.cross(s, e1)
            w = (d * qv).sum(1) * idet
            tt = (qv @ e2) * idet
        m = (det != 0) & (u >= 0) & (u <= 1) & (w >= 0) & (u + w <= 1) & (tt > T_EPS)
        t[m] = tt[m]
        nf = np.cross(e1, e2)
        nf = nf / np.linalg.norm(nf)
        n[m] = np.where(((d @ nf) > 0)[:, None], -nf, nf)[m]
    m = t < tmax
    return np.where(m, t, tmax), np.where(m[:, None], n, 0.0)


def trace_reference(scene, o, d, tmax=None):
    """Closest primitive hit of rays ``o``/``d``: ``(t (R,), index (R,) (-1: none), normal (R, 3))``. Window panes
    (``Scene.prim_glass``) are left out, as depth, segmentation and the laser see through them (shadow rays and the
    images of this reference therefore take panes as fully clear)."""
    R = d.shape[0]
    best = np.full(R, _INF) if tmax is None else np.asarray(tmax, dtype=np.float64).copy()
    k = np.full(R, -1)
    nrm = np.zeros((R, 3))
    glass = scene.prim_glass()
    for i in range(int(scene.prim_type.shape[0])):
        if glass[i]:
            continue
        t, n = hit_primitive(scene, i, o, d, best)
        m = t < best
        best[m], k[m], nrm[m] = t[m], i, n[m]
    return best, k, nrm


def render_reference(scene, K: np.ndarray, T_map_camera: np.ndarray, width: int, height: int) -> dict:
    """Same outputs as :meth:`benchbot_sim_taichi.render.renderer.Renderer.render` (fast mode, one shadow sample),
    computed with NumPy."""
    room_min, room_max = scene.room_min.astype(np.float64), scene.room_max.astype(np.float64)
    shell = scene.shell_albedo.astype(np.float64)
    K = np.asarray(K, dtype=np.float64)
    T = np.asarray(T_map_camera, dtype=np.float64)
    v, u = np.mgrid[0:height, 0:width]
    xc = (u.ravel() - K[0, 2]) / K[0, 0]
    yc = (v.ravel() - K[1, 2]) / K[1, 1]
    d = np.stack([xc, yc, np.ones_like(xc)], axis=1) @ T[:3, :3].T
    o = T[:3, 3]
    P = d.shape[0]
    best, best_i, best_n = trace_reference(scene, o, d)
    inv = 1.0 / _safe(d)
    th = np.maximum((room_min - o) * inv, (room_max - o) * inv)
    exit_axis = np.argmin(th, axis=1)
    t_exit = th.min(axis=1)
    inside = bool(np.all(o >= room_min) and np.all(o <= room_max))
    use_box = (best_i >= 0) & ((not inside) | (best < t_exit * (1.0 + SHELL_TIE)))
    use_shell = (~use_box) & inside & (t_exit > T_EPS)
    hit = use_box | use_shell
    t = np.where(use_box, best, np.where(use_shell, t_exit, 0.0))
    n = np.zeros((P, 3))
    n[np.arange(P), exit_axis] = np.where(d[np.arange(P), exit_axis] > 0, -1.0, 1.0)
    n[use_box] = best_n[use_box]
    albedo = np.zeros((P, 3))
    cls = np.full(P, int(scene.background_class), dtype=np.int32)
    inst = np.zeros(P, dtype=np.int32)
    bi = np.where(use_box, best_i, 0)
    obj = scene.prim_object[bi]
    albedo[use_box] = scene.prim_albedo[bi[use_box]]
    cls[use_box] = scene.box_class[obj[use_box]]
    inst[use_box] = scene.box_instance[obj[use_box]]
    surf = np.where(exit_axis == 2, np.where(d[:, 2] < 0, 0, 2), 1)
    p = o + t[:, None] * d
    parity = (np.floor(p[:, 0] / TILE_M).astype(int) + np.floor(p[:, 1] / TILE_M).astype(int)) & 1
    floor_mod = np.where(surf == 0, 1.0 + TILE_CONTRAST * (2.0 * parity - 1.0), 1.0)
    albedo[use_shell] = (shell[surf] * floor_mod[:, None])[use_shell]
    radiance = scene.ambient.astype(np.float64)[None, :] * (0.8 + 0.2 * n[:, 2:3])
    po = p + n * SHADOW_OFFSET
    for j in range(int(scene.light_kind.shape[0])):
        vec, col, rng = scene.light_vec[j].astype(np.float64), scene.light_colour[j].astype(np.float64), float(scene.light_range[j])
        if scene.light_kind[j] == 1:
            Lv = vec - p
            dist = np.linalg.norm(Lv, axis=1)
            ok = (dist <= rng) & (dist >= 1e-6)
            L = Lv / np.maximum(dist, 1e-12)[:, None]
            f = 1.0 - (dist / rng) ** 2
            atten = f * f / np.maximum(dist * dist, 0.25)
        else:
            L = np.broadcast_to(vec, (P, 3)).copy()
            dist = np.full(P, _INF)
            ok = np.ones(P, dtype=bool)
            atten = np.ones(P)
        ndl = np.einsum("ij,ij->i", n, L)
        lit = ok & (ndl > 0) & hit
        idx = np.nonzero(lit)[0]
        if idx.size:
            reach = dist[idx] - LAMP_FIXTURE_M if scene.light_kind[j] == 1 else dist[idx]
            _, k, _ = trace_reference(scene, po[idx], L[idx], np.maximum(reach, 0.0))
            lit[idx[k >= 0]] = False
        radiance = radiance + np.where(lit, ndl * atten, 0.0)[:, None] * col[None, :]
    c = np.clip(albedo * radiance, 0.0, 1.0)
    rgb = np.where(hit[:, None], np.floor(np.power(c, GAMMA) * 255.0 + 0.5), 0).astype(np.uint8)
    return {
        "rgb": rgb.reshape(height, width, 3),
        "depth": np.where(hit, t, 0.0).astype(np.float32).reshape(height, width),
        "class": cls.reshape(height, width),
        "instance": inst.reshape(height, width),
    }


def scan_reference(scene, T_map_lidar: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Same output as :meth:`benchbot_sim_taichi.render.renderer.Renderer.scan`, computed with NumPy."""
    T = np.asarray(T_map_lidar, dtype=np.float64)
    a = np.asarray(angles, dtype=np.float64) + math.atan2(T[1, 0], T[0, 0])
    d = np.stack([np.cos(a), np.sin(a), np.zeros_like(a)], axis=1)
    o = T[:3, 3]
    best, _, _ = trace_reference(scene, o, d)
    inv = 1.0 / _safe(d[:, :2])
    th = np.maximum((scene.room_min[:2] - o[:2]) * inv, (scene.room_max[:2] - o[:2]) * inv).min(axis=1)
    return np.minimum(best, th)
