"""Where a round robot's centre may stand in a procedural home (:class:`~.layout.Layout` plus ground-truth objects):
an occupancy grid, its connected components, straight-segment checks and grid paths (NumPy, SciPy; metres,
``map`` frame, z up).

Obstacles are axis-aligned xy rectangles: the walls (:func:`wall_rects`: the exterior walls outside the outer
rectangle, an interior wall ``wall_thickness`` thick centred on every room side that is not exterior, doorways cut
out) and every object whose bottom is below :data:`OBSTRUCT_BELOW_M` (its cuboid's xy footprint). A cell is free
when the exact distance from its centre to every obstacle rectangle is at least the robot radius.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import breadth_first_order

from .layout import Layout

#: An object whose bottom (centroid z − extent z / 2, metres) is below this obstructs the robot (carter is 1.1 m
#: tall); higher ones (wall shelves, lamps) pass over it. Small objects on a table are covered by the table's box.
OBSTRUCT_BELOW_M = 1.2
#: Rooms' sides closer than this (m) to the outer rectangle's faces are exterior.
_EPS = 1e-6


def _subtract(lo: float, hi: float, gaps: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The interval lo..hi less the intervals ``gaps`` (sorted pieces longer than 1 µm)."""
    pieces = [(lo, hi)]
    for g0, g1 in sorted(gaps):
        out = []
        for a, b in pieces:
            if g1 <= a or g0 >= b:
                out.append((a, b))
                continue
            if g0 > a:
                out.append((a, g0))
            if g1 < b:
                out.append((g1, b))
        pieces = out
    return [(a, b) for a, b in pieces if b - a > _EPS]


def wall_rects(layout: Layout) -> tuple[np.ndarray, np.ndarray]:
    """The walls of ``layout`` as xy rectangles ``(lo, hi)``, each (W, 2) float64 (metres, map frame): the four
    exterior walls (``wall_thickness`` outside the outer rectangle, corners included) and, for every room side that
    is not on the outer rectangle, a wall ``wall_thickness`` thick centred on the side's line along its length,
    less the clear openings of the doors on that line. A side shared by two rooms gives one rectangle when both
    rooms agree on its extent. Rows sorted (lo x, lo y, hi x, hi y)."""
    t = float(layout.wall_thickness)
    olo, ohi = np.asarray(layout.outer_lo, float), np.asarray(layout.outer_hi, float)
    lo = [[olo[0] - t, olo[1] - t], [ohi[0], olo[1] - t], [olo[0] - t, olo[1] - t], [olo[0] - t, ohi[1]]]
    hi = [[olo[0], ohi[1] + t], [ohi[0] + t, ohi[1] + t], [ohi[0] + t, olo[1]], [ohi[0] + t, ohi[1] + t]]
    for room in layout.rooms:
        rlo, rhi = np.asarray(room.lo, float), np.asarray(room.hi, float)
        for axis in (0, 1):
            for pos in (rlo[axis], rhi[axis]):
                if abs(pos - olo[axis]) < _EPS or abs(pos - ohi[axis]) < _EPS:
                    continue
                gaps = [(d.lo, d.hi) for d in layout.doors if d.axis == axis and abs(d.pos - pos) < _EPS]
                for a, b in _subtract(rlo[1 - axis], rhi[1 - axis], gaps):
                    r_lo, r_hi = [0.0, 0.0], [0.0, 0.0]
                    r_lo[axis], r_hi[axis] = pos - t / 2, pos + t / 2
                    r_lo[1 - axis], r_hi[1 - axis] = a, b
                    lo.append(r_lo)
                    hi.append(r_hi)
    rects = np.unique(np.round(np.concatenate([lo, hi], axis=1), 9), axis=0)  # a shared side once, sorted
    return rects[:, :2].copy(), rects[:, 2:].copy()


def rects_near(lo: np.ndarray, hi: np.ndarray, box_lo, box_hi) -> tuple[np.ndarray, np.ndarray]:
    """The rectangles ``lo``/``hi`` ((K, 2) each) that meet the closed box ``box_lo``..``box_hi`` ((2,) each)."""
    keep = (lo <= np.asarray(box_hi)).all(axis=1) & (hi >= np.asarray(box_lo)).all(axis=1)
    return lo[keep], hi[keep]


