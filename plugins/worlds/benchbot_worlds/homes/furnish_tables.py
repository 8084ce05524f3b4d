"""Things on the ground-truth tables' tops: newspapers, trays, plates, candles (pure NumPy).

A table with nothing on it, seen from a robot's camera, is a plank on legs; a table in a home holds things, and they
lift a COCO detector's confidence that it sees a table (docs/realism.md, 25 Nov 2026: CenterNet's tables scored
0.1–0.3 rose from 25 to 33 of 125 views, though few crossed 0.3). Each GT table
of the environment with a model gets up to :data:`MAX_ITEMS_PER_TABLE` models of kind :data:`TABLETOP_KIND`
(distractors mounted on a ``surface``; of no COCO class, so a detector that boxes one finds no false object), at
their natural size, standing on the table model's top, each turned a seeded quarter turn. An item stands only where
the model's top surface is under its whole footprint, at most :data:`MAX_GAP_M` below it anywhere
(:func:`top_surface`, :func:`surface_heights`: a round top, a top set into a rim, a pebbled top), and keeps
:data:`ITEM_CLEARANCE_M` from every GT cuboid of the home other than its table (a cup or a book on the table stays
free, in every variant), from supports and from other distractors. The draw is seeded by the table's ``ID_name``, so
the variants of a home that share a table dress it alike. Ground truth never changes: the items are distractors,
outside every other cuboid (on a top set into a rim, an item's bottom may lie up to :data:`MAX_GAP_M` inside its
table's cuboid).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from benchbot_worlds.homes.furnish_space import (
    Furnishing, Placement, Space, add_placement, boxes_hit, furniture_of_kinds, gt_box, seeded_rng)

#: The distractor kind of the things put on tables.
TABLETOP_KIND = "tabletop"
#: At most this many things on one table (a seeded number from 1).
MAX_ITEMS_PER_TABLE = 3
#: Positions tried per item, drawn uniformly over the top surface's bounding rectangle.
TRIES_PER_ITEM = 16
#: Clearance (m) kept from other GT cuboids, supports and distractors.
ITEM_CLEARANCE_M = 0.03
#: Tables narrower than this (m) on both sides get nothing (a plant stand).
MIN_TOP_M = 0.55
#: The top's surface: the model's up-facing triangles (normal's z above this) ...
UP_FACING_Z = 0.7
#: ... whose corners are all within this (m) of its highest point (a top set into a rim, a pebbled top).
TOP_DEPTH_M = 0.1
#: An item stands at the highest point of the top under its footprint and may be at most this (m) above the top
#: anywhere under it (a rim, a ridge); everywhere under it there must be top.
MAX_GAP_M = 0.015


def top_surface(vertices: np.ndarray, faces: np.ndarray, transform: np.ndarray) -> np.ndarray:
    """(T, 3, 3) float64 corners, metres, in the frame ``transform`` maps into, of the triangles of a placed model's
    top surface: the mesh (``vertices`` (V, 3) model frame, ``faces`` (F, 3) int) placed by ``transform`` (4, 4);
    its triangles facing up (:data:`UP_FACING_Z`) with every corner within :data:`TOP_DEPTH_M` of its highest
    point."""
    T = np.asarray(transform, dtype=np.float64)
    v = np.asarray(vertices, dtype=np.float64) @ T[:3, :3].T + T[:3, 3]
    tri = v[np.asarray(faces, dtype=np.int64)]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norm = np.linalg.norm(n, axis=1)
    up = np.abs(n[:, 2]) > UP_FACING_Z * np.maximum(norm, 1e-30)  # both faces are drawn: either winding
    high = np.all(tri[:, :, 2] >= v[:, 2].max() - TOP_DEPTH_M, axis=1)
    return tri[up & high & (norm > 1e-12)]


def surface_heights(tris: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(P,) float64: the height (m) of the highest of ``tris`` ((T, 3, 3), :func:`top_surface`) over each point of
    ``points`` (P, 2) xy, metres; −inf where none is under it."""
    if len(tris) == 0:
        return np.full(len(points), -np.inf)
    a, b, c = tris[:, 0][:, None], tris[:, 1][:, None], tris[:, 2][:, None]  # (T, 1, 3)
    p = np.asarray(points, dtype=np.float64)[None]  # (1, P, 2)
    v0, v1, v2 = b[..., :2] - a[..., :2], c[..., :2] - a[..., :2], p - a[..., :2]
    den = v0[..., 0] * v1[..., 1] - v1[..., 0] * v0[..., 1]  # (T, 1)
    den = np.where(np.abs(den) < 1e-18, np.nan, den)
    s = (v2[..., 0] * v1[..., 1] - v1[..., 0] * v2[..., 1]) / den  # (T, P)
    t = (v0[..., 0] * v2[..., 1] - v2[..., 0] * v0[..., 1]) / den
    eps = 1e-9
    inside = (s >= -eps) & (t >= -eps) & (s + t <= 1 + eps)
    z = a[..., 2] + s * (b[..., 2] - a[..., 2]) + t * (c[..., 2] - a[..., 2])
    return np.where(inside, z, -np.inf).max(axis=0)


