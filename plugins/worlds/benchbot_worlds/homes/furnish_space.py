"""What the furnishing steps share: placements and their report, the occupied space of a home (GT cuboids, walls,
doorways, window and door holes, the robot corridor, placed furniture) and geometry helpers (pure NumPy)."""

from __future__ import annotations

import math
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from benchbot_worlds.homes.fitting import fit_to_cuboid

#: GT classes (BEAR); no support or distractor is ever of one of these kinds.
GT_CLASSES = frozenset((
    "bottle", "cup", "knife", "bowl", "wine glass", "fork", "spoon", "banana", "apple", "orange", "cake",
    "potted plant", "mouse", "keyboard", "laptop", "cell phone", "book", "clock", "chair", "table", "couch", "bed",
    "toilet", "tv", "microwave", "toaster", "refrigerator", "oven", "sink", "person"))

#: The tallest robot (m): carter's ``max_height_m``.
ROBOT_HEIGHT_M = 1.1

#: Things whose underside is at least this high (m) may overhang the robot corridor.
OVERHEAD_CLEAR_Z_M = ROBOT_HEIGHT_M + 0.2

#: Free floor (m) kept on both sides of a doorway (no floor furniture there).
DOOR_CLEARANCE_M = 0.7

#: Something is "in front of" a window or door hole when it is within this (m) of it across the wall.
OPENING_FRONT_M = 0.06
#: The roles of a Placement.
ROLES = ("object", "support", "distractor", "door", "window", "light")


@dataclass(frozen=True)
class Placement:
    """One model in the scene.

    Attributes:
        asset_id: the :class:`~benchbot.packs.assets.AssetInfo` id.
        transform: (4, 4) float64, the asset's map-frame model (z up, front −y) → map, non-uniform scale included.
        object_index: index into the ``objects`` given to :func:`furnish` (several placements share it for a book
            row), −1 for everything that is not a GT object.
        role: one of :data:`ROLES`.
        mesh: a mesh made in code (a closed book, a keyboard, a toaster: :mod:`~benchbot_worlds.homes.books`,
            :mod:`~benchbot_worlds.homes.keyboards`, :mod:`~benchbot_worlds.homes.toasters`), drawn instead of an
            asset's model (``transform`` then maps the mesh's frame to the map); ``asset_id`` names it. None: the
            asset's model.
    """

    asset_id: str
    transform: np.ndarray
    object_index: int
    role: str
    mesh: Any = None


@dataclass
class Furnishing:
    """What :func:`furnish_home` produced.

    Attributes:
        placements: every :class:`Placement`.
        without_model: indices of GT objects with no placement (no asset of their class, or a degenerate cuboid):
            the caller draws them otherwise.
        unsupported: ``(object index, reason)`` of floating GT objects left without a support.
        hanging: indices of GT objects taken to hang on a wall (no support needed).
        boxes: ``{"support": [(lo, hi)], "distractor": [...], ...}`` the map-frame boxes of the non-GT placements,
            for checks and plans.
    """

    placements: list[Placement] = field(default_factory=list)
    without_model: list[int] = field(default_factory=list)
    unsupported: list[tuple[int, str]] = field(default_factory=list)
    hanging: list[int] = field(default_factory=list)
    boxes: dict[str, list[tuple[np.ndarray, np.ndarray]]] = field(default_factory=dict)

    def counts(self) -> dict[str, int]:
        """Number of placements per role."""
        out = {r: 0 for r in ROLES}
        for p in self.placements:
            out[p.role] = out.get(p.role, 0) + 1
        return out


def seeded_rng(seed: int, *key: object) -> np.random.Generator:
    """A NumPy generator seeded by ``seed`` and ``key`` (CRC-32 of their text): the same key, the same draws."""
    return np.random.default_rng(zlib.crc32("|".join(str(x) for x in (seed, *key)).encode("utf-8")))