def object_boxes(objects: list[dict]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lo (N, 3), hi (N, 3)) float64 corners of the ground-truth cuboids ``objects`` (dicts with ``centroid`` and
    ``extent``, metres) and (N,) bool: which obstruct the robot (bottom below :data:`OBSTRUCT_BELOW_M`).

    Raises:
        ValueError: an object lacks a 3-number ``centroid`` or ``extent``.
    """
    if not objects:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, dtype=bool)
    c = np.array([np.asarray(o["centroid"], dtype=np.float64).reshape(3) for o in objects])
    e = np.abs(np.array([np.asarray(o["extent"], dtype=np.float64).reshape(3) for o in objects]))
    lo, hi = c - e / 2, c + e / 2
    return lo, hi, lo[:, 2] < OBSTRUCT_BELOW_M


def rect_distances(p: np.ndarray, lo: np.ndarray, hi: np.ndarray, chunk: int = 1 << 18) -> np.ndarray:
    """(M,) float64: the distance (m) from each of the points ``p`` (M, 2) to the nearest of the rectangles
    ``lo``/``hi`` ((K, 2) each); 0 inside one; inf when K = 0. Works in blocks of about ``chunk`` pairs."""
    p = np.asarray(p, dtype=np.float64).reshape(-1, 2)
    out = np.full(len(p), np.inf)
    if not len(lo):
        return out
    step = max(1, chunk // len(lo))
    for s in range(0, len(p), step):
        q = p[s:s + step, None, :]
        d = np.maximum(np.maximum(lo[None] - q, q - hi[None]), 0.0)
        out[s:s + step] = np.hypot(d[..., 0], d[..., 1]).min(axis=1)
    return out


@dataclass(frozen=True)
class FreeSpace:
    """Where the robot's centre may be: an occupancy grid of a home.

    Attributes:
        origin: (2,) float64 xy (m, map frame) of cell [0, 0]'s centre; cell [i, j] is centred at
            ``origin + (i, j) * cell_m`` (i along x, j along y).
        cell_m: cell side, metres.
        free: (nx, ny) bool: True where the exact distance from the cell's centre to every obstacle is at least
            ``robot_radius_m``.
        robot_radius_m: the footprint radius the grid was made for (m).
        obstacle_lo, obstacle_hi: (K, 2) float64 obstacle rectangles, the ``n_walls`` walls first, then the
            obstructing objects' footprints.
        n_walls: how many of the obstacles are walls.
        room_lo, room_hi: (R, 2) float64 the rooms' boxes (between wall centre lines, as :class:`~.layout.RoomBox`).
        object_index: (K − n_walls,) int64 the obstructing objects' indices into the objects given.
    """

    origin: np.ndarray
    cell_m: float
    free: np.ndarray
    robot_radius_m: float
    obstacle_lo: np.ndarray
    obstacle_hi: np.ndarray
    n_walls: int
    room_lo: np.ndarray
    room_hi: np.ndarray
    object_index: np.ndarray

    def cells(self, xy) -> np.ndarray:
        """(M, 2) int64 indices of the cells nearest to the points ``xy`` (M, 2) (may lie outside the grid)."""
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        return np.floor((p - self.origin) / self.cell_m + 0.5).astype(np.int64)

    def centres(self, ij) -> np.ndarray:
        """(M, 2) float64 xy of the centres of the cells ``ij`` (M, 2)."""
        return self.origin + np.asarray(ij, dtype=np.float64).reshape(-1, 2) * self.cell_m

    def is_free(self, xy) -> np.ndarray:
        """(M,) bool: whether each of ``xy`` (M, 2) lies in a free cell (False outside the grid)."""
        ij = self.cells(xy)
        ok = (ij >= 0).all(axis=1) & (ij[:, 0] < self.free.shape[0]) & (ij[:, 1] < self.free.shape[1])
        out = np.zeros(len(ij), dtype=bool)
        out[ok] = self.free[ij[ok, 0], ij[ok, 1]]
        return out

    def segment_free(self, p0, p1) -> bool:
        """Whether the straight segment ``p0``→``p1`` ((2,) xy each) lies in free space: every point sampled along
        it every ``cell_m / 4`` (both ends included) lies in a free cell. Every point of such a segment is within
        ``cell_m·(√2/2 + 1/8)`` of a free cell's centre, so the robot's disc swept along it clears every obstacle by
        at least ``robot_radius_m − 0.83·cell_m``."""
        p0, p1 = np.asarray(p0, dtype=np.float64)[:2], np.asarray(p1, dtype=np.float64)[:2]
        n = int(math.ceil(float(np.hypot(*(p1 - p0))) / (self.cell_m / 4))) + 1
        t = np.linspace(0.0, 1.0, max(n, 2))[:, None]
        return bool(self.is_free(p0 + t * (p1 - p0)).all())

    def clearance(self, xy) -> np.ndarray:
        """(M,) float64 exact distance (m) from each of ``xy`` (M, 2) to the nearest obstacle rectangle."""
        return rect_distances(xy, self.obstacle_lo, self.obstacle_hi)


def _rasterise(shape, origin, cell, lo, hi) -> np.ndarray:
    """(nx, ny) bool: the cells whose square overlaps one of the rectangles ``lo``/``hi`` (K, 2)."""
    occ = np.zeros(shape, dtype=bool)
    a = np.floor((lo - origin) / cell + 0.5).astype(np.int64)
    b = np.floor((hi - origin) / cell + 0.5).astype(np.int64)
    a, b = np.maximum(a, 0), np.minimum(b, np.array(shape) - 1)
    for (i0, j0), (i1, j1) in zip(a, b):
        if i0 <= i1 and j0 <= j1:
            occ[i0:i1 + 1, j0:j1 + 1] = True
    return occ


def free_space(layout: Layout, objects: list[dict], robot_radius_m: float = 0.35, cell_m: float = 0.05) -> FreeSpace:
    """The :class:`FreeSpace` of ``layout`` furnished with ``objects`` (ground-truth dicts, map frame) for a round
    robot of radius ``robot_radius_m`` (m), on cells of ``cell_m`` (m) covering the home and its exterior walls.

    The grid's distances come from a Euclidean distance transform of the rasterised obstacles; the cells within
    about a cell of the radius get the exact distance to the rectangles, so ``free`` is exact at cell centres.

    Raises:
        ValueError: ``cell_m`` or ``robot_radius_m`` not positive, or an object without centroid/extent.
    """
    if not (cell_m > 0 and robot_radius_m > 0):
        raise ValueError(f"free_space: cell_m ({cell_m}) and robot_radius_m ({robot_radius_m}) must be positive")
    t = float(layout.wall_thickness)
    w_lo, w_hi = wall_rects(layout)
    o_lo, o_hi, obstructs = object_boxes(objects)
    lo = np.concatenate([w_lo, o_lo[obstructs, :2]])
    hi = np.concatenate([w_hi, o_hi[obstructs, :2]])
    origin = np.asarray(layout.outer_lo, float) - t
    shape = tuple(int(v) for v in np.ceil((np.asarray(layout.outer_hi, float) + t - origin) / cell_m) + 1)
    occ = _rasterise(shape, origin, cell_m, lo, hi)
    d = ndimage.distance_transform_edt(~occ) * cell_m if occ.any() else np.full(shape, np.inf)
    slack = cell_m * math.sqrt(2) / 2
    free = d - slack >= robot_radius_m
    band = np.nonzero((d - slack < robot_radius_m) & (d + slack >= robot_radius_m))
    if len(band[0]):
        pts = origin + np.stack(band, axis=1) * cell_m
        free[band] = rect_distances(pts, lo, hi) >= robot_radius_m
    rooms = layout.rooms
    return FreeSpace(origin=origin, cell_m=float(cell_m), free=free, robot_radius_m=float(robot_radius_m),
                     obstacle_lo=lo, obstacle_hi=hi, n_walls=len(w_lo),
                     room_lo=np.array([np.asarray(r.lo, float) for r in rooms]).reshape(-1, 2),
                     room_hi=np.array([np.asarray(r.hi, float) for r in rooms]).reshape(-1, 2),
                     object_index=np.nonzero(obstructs)[0].astype(np.int64))


def components(fs: FreeSpace) -> tuple[np.ndarray, int]:
    """The 4-connected components of ``fs.free``: labels (nx, ny) int32 (0: not free, 1..n) and n."""
    labels, n = ndimage.label(fs.free)
    return labels.astype(np.int32), int(n)


def room_cells(fs: FreeSpace, room: int) -> tuple[slice, slice]:
    """The grid window (slices of ``fs.free``) of the cells whose centres lie in room ``room``'s box."""
    a = np.ceil((fs.room_lo[room] - fs.origin) / fs.cell_m - 1e-9).astype(int)
    b = np.floor((fs.room_hi[room] - fs.origin) / fs.cell_m + 1e-9).astype(int)
    return slice(max(a[0], 0), b[0] + 1), slice(max(a[1], 0), b[1] + 1)