#: Points per side of the grid over an item's footprint at which the top is looked for.
FOOTPRINT_GRID = 5


def footprint_points(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(FOOTPRINT_GRID², 2) float64: a grid over the xy footprint ``lo``..``hi`` (2,), its edges included."""
    xs, ys = np.linspace(lo[0], hi[0], FOOTPRINT_GRID), np.linspace(lo[1], hi[1], FOOTPRINT_GRID)
    return np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)


def dress_tables(objects: Sequence[dict], placements: Sequence[Placement], space: Space, library, seed: int,
                 mesh_of: Callable[[Any], Any], bounds_of, out: Furnishing) -> None:
    """Put tabletop models on the GT tables of this environment (see the module docstring).

    Args:
        objects: the environment's GT objects (``class``, ``ID_name``), home frame.
        placements: the GT objects' placements (``object_index`` into ``objects``, role ``object``).
        space: the occupied space of the home (every variant's GT cuboids, supports, distractors); items are added.
        library: an :class:`~benchbot.packs.assets.AssetLibrary`; nothing happens without a :data:`TABLETOP_KIND`.
        seed: the home's seed.
        mesh_of: an asset's mesh (``v`` (V, 3) model frame, metres; ``f`` (F, 3) int).
        bounds_of: an asset's (2, 3) model-frame bounds (for the fit).
        out: the placements are appended here (role ``distractor``).
    """
    assets = [a for a in furniture_of_kinds(library, (TABLETOP_KIND,)) if a.mount in ("surface", None)]
    if not assets:
        return
    for p in placements:
        obj = objects[p.object_index] if p.role == "object" and p.mesh is None else None
        if obj is None or obj.get("class") != "table":
            continue
        table = library.get(p.asset_id)
        mesh = mesh_of(table)
        tris = top_surface(mesh.v, mesh.f, p.transform)
        if len(tris) == 0:
            continue
        lo, hi = tris[:, :, :2].reshape(-1, 2).min(axis=0), tris[:, :, :2].reshape(-1, 2).max(axis=0)
        if np.all(hi - lo < MIN_TOP_M):
            continue
        tlo, thi = gt_box(obj)
        others = ~(np.all(np.isclose(space.gt_lo, tlo), axis=1) & np.all(np.isclose(space.gt_hi, thi), axis=1))
        rng = seeded_rng(seed, "tabletop", str(obj.get("ID_name", p.object_index)))
        order = rng.permutation(len(assets))  # never the same thing twice on one table
        for asset in [assets[i] for i in order[:int(rng.integers(1, MAX_ITEMS_PER_TABLE + 1))]]:
            k = int(rng.integers(4))
            w, d, h = (float(v) for v in asset.size_m)
            ext = np.array([d, w] if k % 2 else [w, d])
            if np.any(ext > hi - lo):
                continue
            for _ in range(TRIES_PER_ITEM):
                c = lo + ext / 2 + rng.random(2) * (hi - lo - ext)
                z = surface_heights(tris, footprint_points(c - ext / 2, c + ext / 2))
                base = float(z.max())
                # no top under it at all (base -inf), off the top somewhere, or over a gap or a rim
                if not np.isfinite(base) or not np.all(z >= base - MAX_GAP_M):
                    continue
                blo, bhi = np.array([*(c - ext / 2), base]), np.array([*(c + ext / 2), base + h])
                if boxes_hit(blo, bhi, space.gt_lo[others], space.gt_hi[others], ITEM_CLEARANCE_M).any() \
                        or boxes_hit(blo, bhi, space.placed_lo, space.placed_hi, ITEM_CLEARANCE_M).any():
                    continue
                add_placement(out, space, asset, blo, bhi, k, "distractor", bounds_of)
                break