def boxes_hit(lo: np.ndarray, hi: np.ndarray, blo: np.ndarray, bhi: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """(N,) bool: which boxes blo/bhi (N, 3) the box lo..hi (3,) intersects with positive volume (after growing
    it by ``margin``; a negative margin lets boxes touch and overlap slightly)."""
    if len(blo) == 0:
        return np.zeros(0, dtype=bool)
    return np.all((lo - margin < bhi) & (blo < hi + margin), axis=1)


def overlap_area(alo, ahi, blo, bhi) -> float:
    """Area (m²) of the overlap of the xy footprints of two boxes (0 if apart)."""
    d = np.minimum(ahi[:2], bhi[:2]) - np.maximum(alo[:2], blo[:2])
    return float(max(d[0], 0.0) * max(d[1], 0.0))


def rect_gap(alo, ahi, blo, bhi) -> float:
    """Shortest xy distance (m) between the footprints of two boxes (0 if they overlap or touch)."""
    d = np.maximum(np.maximum(blo[:2] - ahi[:2], alo[:2] - bhi[:2]), 0.0)
    return float(math.hypot(d[0], d[1]))


def gt_box(obj: dict) -> tuple[np.ndarray, np.ndarray]:
    """(lo (3,), hi (3,)) of a GT object's cuboid ``centroid ± extent / 2``."""
    c = np.asarray(obj["centroid"], dtype=np.float64)
    e = np.asarray(obj["extent"], dtype=np.float64)
    return c - e / 2, c + e / 2


class Space:
    """Occupied boxes (GT cuboids, walls, supports, distractors) and the keep-out zones of a plan."""

    def __init__(self, plan: Any, gt_boxes: list[tuple[np.ndarray, np.ndarray]], gt_names: Sequence[str] = (),
                 gt_classes: Sequence[str] = ()):
        self.plan = plan
        self.gt_names = list(gt_names)
        self.gt_classes = list(gt_classes)
        self.gt_lo = np.array([b[0] for b in gt_boxes]).reshape(-1, 3)
        self.gt_hi = np.array([b[1] for b in gt_boxes]).reshape(-1, 3)
        walls = list(getattr(plan, "walls", []) or [])
        self.wall_lo = np.array([np.asarray(w.lo, dtype=np.float64) for w in walls]).reshape(-1, 3)
        self.wall_hi = np.array([np.asarray(w.hi, dtype=np.float64) for w in walls]).reshape(-1, 3)
        self.counts: dict = {}  # what the steps count, e.g. (room, kind) -> wall-hung distractors
        self.placed_lo = np.zeros((0, 3))
        self.placed_hi = np.zeros((0, 3))
        doors, holes = [], []
        for o in getattr(plan, "openings", []) or []:
            olo, ohi = np.asarray(o.lo, dtype=np.float64), np.asarray(o.hi, dtype=np.float64)
            holes.append((olo, ohi))
            if o.kind == "door":
                ax = int(np.argmax(np.abs(np.asarray(o.outward, dtype=np.float64)[:2])))
                zlo, zhi = olo.copy(), ohi.copy()
                zlo[2], zhi[2] = 0.0, max(ohi[2], 2.0)
                doors.append((zlo, zhi, ax))
        self.door_axis = np.array([d[2] for d in doors], dtype=int)
        self.door_lo = np.array([d[0] for d in doors]).reshape(-1, 3)
        self.door_hi = np.array([d[1] for d in doors]).reshape(-1, 3)
        self.hole_lo = np.array([w[0] for w in holes]).reshape(-1, 3)
        self.hole_hi = np.array([w[1] for w in holes]).reshape(-1, 3)
        # "in front of a hole": within OPENING_FRONT_M of it across its wall (its thinnest horizontal side)
        self.hole_margin = np.zeros((len(holes), 3))
        if len(holes):
            thin = np.argmin((self.hole_hi - self.hole_lo)[:, :2], axis=1)
            self.hole_margin[np.arange(len(holes)), thin] = OPENING_FRONT_M
        self._blocked = corridor_test(plan)
        c = getattr(plan, "corridor", None)
        self._seg_lo = self._seg_hi = None
        if all(hasattr(c, k) for k in ("p0", "p1", "radius")):
            p0 = np.asarray(c.p0, dtype=np.float64).reshape(-1, 2)
            p1 = np.asarray(c.p1, dtype=np.float64).reshape(-1, 2)
            r = float(c.radius) + 1e-6
            self._seg_lo, self._seg_hi = np.minimum(p0, p1) - r, np.maximum(p0, p1) + r

    def blocked(self, lo: np.ndarray, hi: np.ndarray) -> bool:
        lo2, hi2 = np.asarray(lo[:2], dtype=np.float64), np.asarray(hi[:2], dtype=np.float64)
        if self._seg_lo is not None:  # no segment's box, grown by the radius, reaches the box: not blocked
            if not np.all((self._seg_lo < hi2) & (lo2 < self._seg_hi), axis=1).any():
                return False
        return bool(self._blocked(lo2, hi2))

    def blocked_beyond_gt(self, lo: np.ndarray, hi: np.ndarray) -> bool:
        """Whether the part of the footprint lo..hi that no GT cuboid the robot must already avoid covers (one whose
        bottom is below ROBOT_HEIGHT_M) comes within the corridor: furniture there takes no floor the robot could
        use. Exact: the footprint is cut along the covering cuboids' edges and each uncovered cell is tested."""
        if not self.blocked(lo, hi):
            return False
        lo2, hi2 = np.asarray(lo[:2], dtype=np.float64), np.asarray(hi[:2], dtype=np.float64)
        m = (self.gt_lo[:, 2] < ROBOT_HEIGHT_M) & np.all((self.gt_lo[:, :2] < hi2) & (lo2 < self.gt_hi[:, :2]), axis=1)
        cl, ch = self.gt_lo[m, :2], self.gt_hi[m, :2]
        if not len(cl):
            return True
        xs = np.unique(np.clip(np.concatenate([[lo2[0], hi2[0]], cl[:, 0], ch[:, 0]]), lo2[0], hi2[0]))
        ys = np.unique(np.clip(np.concatenate([[lo2[1], hi2[1]], cl[:, 1], ch[:, 1]]), lo2[1], hi2[1]))
        for x0, x1 in zip(xs[:-1], xs[1:]):
            for y0, y1 in zip(ys[:-1], ys[1:]):
                c = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
                if np.all((cl <= c) & (c <= ch), axis=1).any():
                    continue
                if self.blocked(np.array([x0, y0]), np.array([x1, y1])):
                    return True
        return False

    def add(self, lo: np.ndarray, hi: np.ndarray) -> None:
        self.placed_lo = np.vstack([self.placed_lo, lo[None]])
        self.placed_hi = np.vstack([self.placed_hi, hi[None]])

    def why_not(self, lo: np.ndarray, hi: np.ndarray, *, gt_margin: float = 0.0, placed_margin: float = 0.0,
                corridor: bool | str = True, doors: float | bool = True, openings: bool = False) -> str | None:
        """None if the box lo..hi is free, else a short reason. ``gt_margin``/``placed_margin``: clearance kept from
        GT cuboids / supports and distractors; ``doors``: stay out of the free floor at doorways; ``openings``: do
        not stand in front of a window or door hole (a low item under a window sill is fine); ``doors`` True means
        DOOR_CLEARANCE_M, a number that clearance; ``corridor``: keep clear of the robot corridor (``"beyond_gt"``:
        only where no GT cuboid is in the robot's way already, :meth:`blocked_beyond_gt`)."""
        hit = boxes_hit(lo, hi, self.gt_lo, self.gt_hi, gt_margin)
        if hit.any():
            j = int(np.flatnonzero(hit)[0])
            return f"it would intersect GT object {self.gt_names[j] if j < len(self.gt_names) else j}"
        if boxes_hit(lo, hi, self.wall_lo, self.wall_hi, -1e-4).any():
            return "it would cut a wall"
        if boxes_hit(lo, hi, self.placed_lo, self.placed_hi, placed_margin - 1e-6).any():
            return "it would intersect a support or distractor"
        if doors is not False and len(self.door_lo):
            clear = DOOR_CLEARANCE_M if doors is True else float(doors)
            m = np.zeros((len(self.door_lo), 3))
            m[np.arange(len(self.door_lo)), self.door_axis] = clear
            if np.all((lo < self.door_hi + m - 1e-4) & (self.door_lo - m < hi - 1e-4), axis=1).any():
                return "it would stand in a doorway"
        if openings and len(self.hole_lo) and np.all((lo - self.hole_margin < self.hole_hi - 1e-6)
                                                     & (self.hole_lo - self.hole_margin < hi - 1e-6), axis=1).any():
            return "it would cover a window or door"
        if corridor == "beyond_gt":
            if self.blocked_beyond_gt(lo, hi):
                return "the floor there is in the robot corridor"
        elif corridor and self.blocked(lo, hi):
            return "the floor there is in the robot corridor"
        return None


def corridor_test(plan: Any) -> Callable[[np.ndarray, np.ndarray], bool]:
    """``blocked(lo_xy, hi_xy) -> bool`` of a plan (its ``blocked`` method, its ``corridor``'s ``blocked``, or a
    callable ``corridor``); never blocked if the plan has none."""
    f = getattr(plan, "blocked", None)
    if callable(f):
        return f
    c = getattr(plan, "corridor", None)
    if c is not None and callable(getattr(c, "blocked", None)):
        return c.blocked
    if callable(c):
        return c
    return lambda lo, hi: False


def room_of(plan: Any, xy: np.ndarray) -> Any | None:
    """The plan's room holding the point ``xy`` (2,), else the nearest one; None if the plan has no rooms."""
    rooms = list(getattr(plan, "rooms", []) or [])
    best, best_d = None, math.inf
    for r in rooms:
        rlo, rhi = np.asarray(r.lo, dtype=np.float64), np.asarray(r.hi, dtype=np.float64)
        d = float(np.linalg.norm(np.maximum(np.maximum(rlo - xy, xy - rhi), 0.0)))
        if d < best_d:
            best, best_d = r, d
    return best


def room_centre(plan: Any, xy: np.ndarray) -> np.ndarray:
    """(2,) centre of :func:`room_of` ``xy`` (of the plan's outer bounds if it has no rooms)."""
    r = room_of(plan, xy)
    if r is not None:
        return (np.asarray(r.lo, dtype=np.float64) + np.asarray(r.hi, dtype=np.float64)) / 2
    return (np.asarray(plan.outer_lo, dtype=np.float64) + np.asarray(plan.outer_hi, dtype=np.float64)) / 2


def unit_vector(v: np.ndarray) -> np.ndarray | None:
    """``v`` / |v|, or None for a (near) zero vector."""
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-9 else None


def wall_faces(space: Space, lo: np.ndarray, hi: np.ndarray, z: tuple[float, float] | None = None):
    """Wall faces in front of the footprint lo..hi: list of (gap m, away (2,) unit, axis, face coordinate), nearest
    first. A face counts if the wall overlaps the footprint along the face, and (if ``z``) that height range."""
    out = []
    for wlo, whi in zip(space.wall_lo, space.wall_hi):
        ax = int(np.argmin((whi - wlo)[:2]))
        other = 1 - ax
        if min(hi[other], whi[other]) - max(lo[other], wlo[other]) <= 1e-6:
            continue
        if z is not None and (wlo[2] > z[0] + 1e-6 or whi[2] < z[1] - 1e-6):
            continue
        if lo[ax] >= whi[ax] - 1e-9:
            gap, sign, face = lo[ax] - whi[ax], 1.0, whi[ax]
        elif hi[ax] <= wlo[ax] + 1e-9:
            gap, sign, face = wlo[ax] - hi[ax], -1.0, wlo[ax]
        else:
            continue
        away = np.zeros(2)
        away[ax] = sign
        out.append((float(gap), away, ax, float(face)))
    out.sort(key=lambda t: t[0])
    return out


def nearest_wall_away(space: Space, lo: np.ndarray, hi: np.ndarray) -> np.ndarray | None:
    """(2,) unit axis direction pointing from the wall face nearest the footprint lo..hi into the room (the
    nearest side of the plan's outer bounds when no wall box faces it)."""
    faces = wall_faces(space, lo, hi)
    if faces:
        return faces[0][1]
    plan = space.plan
    olo, ohi = np.asarray(plan.outer_lo, dtype=np.float64), np.asarray(plan.outer_hi, dtype=np.float64)
    gaps = [lo[0] - olo[0], ohi[0] - hi[0], lo[1] - olo[1], ohi[1] - hi[1]]
    return np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])[int(np.argmin(gaps))]


def furniture_of_kinds(library, kinds: Sequence[str]) -> list:
    """The non-GT assets of the first of ``kinds`` that the library has (``[]`` if none)."""
    for kd in kinds:
        assets = [a for a in library.by_kind(kd) if a.cls is None and a.kind not in GT_CLASSES]
        if assets:
            return assets
    return []


def add_placement(out: Furnishing, space: Space, a, lo, hi, k, role, bounds_of) -> None:
    """Fit asset ``a`` with ``k`` quarter turns into the box lo..hi, add it to ``out`` (a placement and
    ``out.boxes[role]``) and to the occupied ``space``."""
    out.placements.append(Placement(a.id, fit_to_cuboid(a, lo, hi, k, bounds=bounds_of(a)), -1, role))
    space.add(lo, hi)
    out.boxes.setdefault(role, []).append((lo, hi))