def main_component(fs: FreeSpace) -> tuple[np.ndarray, list[bool]]:
    """((nx, ny) bool mask of the free component that reaches the most rooms, ties to the largest (then the lowest
    label), all False when nothing is free; per room, whether that component has a cell in the room's box)."""
    labels, n = components(fs)
    if n == 0:
        return np.zeros_like(fs.free), [False] * len(fs.room_lo)
    present = np.zeros((len(fs.room_lo), n + 1), dtype=bool)
    for r in range(len(fs.room_lo)):
        present[r, np.unique(labels[room_cells(fs, r)])] = True
    present[:, 0] = False
    sizes = np.bincount(labels.ravel(), minlength=n + 1)
    sizes[0] = 0
    best = int(np.lexsort((-np.arange(n + 1), sizes, present.sum(axis=0)))[-1])  # most rooms, then most cells
    return labels == best, [bool(v) for v in present[:, best]]


def connected(fs: FreeSpace) -> bool:
    """True when one connected piece of free space reaches every room (the robot can drive between any two rooms);
    free pockets that reach no other room (behind furniture) do not matter. False also for a home without rooms."""
    reach = main_component(fs)[1]
    return bool(reach) and all(reach)


def grid_path(fs: FreeSpace, a, b, window: tuple[slice, slice] | None = None) -> np.ndarray | None:
    """A shortest 4-connected path of free cells from the cell of ``a`` to the cell of ``b`` ((2,) xy each) within
    ``window`` (slices of the grid; default the whole grid): (M, 2) float64 xy of ``a``, the cells' centres, ``b``;
    None when either cell is not free or not in the window, or no path joins them."""
    window = window or (slice(0, fs.free.shape[0]), slice(0, fs.free.shape[1]))
    sub = fs.free[window]
    off = np.array([window[0].start, window[1].start])
    ia, ib = fs.cells(a)[0] - off, fs.cells(b)[0] - off
    for ij in (ia, ib):
        if not (0 <= ij[0] < sub.shape[0] and 0 <= ij[1] < sub.shape[1] and sub[ij[0], ij[1]]):
            return None
    ids = np.arange(sub.size).reshape(sub.shape)
    rows, cols = [], []
    for u, v in ((sub[:-1] & sub[1:], (ids[:-1], ids[1:])), (sub[:, :-1] & sub[:, 1:], (ids[:, :-1], ids[:, 1:]))):
        rows.append(v[0][u])
        cols.append(v[1][u])
    r, c = np.concatenate(rows), np.concatenate(cols)
    graph = coo_matrix((np.ones(len(r), dtype=np.int8), (r, c)), shape=(sub.size, sub.size)).tocsr()
    start, goal = int(ids[ia[0], ia[1]]), int(ids[ib[0], ib[1]])
    _, pred = breadth_first_order(graph, start, directed=False, return_predecessors=True)
    if start != goal and pred[goal] < 0:
        return None
    chain = [goal]
    while chain[-1] != start:
        chain.append(int(pred[chain[-1]]))
    ij = np.stack(np.unravel_index(np.array(chain[::-1]), sub.shape), axis=1) + off
    return np.concatenate([np.asarray(a, float)[None, :2], fs.centres(ij), np.asarray(b, float)[None, :2]])


def shortcut(path: np.ndarray, reachable: "Callable[[np.ndarray, np.ndarray], bool]") -> np.ndarray:
    """``path`` (M, 2) in metres with corners cut: from each kept point, the farthest later point that
    ``reachable(a, b)`` says a straight move reaches (at least the next point); (M', 2), the same ends."""
    out, i, m = [path[0]], 0, len(path)
    while i < m - 1:
        j = m - 1
        if not reachable(path[i], path[j]):
            j = i + 1
            while j + 1 < m and reachable(path[i], path[j + 1]):
                j += 1
        out.append(path[j])
        i = j
    return np.array(out)
