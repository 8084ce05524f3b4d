"""Floor plans of the furnished homes, derived from the ground truth and the robot's paths (pure NumPy).

:func:`derive_floor_plan` turns a home's ground-truth cuboids (the union over its variants) and its robot paths into
rooms separated by walls, with doorways where the paths cross a wall, windows in the exterior walls, ceiling lamps
and the free stretches along the walls (for the furnishing step). All coordinates are metres in the ``map`` frame
(z up, floor at z = 0).

How the plan is derived:

1. The outer boundary (the inner faces of the exterior walls) encloses every cuboid by :data:`OUTER_OBJECT_MARGIN_M`
   and every path point by the robot radius plus :data:`OUTER_PATH_MARGIN_M`.
2. The boundary is split recursively by axis-aligned walls across a cell (a binary space partition). Where a wall
   line would cut a cuboid (:data:`OBJECT_MARGIN_M` clearance) or the robot's swept footprint (radius +
   :data:`PATH_MARGIN_M`), the wall gets an opening: a stretch only the paths need becomes a doorway of
   :data:`DOOR_MIN_WIDTH_M`–:data:`DOOR_MAX_WIDTH_M` with jambs (``leaf``: it takes a door); a wider stretch, or one
   holding a cuboid, becomes an open passage (open plan, no door). A wall has at most :data:`MAX_OPENINGS_PER_WALL`
   openings and is at least :data:`MIN_SOLID_FRACTION` solid, else that line is no candidate. A wall the paths never
   cross gets a doorway where the floor is clear on both sides (or none when the rooms already connect through
   others), so every room stays reachable. Both new rooms are at least :data:`MIN_ROOM_SIDE_M` a side. A cell is
   split when a candidate separates room-typical objects (bed / toilet, sink / refrigerator, oven, microwave,
   toaster / couch, tv / laptop, keyboard, mouse: a Gini gain over their :data:`TYPICAL_WEIGHTS`) or when the cell
   is larger than :data:`MAX_ROOM_AREA_M2`; candidates are ranked by that gain, balance, and the cost of passages
   (:data:`PASSAGE_COST`, :data:`STRADDLE_COST`), and the seed breaks near-ties (:data:`SEED_JITTER`), so different
   seeds may give different houses and the same seed always the same one.
   A procedural home declares its layout (``environment.layout``, :func:`home_layout`): then its outer rectangle
   and its guillotine cuts are the boundary and the walls (no search), its rooms' kinds name the rooms and its
   doors are the walls' doorways (a layout without doors: each wall's openings are found as above).
3. Rooms are named after what they hold (kitchen, bathroom, bedroom, living_room, office, else hall); exterior walls
   get windows (sill :data:`WINDOW_SILL_M`, head :data:`WINDOW_HEAD_M`) wherever no cuboid taller than the sill
   stands within :data:`WINDOW_CLEAR_DEPTH_M` of the wall; every room gets ceiling lamps on a grid of about
   :data:`LIGHT_SPACING_M`.

The wall boxes returned have the openings cut out (a doorway leaves a lintel above it, a window a parapet below
and a lintel above), so a collision or rendering test can use the boxes as they are.

:func:`derive_floor_plan` works in whatever frame its inputs are in. A home's plan (:func:`home_plan`,
:func:`plan_for_files`) is derived in the home's frame (:mod:`benchbot_worlds.homes.home_frame`: the symmetry of
the square that brings every turned or mirrored copy of a layout to the same orientation, and an origin at the
layout's lowest corner, coordinates rounded to a micrometre), then carried to the map frame, so that a turned or
moved layout gets the same plan turned or moved. Every variant of a home that declares the same ``home_files`` and
is built with the same seed (the home's: :func:`benchbot.core.seeding.home_seed`) gets the same plan.
"""

from __future__ import annotations

import functools
import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchbot.core.errors import BackendError
from benchbot.core.geometry import pose7_to_se2

#: Thickness of every wall, metres.
WALL_THICKNESS_M = 0.12
#: Lowest wall (ceiling) height, metres; the walls are at least :data:`WALL_CLEARANCE_ABOVE_M` above the tallest cuboid.
WALL_HEIGHT_MIN_M = 2.6
#: Clearance between the tallest cuboid and the ceiling, metres.
WALL_CLEARANCE_ABOVE_M = 0.3
#: Smallest xy gap between a wall box and a ground-truth cuboid, metres.
OBJECT_MARGIN_M = 0.05
#: Smallest gap between a wall box and the robot's swept footprint (beyond the robot radius), metres.
PATH_MARGIN_M = 0.05
#: Gap between the outermost cuboids and the exterior walls' inner faces, metres.
OUTER_OBJECT_MARGIN_M = 0.15
#: Gap between the robot's footprint at the outermost path points and the exterior walls' inner faces, metres.
OUTER_PATH_MARGIN_M = 0.15
#: Smallest room side, metres, measured between wall centre lines.
MIN_ROOM_SIDE_M = 2.5
#: A room larger than this (m²) is split further even when the split separates no room-typical objects.
MAX_ROOM_AREA_M2 = 30.0
#: Doorway widths, metres: a doorway is at least the minimum; a wider stretch the paths need is an open passage.
DOOR_MIN_WIDTH_M = 0.9
DOOR_MAX_WIDTH_M = 1.6
#: Height of a doorway's head (the lintel's underside), metres.
DOOR_HEAD_M = 2.1
#: Smallest stretch of wall between a doorway and the end of its wall, metres.
DOOR_JAMB_M = 0.15
#: Two doorways of one wall closer than this (metres) become one.
DOOR_MERGE_GAP_M = 0.5
#: Most openings (doorways and open passages) in one wall.
MAX_OPENINGS_PER_WALL = 2
#: A wall is at least this fraction solid (the rest: doorways and open passages), else it is not built.
MIN_SOLID_FRACTION = 0.5
#: Shortest solid stretch of wall between an open passage and the wall's end, metres (shorter: the passage runs on).
MIN_SOLID_PIECE_M = 0.3
#: Score costs in choosing walls: per metre of open passage (open plan), per cuboid standing in a passage.
PASSAGE_COST = 0.25
STRADDLE_COST = 0.3
#: Depth (metres) of floor that must be free of cuboids on both sides of a doorway the paths do not use.
DOOR_APPROACH_M = 0.7
#: Windows: sill and head heights, width, one window per this much exterior wall, metres.
WINDOW_SILL_M = 0.9
WINDOW_HEAD_M = 2.1
WINDOW_WIDTH_M = 1.2
WINDOW_SPACING_M = 3.0
#: No window where a cuboid taller than the sill stands within this distance (metres) of the wall's inner face.
WINDOW_CLEAR_DEPTH_M = 0.3
#: Smallest stretch of wall between a window and the end of its wall (or the next window), metres.
WINDOW_END_GAP_M = 0.3
#: Ceiling lamps: about one per this many metres of room side; hung this far below the ceiling.
LIGHT_SPACING_M = 4.0
LIGHT_DROP_M = 0.3
#: Stretches of wall shorter than this (metres) are not offered to the furnishing step.
MIN_WALL_SPAN_M = 0.3
#: Free wall kept on each side of a doorway for its swing and its frame (metres), not offered to the furnishing step.
DOOR_SPAN_CLEARANCE_M = 0.2
#: Step (metres) between candidate wall positions.
CANDIDATE_STEP_M = 0.05
#: The seed's weight in choosing among candidate walls (0 = every seed gives the same house).
SEED_JITTER = 0.3

ROOM_KINDS = ("kitchen", "bathroom", "bedroom", "living_room", "office", "hall")

#: Room-typical classes: their weight towards each room kind. They decide splits and room kinds.
TYPICAL_WEIGHTS: dict[str, dict[str, float]] = {
    "bed": {"bedroom": 8.0},
    "toilet": {"bathroom": 5.0},
    "sink": {"bathroom": 1.5, "kitchen": 1.0},
    "refrigerator": {"kitchen": 4.0},
    "oven": {"kitchen": 3.0},
    "microwave": {"kitchen": 3.0},
    "toaster": {"kitchen": 2.0},
    "couch": {"living_room": 3.0},
    "tv": {"living_room": 2.0},
    "laptop": {"office": 3.0},
    "keyboard": {"office": 2.0},
    "mouse": {"office": 1.0},
}
#: Weaker hints, used only to name rooms (never to split them).
HINT_WEIGHTS: dict[str, dict[str, float]] = {
    "book": {"office": 0.3},
    "table": {"living_room": 0.3},
    "chair": {"living_room": 0.2},
    "bowl": {"kitchen": 0.2},
    "cup": {"kitchen": 0.2},
    "knife": {"kitchen": 0.3},
    "fork": {"kitchen": 0.3},
    "spoon": {"kitchen": 0.3},
}
#: A room whose best kind scores less than this is a hall.
KIND_MIN_SCORE = 1.0


@dataclass(frozen=True)
class Room:
    """A rectangular room. ``lo``/``hi``: (2,) float64 corners of its clear floor (between the walls' inner faces);
    ``kind``: one of :data:`ROOM_KINDS`."""

    index: int
    lo: np.ndarray
    hi: np.ndarray
    kind: str


@dataclass(frozen=True)
class Wall:
    """One axis-aligned wall box, ``lo``/``hi`` (3,) float64, openings already cut out. ``rooms`` = (a, b): the rooms
    on its low and high side along its thin axis, −1 for outside; for an exterior wall (room, −1)."""

    lo: np.ndarray
    hi: np.ndarray
    exterior: bool
    rooms: tuple[int, int]


@dataclass(frozen=True)
class Opening:
    """A doorway or window: ``kind`` "door" | "window"; ``lo``/``hi`` (3,) the hole's box (through the wall's
    thickness); ``wall`` the index (into :attr:`FloorPlan.walls`) of the wall box above the hole (its lintel),
    else of the box below it (a window's parapet), else of the wall box beside it (an open passage running the
    wall's full height); ``outward`` (2,) the unit normal from ``rooms[0]`` to ``rooms[1]`` (outside for a window);
    ``rooms`` the wall's rooms; ``leaf``: a doorway that takes a door (at most :data:`DOOR_MAX_WIDTH_M` wide, jambs
    on both sides) — False for an open passage (open plan: no door model) and for windows."""

    kind: str
    lo: np.ndarray
    hi: np.ndarray
    wall: int
    outward: np.ndarray
    rooms: tuple[int, int] = (-1, -1)
    leaf: bool = False


@dataclass(frozen=True)
class WallSpan:
    """A free stretch ``a``→``b`` ((2,) xy, metres) along the inner face of a wall of room ``room``, doorways (and
    :data:`DOOR_SPAN_CLEARANCE_M` beside them) excluded; ``inward`` (2,) the unit normal into the room;
    ``max_height`` (m): the tallest furniture that may stand there (:data:`WINDOW_SILL_M` under a window, else the
    wall height). Ground-truth cuboids and the robot corridor are not subtracted: the furnishing step checks them."""

    room: int
    a: np.ndarray
    b: np.ndarray
    inward: np.ndarray
    max_height: float


class Corridor:
    """The robot's swept paths: segments ``p0``/``p1`` (S, 2) float64 and a radius (m).

    ``blocked(lo_xy, hi_xy)`` tells whether an xy box comes within the radius (plus ``margin``) of any segment.
    """

    def __init__(self, p0: np.ndarray, p1: np.ndarray, radius: float) -> None:
        self.p0 = np.asarray(p0, dtype=np.float64).reshape(-1, 2)
        self.p1 = np.asarray(p1, dtype=np.float64).reshape(-1, 2)
        self.radius = float(radius)

    @classmethod
    def from_paths(cls, paths: list, radius: float) -> Corridor:
        """Corridor of a list of (M, 2) xy paths (consecutive points form segments; one point is a segment of
        length 0)."""
        p0, p1 = _segments(paths)
        return cls(p0, p1, radius)

    def distance(self, lo_xy, hi_xy) -> float:
        """Smallest distance (m) from the box ``lo_xy``..``hi_xy`` to any segment (inf when there is none)."""
        if not len(self.p0):
            return float("inf")
        return float(segment_box_distance(self.p0, self.p1, lo_xy, hi_xy).min())

    def blocked(self, lo_xy, hi_xy, margin: float = 0.0) -> bool:
        """True when the xy box ``lo_xy``..``hi_xy`` is closer than radius + ``margin`` to a segment."""
        return self.distance(lo_xy, hi_xy) < self.radius + margin

    __call__ = blocked


@dataclass(frozen=True)
class FloorPlan:
    """A home's floor plan (metres, ``map`` frame). ``outer_lo``/``outer_hi`` (2,): the inner faces of the exterior
    walls; ``wall_height``, ``wall_thickness``; ``rooms``, ``walls`` (openings cut out), ``openings``, ``lights``
    (list of (3,) ceiling-lamp positions, at least one per room), ``wall_spans``, and ``corridor`` (its
    ``blocked(lo_xy, hi_xy)`` is the robot-corridor test)."""

    outer_lo: np.ndarray
    outer_hi: np.ndarray
    wall_height: float
    wall_thickness: float
    rooms: list[Room]
    walls: list[Wall]
    openings: list[Opening]
    lights: list[np.ndarray]
    wall_spans: list[WallSpan]
    corridor: Corridor = field(repr=False)

    def blocked(self, lo_xy, hi_xy, margin: float = 0.0) -> bool:
        """:meth:`Corridor.blocked` of this plan's corridor."""
        return self.corridor.blocked(lo_xy, hi_xy, margin)

    def room_at(self, xy) -> int:
        """Index of the room whose floor (between its walls' centre lines) holds the point ``xy``, else −1."""
        x, y = float(xy[0]), float(xy[1])
        h = self.wall_thickness / 2 + 1e-9
        for r in self.rooms:
            if r.lo[0] - h <= x <= r.hi[0] + h and r.lo[1] - h <= y <= r.hi[1] + h:
                return r.index
        return -1

    def to_dict(self) -> dict:
        """A JSON-ready dict of the plan (without the corridor function): for comparisons, caches and figures."""
        def f(a):
            return [round(float(v), 6) for v in np.ravel(a)]

        return {
            "outer_lo": f(self.outer_lo), "outer_hi": f(self.outer_hi),
            "wall_height": round(self.wall_height, 6), "wall_thickness": round(self.wall_thickness, 6),
            "rooms": [{"index": r.index, "lo": f(r.lo), "hi": f(r.hi), "kind": r.kind} for r in self.rooms],
            "walls": [{"lo": f(w.lo), "hi": f(w.hi), "exterior": w.exterior, "rooms": list(w.rooms)}
                      for w in self.walls],
            "openings": [{"kind": o.kind, "lo": f(o.lo), "hi": f(o.hi), "wall": o.wall, "outward": f(o.outward),
                          "rooms": list(o.rooms), "leaf": o.leaf} for o in self.openings],
            "lights": [f(p) for p in self.lights],
            "wall_spans": [{"room": s.room, "a": f(s.a), "b": f(s.b), "inward": f(s.inward),
                            "max_height": round(s.max_height, 6)} for s in self.wall_spans],
        }

    def digest(self) -> str:
        """SHA-256 hex digest (64 characters) of :meth:`to_dict` (coordinates to a micrometre): equal for equal plans,
        e.g. those of a home's variants; another for a plan moved or turned (the plan is in the map frame)."""
        text = json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode("utf-8")).hexdigest()

    def summary(self) -> str:
        """One line of counts: rooms, doorways that take a door, open passages, windows, ceiling lamps."""
        doors = sum(o.kind == "door" and o.leaf for o in self.openings)
        passages = sum(o.kind == "door" and not o.leaf for o in self.openings)
        windows = sum(o.kind == "window" for o in self.openings)
        counts = ((len(self.rooms), "room"), (doors, "door"), (passages, "open passage"), (windows, "window"),
                  (len(self.lights), "lamp"))
        return ", ".join(f"{n} {what}{'' if n == 1 else 's'}" for n, what in counts)


# ---------------------------------------------------------------------------------------------------------------
# geometry helpers


def _segments(paths: list) -> tuple[np.ndarray, np.ndarray]:
    """(S, 2) start and end points of every segment of ``paths`` (a one-point path is a segment of length 0)."""
    p0, p1 = [], []
    for k, p in enumerate(paths):
        a = np.asarray(p, dtype=np.float64)
        if a.ndim != 2 or a.shape[1] != 2 or not len(a) or not np.all(np.isfinite(a)):
            raise BackendError(f"floor plan: path {k} has shape {a.shape} or non-finite values",
                               "each path is an (M, 2) array of finite xy positions, M >= 1")
        if len(a) == 1:
            a = np.concatenate([a, a])
        p0.append(a[:-1])
        p1.append(a[1:])
    if not p0:
        return np.zeros((0, 2)), np.zeros((0, 2))
    return np.concatenate(p0), np.concatenate(p1)


def _point_box_distance(p: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    d = np.maximum(np.maximum(lo - p, p - hi), 0.0)
    return np.hypot(d[..., 0], d[..., 1])


def _point_segment_distance(q: np.ndarray, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
    d = p1 - p0
    dd = np.einsum("...i,...i->...", d, d)
    t = np.where(dd > 0, np.einsum("...i,...i->...", q - p0, d) / np.where(dd > 0, dd, 1.0), 0.0)
    t = np.clip(t, 0.0, 1.0)
    c = p0 + t[..., None] * d
    return np.hypot(q[..., 0] - c[..., 0], q[..., 1] - c[..., 1])


def segment_box_distance(p0: np.ndarray, p1: np.ndarray, lo_xy, hi_xy) -> np.ndarray:
    """Exact distance (m) from each segment ``p0[i]``→``p1[i]`` ((S, 2) each) to the xy box ``lo_xy``..``hi_xy``:
    0 where the segment touches the box; (S,) float64."""
    p0 = np.asarray(p0, dtype=np.float64).reshape(-1, 2)
    p1 = np.asarray(p1, dtype=np.float64).reshape(-1, 2)
    lo = np.asarray(lo_xy, dtype=np.float64).reshape(2)
    hi = np.asarray(hi_xy, dtype=np.float64).reshape(2)
    # Liang–Barsky: does the segment meet the box?
    d = p1 - p0
    t0 = np.zeros(len(p0))
    t1 = np.ones(len(p0))
    outside = np.zeros(len(p0), dtype=bool)
    for ax in range(2):
        par = np.abs(d[:, ax]) < 1e-15
        outside |= par & ((p0[:, ax] < lo[ax]) | (p0[:, ax] > hi[ax]))
        with np.errstate(divide="ignore", invalid="ignore"):
            ta = (lo[ax] - p0[:, ax]) / d[:, ax]
            tb = (hi[ax] - p0[:, ax]) / d[:, ax]
        t0 = np.where(par, t0, np.maximum(t0, np.minimum(ta, tb)))
        t1 = np.where(par, t1, np.minimum(t1, np.maximum(ta, tb)))
    hit = ~outside & (t0 <= t1)
    # Disjoint convex sets in the plane: the closest pair has a vertex of one of them.
    corners = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [lo[0], hi[1]], [hi[0], hi[1]]])
    dist = np.minimum(_point_box_distance(p0, lo, hi), _point_box_distance(p1, lo, hi))
    for c in corners:
        dist = np.minimum(dist, _point_segment_distance(c[None, :], p0, p1))
    return np.where(hit, 0.0, dist)


def blocked(plan_or_paths, lo_xy, hi_xy, *, robot_radius_m: float = 0.35, margin: float = 0.0) -> bool:
    """Corridor test: True when the xy box ``lo_xy``..``hi_xy`` comes within the robot radius (+ ``margin``) of a
    path segment. ``plan_or_paths``: a :class:`FloorPlan` (its corridor and radius; ``robot_radius_m`` ignored), a
    :class:`Corridor`, or a list of (M, 2) xy paths."""
    if isinstance(plan_or_paths, FloorPlan):
        return plan_or_paths.blocked(lo_xy, hi_xy, margin)
    if isinstance(plan_or_paths, Corridor):
        return plan_or_paths.blocked(lo_xy, hi_xy, margin)
    return Corridor.from_paths(plan_or_paths, robot_radius_m).blocked(lo_xy, hi_xy, margin)


# ---------------------------------------------------------------------------------------------------------------
# the partition


@dataclass
class _Cell:
    lo: np.ndarray  # wall centre lines (exterior sides: the walls' inner faces)
    hi: np.ndarray
    objs: np.ndarray  # indices of the cuboids inside


@dataclass
class _Split:
    axis: int  # the wall is the line x[axis] = pos
    pos: float
    lo: float  # its extent along the other axis (centre lines / exterior inner faces)
    hi: float
    openings: list  # [(a, b, "door" | "passage")] along the other axis


class _Planner:
    def __init__(self, objects, paths, seed, radius):
        self.t = WALL_THICKNESS_M
        self.r = float(radius)
        self.rng = np.random.default_rng(seed)
        lo, hi, cls = [], [], []
        for k, o in enumerate(objects):
            try:
                c = np.asarray(o["centroid"], dtype=np.float64).reshape(3)
                e = np.abs(np.asarray(o["extent"], dtype=np.float64).reshape(3))
                name = str(o["class"])
            except (KeyError, TypeError, ValueError) as exc:
                raise BackendError(f"floor plan: object {k} ({o.get('ID_name', '?') if isinstance(o, dict) else o!r})"
                                   f" lacks a class, a 3-number centroid or a 3-number extent ({exc})",
                                   "objects are ground-truth dicts with class, centroid [x,y,z], extent [dx,dy,dz]")
            if not (np.all(np.isfinite(c)) and np.all(np.isfinite(e))):
                raise BackendError(f"floor plan: object {k} has a non-finite centroid or extent",
                                   "fix the ground-truth file")
            lo.append(c - e / 2)
            hi.append(c + e / 2)
            cls.append(name)
        self.olo = np.asarray(lo, dtype=np.float64).reshape(-1, 3)
        self.ohi = np.asarray(hi, dtype=np.float64).reshape(-1, 3)
        self.cls = cls
        self.p0, self.p1 = _segments(paths)
        if not len(self.olo) and not len(self.p0):
            raise BackendError("floor plan: no objects and no path to derive a floor plan from",
                               "give the environment ground-truth objects or a start pose")
        # typical weights (splitting) per object, (N, K)
        self.kinds = ROOM_KINDS[:-1]
        self.w = np.zeros((len(cls), len(self.kinds)))
        self.hint = np.zeros((len(cls), len(self.kinds)))
        for i, name in enumerate(cls):
            for k, v in TYPICAL_WEIGHTS.get(name, {}).items():
                self.w[i, self.kinds.index(k)] = v
            for k, v in HINT_WEIGHTS.get(name, {}).items():
                self.hint[i, self.kinds.index(k)] = v
        pts = np.concatenate([self.p0, self.p1]) if len(self.p0) else np.zeros((0, 2))
        blo = [a for a in (self.olo[:, :2].min(0) - OUTER_OBJECT_MARGIN_M if len(self.olo) else None,
                           pts.min(0) - self.r - OUTER_PATH_MARGIN_M if len(pts) else None) if a is not None]
        bhi = [a for a in (self.ohi[:, :2].max(0) + OUTER_OBJECT_MARGIN_M if len(self.olo) else None,
                           pts.max(0) + self.r + OUTER_PATH_MARGIN_M if len(pts) else None) if a is not None]
        self.outer_lo = np.min(blo, axis=0)
        self.outer_hi = np.max(bhi, axis=0)
        top = float(self.ohi[:, 2].max()) if len(self.ohi) else 0.0
        self.height = max(WALL_HEIGHT_MIN_M, top + WALL_CLEARANCE_ABOVE_M)
        self.splits: list[_Split] = []
        # fake path segments through doorways the paths do not use (later walls keep clear of them)
        self.res0 = np.zeros((0, 2))
        self.res1 = np.zeros((0, 2))

    # -- scoring ------------------------------------------------------------------------------------------------

    @staticmethod
    def _impurity(w: np.ndarray) -> float:
        s = float(w.sum())
        return 0.0 if s <= 0 else s - float((w * w).sum()) / s

    def _centres(self, idx):
        return (self.olo[idx, :2] + self.ohi[idx, :2]) / 2

    # -- candidates ---------------------------------------------------------------------------------------------

    def _span(self, cell: _Cell, o: int) -> tuple[float, float]:
        """Extent of a wall across ``cell`` along axis ``o``: from face to face of the walls it meets."""
        a = cell.lo[o] + (0.0 if cell.lo[o] == self.outer_lo[o] else self.t / 2)
        b = cell.hi[o] - (0.0 if cell.hi[o] == self.outer_hi[o] else self.t / 2)
        return a, b

    def _overlapping(self, cell: _Cell) -> np.ndarray:
        """Indices of the cuboids whose xy box reaches into ``cell`` (an open passage lets one straddle a room
        boundary)."""
        m = OBJECT_MARGIN_M + self.t
        inside = np.all(self.olo[:, :2] < cell.hi + m, axis=1) & np.all(self.ohi[:, :2] > cell.lo - m, axis=1)
        return np.nonzero(inside)[0]

    def _positions(self, cell: _Cell, ax: int) -> np.ndarray:
        """Candidate wall positions along ``ax``: rooms of at least :data:`MIN_ROOM_SIDE_M` on both sides, and not
        ending in (or beside) an opening of the walls the new wall would meet."""
        lo = cell.lo[ax] + MIN_ROOM_SIDE_M
        hi = cell.hi[ax] - MIN_ROOM_SIDE_M
        if hi < lo:
            return np.zeros(0)
        n = int(np.floor((hi - lo) / CANDIDATE_STEP_M + 1e-9)) + 1
        c = lo + CANDIDATE_STEP_M * np.arange(n)
        c = c + ((hi - lo) - CANDIDATE_STEP_M * (n - 1)) / 2  # centred grid
        ok = np.ones(len(c), dtype=bool)
        o = 1 - ax
        for s in self.splits:
            if s.axis != o or s.pos not in (cell.lo[o], cell.hi[o]):
                continue
            if s.hi <= cell.lo[ax] or s.lo >= cell.hi[ax]:
                continue
            for a, b, _ in s.openings:
                ok &= ~((c > a - self.t / 2 - DOOR_JAMB_M) & (c < b + self.t / 2 + DOOR_JAMB_M))
        return c[ok]

    def _object_intervals(self, cell: _Cell, c: np.ndarray, ax: int) -> list[list]:
        """Per candidate position: the stretches (along the other axis) where the wall would cut a cuboid."""
        o = 1 - ax
        idx = self._overlapping(cell)
        g = self.t / 2 + OBJECT_MARGIN_M
        hit = (self.olo[idx, ax][None, :] < c[:, None] + g) & (self.ohi[idx, ax][None, :] > c[:, None] - g)
        a = self.olo[idx, o] - OBJECT_MARGIN_M
        b = self.ohi[idx, o] + OBJECT_MARGIN_M
        return [list(zip(a[m].tolist(), b[m].tolist())) for m in hit]

    def _path_intervals(self, c: np.ndarray, ax: int, span) -> list[list]:
        """Per candidate position: the stretches (along the other axis) of the wall that the swept paths touch."""
        o = 1 - ax
        p0 = np.concatenate([self.p0, self.res0])
        p1 = np.concatenate([self.p1, self.res1])
        h = self.t / 2 + self.r + PATH_MARGIN_M
        # only segments near the wall's extent
        near = (np.maximum(p0[:, o], p1[:, o]) >= span[0] - h) & (np.minimum(p0[:, o], p1[:, o]) <= span[1] + h)
        near &= (np.maximum(p0[:, ax], p1[:, ax]) >= c.min() - h) & (np.minimum(p0[:, ax], p1[:, ax]) <= c.max() + h)
        p0, p1 = p0[near], p1[near]
        out: list[list] = [[] for _ in c]
        if not len(p0):
            return out
        d = (p1[:, ax] - p0[:, ax])[None, :]
        par = np.abs(d) < 1e-12
        with np.errstate(divide="ignore", invalid="ignore"):
            ta = (c[:, None] - h - p0[None, :, ax]) / d
            tb = (c[:, None] + h - p0[None, :, ax]) / d
        inside_par = np.abs(p0[None, :, ax] - c[:, None]) <= h
        s0 = np.where(par, np.where(inside_par, 0.0, 1.0), np.maximum(np.minimum(ta, tb), 0.0))
        s1 = np.where(par, np.where(inside_par, 1.0, 0.0), np.minimum(np.maximum(ta, tb), 1.0))
        valid = s0 <= s1
        do = (p1[:, o] - p0[:, o])[None, :]
        y0 = p0[None, :, o] + s0 * do
        y1 = p0[None, :, o] + s1 * do
        ext = self.r + PATH_MARGIN_M
        ilo = np.minimum(y0, y1) - ext
        ihi = np.maximum(y0, y1) + ext
        valid &= (ihi > span[0]) & (ilo < span[1])
        for k in np.nonzero(valid.any(axis=1))[0]:
            m = valid[k]
            a, b = ilo[k, m], ihi[k, m]
            order = np.argsort(a, kind="stable")
            a, b = a[order], b[order]
            new = np.ones(len(a), dtype=bool)
            new[1:] = a[1:] > np.maximum.accumulate(b)[:-1] + DOOR_MERGE_GAP_M
            starts = np.nonzero(new)[0]
            out[k] = list(zip(a[starts].tolist(), np.maximum.reduceat(b, starts).tolist()))  # merged
        return out

    @staticmethod
    def _merge(ivs: list) -> list[list]:
        """Merge (a, b, solid_object) intervals closer than :data:`DOOR_MERGE_GAP_M`; the flag is or-ed."""
        merged: list[list] = []
        for a, b, f in sorted(ivs):
            if merged and a <= merged[-1][1] + DOOR_MERGE_GAP_M:
                merged[-1][1] = max(merged[-1][1], b)
                merged[-1][2] = merged[-1][2] or f
            else:
                merged.append([a, b, f])
        return merged

    def _openings(self, obj_iv: list, path_iv: list, span, strict: bool = True) -> list | None:
        """The openings (a, b, "door" | "passage") a wall across ``span`` needs so that it cuts no cuboid and no
        swept path, or None when such a wall would be mostly openings.

        A stretch only the paths need becomes a doorway (at least :data:`DOOR_MIN_WIDTH_M`, with a jamb of
        :data:`DOOR_JAMB_M` at both ends); a stretch wider than :data:`DOOR_MAX_WIDTH_M`, holding a cuboid or near
        the wall's end becomes an open passage (open plan: no door leaf; at the wall's end the wall stops).
        ``strict=False`` (a given wall, :func:`derive_floor_plan` with a layout): never None, however open."""
        s0, s1 = span
        length = s1 - s0
        groups = self._merge([(a, b, True) for a, b in obj_iv] + [(a, b, False) for a, b in path_iv])
        out = []
        for a, b, has_obj in groups:
            a, b = max(a, s0), min(b, s1)
            if b <= a:
                continue
            if not has_obj and b - a <= DOOR_MAX_WIDTH_M:
                w = max(DOOR_MIN_WIDTH_M, b - a)
                m = (a + b) / 2
                d0, d1 = max(m - w / 2, s0 + DOOR_JAMB_M), min(m + w / 2, s1 - DOOR_JAMB_M)
                if d1 - d0 < w - 1e-9:  # squeezed by a wall end: slide it along
                    d0, d1 = (s0 + DOOR_JAMB_M, s0 + DOOR_JAMB_M + w) if d0 <= s0 + DOOR_JAMB_M else (
                        s1 - DOOR_JAMB_M - w, s1 - DOOR_JAMB_M)
                # (the doorway of a stretch of its own width starts at a and ends at b but for the last bit)
                if d0 >= s0 + DOOR_JAMB_M - 1e-9 and d1 <= s1 + 1e-9 - DOOR_JAMB_M and d0 <= a + 1e-9 \
                        and d1 >= b - 1e-9:
                    out.append([d0, d1, False])
                    continue
            # an open passage; near a wall end it runs to the end
            if a - s0 < DOOR_JAMB_M + MIN_SOLID_PIECE_M:
                a = s0
            if s1 - b < DOOR_JAMB_M + MIN_SOLID_PIECE_M:
                b = s1
            out.append([a, b, True])
        out = self._merge([tuple(x) for x in out])
        if strict and len(out) > MAX_OPENINGS_PER_WALL:
            return None
        open_len = sum(b - a for a, b, _ in out)
        if strict and length - open_len < MIN_SOLID_FRACTION * length:
            return None
        res = []
        for a, b, passage in out:
            kind = "passage" if passage or b - a > DOOR_MAX_WIDTH_M else "door"
            res.append((float(a), float(b), kind))
        return res

    def _approach_clear(self, cell: _Cell, ax: int, pos: float, d0: float, d1: float) -> bool:
        o = 1 - ax
        lo = np.zeros(2)
        hi = np.zeros(2)
        lo[ax], hi[ax] = pos - self.t / 2 - DOOR_APPROACH_M, pos + self.t / 2 + DOOR_APPROACH_M
        lo[o], hi[o] = d0, d1
        for i in self._overlapping(cell):
            if np.all(self.olo[i, :2] < hi + OBJECT_MARGIN_M) and np.all(self.ohi[i, :2] > lo - OBJECT_MARGIN_M):
                return False
        return True

    def _connect_door(self, cell: _Cell, ax: int, pos: float, span, openings):
        """A doorway for a wall the paths do not cross: clear floor on both sides, nearest the wall's middle, away
        from its other openings."""
        lo, hi = span[0] + DOOR_JAMB_M, span[1] - DOOR_JAMB_M - DOOR_MIN_WIDTH_M
        if hi < lo:
            return None
        starts = np.arange(lo, hi + 1e-9, CANDIDATE_STEP_M)
        mid = (span[0] + span[1] - DOOR_MIN_WIDTH_M) / 2
        for s in starts[np.argsort(np.abs(starts - mid), kind="stable")]:
            e = s + DOOR_MIN_WIDTH_M
            if any(s < b + MIN_SOLID_PIECE_M and e > a - MIN_SOLID_PIECE_M for a, b, _ in openings):
                continue
            if self._approach_clear(cell, ax, pos, s, e):
                return (float(s), float(e), "door")
        return None

    def _children(self, cell: _Cell, ax: int, pos: float) -> tuple[_Cell, _Cell]:
        left = self._centres(cell.objs)[:, ax] < pos
        lhi = cell.hi.copy()
        lhi[ax] = pos
        rlo = cell.lo.copy()
        rlo[ax] = pos
        return _Cell(cell.lo.copy(), lhi, cell.objs[left]), _Cell(rlo, cell.hi.copy(), cell.objs[~left])

    def _connected(self, cells: list[_Cell], extra: _Split | None = None) -> bool:
        """Whether ``cells`` (a partition of the boundary) form one graph through the openings of the walls."""
        n = len(cells)
        parent = list(range(n))

        def find(i):
            while parent[i] != i:
                parent[i] = parent[parent[i]]
                i = parent[i]
            return i

        for s in self.splits + ([extra] if extra is not None else []):
            ax, o = s.axis, 1 - s.axis
            lows = [i for i, c in enumerate(cells) if c.hi[ax] == s.pos]
            highs = [j for j, c in enumerate(cells) if c.lo[ax] == s.pos]
            for a, b, _ in s.openings:
                for i in lows:
                    for j in highs:
                        lo = max(a, cells[i].lo[o], cells[j].lo[o])
                        hi = min(b, cells[i].hi[o], cells[j].hi[o])
                        if hi - lo > 1e-6:
                            parent[find(i)] = find(j)
        return len({find(i) for i in range(n)}) == 1

    def _best_split(self, cell: _Cell, others: list[_Cell]):
        """The best wall across ``cell`` as (axis, position, openings), or None to keep it one room. ``others``:
        the rest of the current partition (to keep every room reachable)."""
        area = float(np.prod(cell.hi - cell.lo))
        w_cell = self.w[cell.objs].sum(axis=0) if len(cell.objs) else np.zeros(len(self.kinds))
        imp = self._impurity(w_cell)
        centres = self._centres(cell.objs)
        ranked = []
        for ax in (0, 1):
            o = 1 - ax
            cands = self._positions(cell, ax)
            if not len(cands):
                continue
            span = self._span(cell, o)
            piv = self._path_intervals(cands, ax, span)
            oiv = self._object_intervals(cell, cands, ax)
            jitter = self.rng.uniform(0.0, SEED_JITTER, len(cands))
            for k, pos in enumerate(cands):
                openings = self._openings(oiv[k], piv[k], span)
                if openings is None:
                    continue
                left = centres[:, ax] < pos
                wl = self.w[cell.objs[left]].sum(axis=0)
                wr = self.w[cell.objs[~left]].sum(axis=0)
                gain = imp - self._impurity(wl) - self._impurity(wr)
                if gain <= 0.5 and area <= MAX_ROOM_AREA_M2:
                    continue
                al = (pos - cell.lo[ax]) / (cell.hi[ax] - cell.lo[ax])
                balance = min(al, 1 - al) / max(al, 1 - al)
                torn = float(np.minimum(wl, wr).sum())  # a room-type group cut in two
                passage = sum(b - a for a, b, kind in openings if kind == "passage")
                straddled = sum(1 for a, b in oiv[k] if b > span[0] and a < span[1])
                score = (gain + balance - 0.5 * torn - 0.2 * max(0, len(openings) - 1) - PASSAGE_COST * passage
                         - STRADDLE_COST * straddled + jitter[k])
                ranked.append((-score, ax, k, float(pos), openings))
        ranked.sort(key=lambda r: (r[0], r[1], r[2]))
        for _, ax, _, pos, openings in ranked:
            if openings:
                return ax, pos, openings
            # no path crosses this wall: a doorway where the floor is clear, unless the rooms connect anyway
            span = self._span(cell, 1 - ax)
            door = self._connect_door(cell, ax, pos, span, openings)
            if door is not None:
                m = (door[0] + door[1]) / 2
                a, b = np.zeros(2), np.zeros(2)
                a[ax], b[ax] = pos - 0.5, pos + 0.5
                a[1 - ax] = b[1 - ax] = m
                self.res0 = np.concatenate([self.res0, a[None]])
                self.res1 = np.concatenate([self.res1, b[None]])
                return ax, pos, [door]
            o = 1 - ax
            if self._connected(others + list(self._children(cell, ax, pos)),
                               _Split(ax, pos, cell.lo[o], cell.hi[o], [])):
                return ax, pos, []
        return None

    def partition(self) -> list[_Cell]:
        root = _Cell(self.outer_lo.copy(), self.outer_hi.copy(), np.arange(len(self.olo)))
        stack, leaves = [root], []
        while stack:
            cell = stack.pop()
            sp = self._best_split(cell, leaves + stack)
            if sp is None:
                leaves.append(cell)
                continue
            ax, pos, openings = sp
            o = 1 - ax
            self.splits.append(_Split(ax, pos, cell.lo[o], cell.hi[o], openings))
            left, right = self._children(cell, ax, pos)
            stack.append(right)
            stack.append(left)
        leaves.sort(key=lambda c: (round(float(c.lo[1]), 6), round(float(c.lo[0]), 6)))
        return leaves


    def given_partition(self, layout: dict) -> list[_Cell]:
        """The cells of a given layout's cuts (``layout["cuts"]`` [[axis, pos, lo, hi], ...] in the order made, in
        this planner's frame; the outer boundary already set to ``layout["outer"]``). A layout that lists its
        ``doors`` ([{axis, pos, lo, hi, rooms}], as :func:`benchbot_worlds.procedural.layout.layout_to_dict` writes
        them) gets exactly those doorways in its walls (each takes a door); one without gets, in each wall, the
        openings the paths need (:meth:`_openings`, never refused) or, when they need none, a connecting doorway
        where the floor is clear (:meth:`_connect_door`), as :meth:`partition` gives its walls.

        Raises:
            BackendError: a cut does not run across exactly one cell from side to side.
        """
        leaves = [_Cell(self.outer_lo.copy(), self.outer_hi.copy(), np.arange(len(self.olo)))]
        for k, (ax, pos, lo, hi) in enumerate(layout["cuts"]):
            ax, pos, o = int(ax), float(pos), 1 - int(ax)
            hits = [i for i, c in enumerate(leaves)
                    if c.lo[ax] < pos < c.hi[ax] and c.lo[o] == float(lo) and c.hi[o] == float(hi)]
            if len(hits) != 1:
                raise BackendError(f"floor plan: the layout's cut {k} {[ax, pos, lo, hi]} does not run across one "
                                   "cell of the cuts before it", "give guillotine cuts in the order they were made")
            cell = leaves.pop(hits[0])
            span = self._span(cell, o)
            c = np.array([pos])
            if "doors" in layout:  # the layout's own doorways in this wall, and no other opening
                openings = sorted((float(d["lo"]), float(d["hi"]), "door") for d in layout["doors"]
                                  if int(d["axis"]) == ax and abs(float(d["pos"]) - pos) < 1e-6
                                  and float(d["lo"]) >= span[0] - 1e-6 and float(d["hi"]) <= span[1] + 1e-6)
            else:
                openings = self._openings(self._object_intervals(cell, c, ax)[0],
                                          self._path_intervals(c, ax, span)[0], span, strict=False)
            if not openings and "doors" not in layout:
                door = self._connect_door(cell, ax, pos, span, openings)
                if door is not None:
                    openings = [door]
                    m = (door[0] + door[1]) / 2
                    a, b = np.zeros(2), np.zeros(2)
                    a[ax], b[ax] = pos - 0.5, pos + 0.5
                    a[o] = b[o] = m
                    self.res0 = np.concatenate([self.res0, a[None]])
                    self.res1 = np.concatenate([self.res1, b[None]])
            self.splits.append(_Split(ax, pos, cell.lo[o], cell.hi[o], openings))
            leaves.extend(self._children(cell, ax, pos))
        leaves.sort(key=lambda c: (round(float(c.lo[1]), 6), round(float(c.lo[0]), 6)))
        return leaves


def _given_kind(layout: dict, cell: _Cell) -> str | None:
    """The kind of the layout room holding ``cell``'s centre, None when no room does."""
    m = (cell.lo + cell.hi) / 2
    for r in layout.get("rooms", []):
        if r["lo"][0] <= m[0] <= r["hi"][0] and r["lo"][1] <= m[1] <= r["hi"][1]:
            return str(r["kind"])
    return None


# ---------------------------------------------------------------------------------------------------------------
# assembling the plan


def _room_kind(planner: _Planner, objs: np.ndarray) -> str:
    if not len(objs):
        return "hall"
    s = planner.w[objs].sum(axis=0) + planner.hint[objs].sum(axis=0)
    k = int(np.argmax(s))
    return planner.kinds[k] if s[k] >= KIND_MIN_SCORE else "hall"


def _window_positions(planner: _Planner, ax: int, face: float, side: int, a: float, b: float) -> list:
    """Windows (along the other axis) on an exterior wall whose inner face is the line x[ax] = face, the room on
    side ``side`` (+1: the room is at larger x[ax]), from ``a`` to ``b`` along the wall."""
    o = 1 - ax
    lo, hi = a + WINDOW_END_GAP_M, b - WINDOW_END_GAP_M
    if hi - lo < WINDOW_WIDTH_M:
        return []
    # stretches blocked by cuboids taller than the sill standing near the wall
    blocked_iv = []
    for i in range(len(planner.olo)):
        if planner.ohi[i, 2] <= WINDOW_SILL_M:
            continue
        gap = planner.olo[i, ax] - face if side > 0 else face - planner.ohi[i, ax]
        if gap > WINDOW_CLEAR_DEPTH_M:
            continue
        blocked_iv.append((planner.olo[i, o] - 0.1, planner.ohi[i, o] + 0.1))
    step = CANDIDATE_STEP_M
    n_want = max(1, int((b - a) // WINDOW_SPACING_M))
    starts = np.arange(lo, hi - WINDOW_WIDTH_M + 1e-9, step)
    free = np.array([all(s + WINDOW_WIDTH_M <= u or s >= v for u, v in blocked_iv) for s in starts], dtype=bool)
    chosen: list[tuple[float, float]] = []
    for j in range(n_want):
        target = a + (b - a) * (j + 0.5) / n_want - WINDOW_WIDTH_M / 2
        order = np.argsort(np.abs(starts - target), kind="stable")
        for s in starts[order][free[order]]:
            if any(s < v + WINDOW_END_GAP_M and s + WINDOW_WIDTH_M > u - WINDOW_END_GAP_M for u, v in chosen):
                continue
            if abs(s - target) > (b - a) / n_want:  # keep windows spread out
                break
            chosen.append((float(s), float(s + WINDOW_WIDTH_M)))
            break
    return sorted(chosen)


def _cut(planner: _Planner, box_lo, box_hi, ax: int, holes, exterior, rooms, outward, walls, openings):
    """Add the wall box ``box_lo``..``box_hi`` (thin along ``ax``) with ``holes`` [(kind, a, b, z0, z1, leaf)] along
    the other axis cut out."""
    o = 1 - ax
    H = planner.height
    first = len(walls)

    def add(lo_o, hi_o, z0, z1):
        if hi_o - lo_o <= 1e-9 or z1 - z0 <= 1e-9:
            return None
        lo = np.array(box_lo, dtype=np.float64)
        hi = np.array(box_hi, dtype=np.float64)
        lo[o], hi[o], lo[2], hi[2] = lo_o, hi_o, z0, z1
        walls.append(Wall(lo, hi, exterior, rooms))
        return len(walls) - 1

    cursor = box_lo[o]
    pending = []
    for kind, a, b, z0, z1, leaf in sorted(holes, key=lambda h: h[1]):
        add(cursor, a, 0.0, H)
        below = add(a, b, 0.0, z0)
        above = add(a, b, z1, H)
        lo = np.array(box_lo, dtype=np.float64)
        hi = np.array(box_hi, dtype=np.float64)
        lo[o], hi[o], lo[2], hi[2] = a, b, z0, z1
        ref = above if above is not None else below
        if ref is None:
            pending.append(len(openings))
        openings.append(Opening(kind, lo, hi, -1 if ref is None else ref, np.array(outward, dtype=np.float64),
                                rooms, bool(leaf)))
        cursor = b
    add(cursor, box_hi[o], 0.0, H)
    for k in pending:  # a full-height passage: refer to the nearest box of this wall
        op = openings[k]
        mids = [((walls[i].lo[o] + walls[i].hi[o]) / 2, i) for i in range(first, len(walls))]
        if mids:
            c = (op.lo[o] + op.hi[o]) / 2
            i = min(mids, key=lambda m: abs(m[0] - c))[1]
            openings[k] = Opening(op.kind, op.lo, op.hi, i, op.outward, op.rooms, op.leaf)


def derive_floor_plan(objects: list[dict], paths: list[np.ndarray], *, seed: int = 0,
                      robot_radius_m: float = 0.35, layout: dict | None = None) -> FloorPlan:
    """Derive a home's floor plan from its ground-truth cuboids and robot paths (see the module docstring).

    Args:
        objects: ground-truth objects (dicts with ``class``, ``centroid`` [x,y,z], ``extent`` [dx,dy,dz], metres;
            axis-aligned cuboids), the union over the home's variants.
        paths: (M, 2) xy robot positions per path (start pose then trajectory); consecutive points form segments.
        seed: chooses among near-equal candidate walls; the same seed always gives the same plan.
        robot_radius_m: the robot's footprint radius (m): walls keep this (+ :data:`PATH_MARGIN_M`) from every
            path segment except through doorways.
        layout: a procedural home's layout (the JSON form of :func:`benchbot_worlds.procedural.layout.layout_to_dict`,
            in the frame of ``objects`` and ``paths``): its ``outer`` rectangle is the outer boundary and its
            ``cuts`` are the walls, in their order (no search; ``seed`` is not used); a room's kind is that of the
            layout room (``rooms``: kind, lo, hi) holding its centre. Its ``doors`` are the walls' doorways (each with
            a door leaf); without ``doors``, the openings are found as for a derived wall: where the paths cross a
            wall, else a connecting doorway where the floor is clear. None (BEAR's homes):
            the binary space partition of the module docstring.

    Returns:
        A :class:`FloorPlan`.

    Raises:
        BackendError: an object lacks a class/centroid/extent or has non-finite numbers, a path is not an (M, 2)
            finite array, there are neither objects nor paths, or the layout is malformed or its cuts are no
            guillotine cuts of its outer rectangle.
    """
    if not np.isfinite(robot_radius_m) or robot_radius_m < 0:
        raise BackendError(f"floor plan: robot_radius_m={robot_radius_m} is not a finite radius >= 0",
                           "pass the robot's footprint radius in metres")
    pl = _Planner(objects, paths, int(seed), robot_radius_m)
    if layout is None:
        cells = pl.partition()
    else:
        try:
            outer = np.asarray(layout["outer"], dtype=np.float64).reshape(2, 2)
            pl.outer_lo, pl.outer_hi = outer[0].copy(), outer[1].copy()
            cells = pl.given_partition(layout)
        except (KeyError, TypeError, ValueError) as e:
            raise BackendError(f"floor plan: malformed layout ({e!r})",
                               "layout: {outer: [[x0,y0],[x1,y1]], cuts: [[axis,pos,lo,hi],...], rooms: [...]}") from e
    t, H = pl.t, pl.height
    olo, ohi = pl.outer_lo, pl.outer_hi

    # rooms (clear floor between the walls' inner faces)
    rooms: list[Room] = []
    for i, c in enumerate(cells):
        lo = np.array([c.lo[k] + (0.0 if c.lo[k] == olo[k] else t / 2) for k in range(2)])
        hi = np.array([c.hi[k] - (0.0 if c.hi[k] == ohi[k] else t / 2) for k in range(2)])
        kind = _given_kind(layout, c) if layout is not None else None
        rooms.append(Room(i, lo, hi, kind if kind is not None else _room_kind(pl, c.objs)))

    walls: list[Wall] = []
    openings: list[Opening] = []
    # interior walls: each split line, in pieces with one room on each side
    for s in pl.splits:
        ax, o = s.axis, 1 - s.axis
        for i, ci in enumerate(cells):
            if ci.hi[ax] != s.pos or ci.hi[o] <= s.lo or ci.lo[o] >= s.hi:
                continue
            for j, cj in enumerate(cells):
                if cj.lo[ax] != s.pos:
                    continue
                a, b = max(ci.lo[o], cj.lo[o], s.lo), min(ci.hi[o], cj.hi[o], s.hi)
                if b - a <= 1e-9:
                    continue
                if a == s.lo:
                    a += 0.0 if a == olo[o] else t / 2
                if b == s.hi:
                    b -= 0.0 if b == ohi[o] else t / 2
                lo3, hi3 = np.zeros(3), np.zeros(3)
                lo3[ax], hi3[ax] = s.pos - t / 2, s.pos + t / 2
                lo3[o], hi3[o] = a, b
                hi3[2] = H
                holes = []
                for d0, d1, kind in s.openings:
                    if d1 <= a + 1e-9 or d0 >= b - 1e-9:
                        continue
                    full = kind == "passage" and (d0 <= a + 1e-9 or d1 >= b - 1e-9)
                    holes.append(("door", max(d0, a), min(d1, b), 0.0, H if full else min(DOOR_HEAD_M, H),
                                  kind == "door"))
                normal = np.zeros(2)
                normal[ax] = 1.0
                _cut(pl, lo3, hi3, ax, holes, False, (i, j), normal, walls, openings)
    # exterior walls: per room and side, with windows
    for i, c in enumerate(cells):
        r = rooms[i]
        for ax in (0, 1):
            o = 1 - ax
            for side, face in ((-1, olo[ax]), (+1, ohi[ax])):
                if (c.lo[ax] if side < 0 else c.hi[ax]) != face:
                    continue
                a, b = c.lo[o], c.hi[o]
                wins = _window_positions(pl, ax, face, -side, r.lo[o], r.hi[o])
                if a == olo[o]:
                    a -= t  # outer corner
                if b == ohi[o]:
                    b += t
                lo3, hi3 = np.zeros(3), np.zeros(3)
                lo3[ax], hi3[ax] = (face - t, face) if side < 0 else (face, face + t)
                lo3[o], hi3[o] = a, b
                hi3[2] = H
                normal = np.zeros(2)
                normal[ax] = float(side)
                holes = [("window", u, v, WINDOW_SILL_M, min(WINDOW_HEAD_M, H), False) for u, v in wins]
                _cut(pl, lo3, hi3, ax, holes, True, (i, -1), normal, walls, openings)

    lights = _lights(pl, rooms)
    spans = _wall_spans(pl, rooms, openings)
    return FloorPlan(outer_lo=olo.copy(), outer_hi=ohi.copy(), wall_height=float(H), wall_thickness=float(t),
                     rooms=rooms, walls=walls, openings=openings, lights=lights, wall_spans=spans,
                     corridor=Corridor(pl.p0, pl.p1, pl.r))


def _lights(pl: _Planner, rooms: list[Room]) -> list[np.ndarray]:
    """Ceiling lamps on a grid per room, each moved (within its grid cell) away from cuboids reaching near it."""
    z = pl.height - LIGHT_DROP_M
    tall = pl.ohi[:, 2] > z - 0.3
    out = []
    for r in rooms:
        size = r.hi - r.lo
        n = np.maximum(1, np.ceil(size / LIGHT_SPACING_M).astype(int))
        for j in range(n[1]):
            for i in range(n[0]):
                p = r.lo + (np.array([i, j]) + 0.5) * size / n
                if tall.any():
                    lo = r.lo + np.array([i, j]) * size / n
                    cands = lo + (np.stack(np.meshgrid(np.linspace(0.2, 0.8, 7), np.linspace(0.2, 0.8, 7)),
                                           -1).reshape(-1, 2)) * size / n
                    d = np.full(len(cands), np.inf)
                    for k in np.nonzero(tall)[0]:
                        d = np.minimum(d, _point_box_distance(cands, pl.olo[k, :2], pl.ohi[k, :2]))
                    if np.isfinite(d).any() and _point_box_distance(p[None], pl.olo[tall, :2],
                                                                    pl.ohi[tall, :2]).min() < 0.3:
                        p = cands[int(np.argmax(d))]
                out.append(np.array([p[0], p[1], z]))
    return out


def _wall_spans(pl: _Planner, rooms: list[Room], openings: list[Opening]) -> list[WallSpan]:
    t = pl.t
    spans = []
    for r in rooms:
        for ax in (0, 1):
            o = 1 - ax
            for side in (-1, +1):
                face = r.lo[ax] if side < 0 else r.hi[ax]
                inward = np.zeros(2)
                inward[ax] = -float(side)
                cuts = []  # (a, b, max_height or None for "none")
                for op in openings:
                    # the opening is in this face's wall when its box touches the face plane
                    if not (op.lo[ax] - 1e-6 <= face <= op.hi[ax] + 1e-6):
                        continue
                    if op.hi[o] <= r.lo[o] or op.lo[o] >= r.hi[o]:
                        continue
                    if abs((op.hi[ax] - op.lo[ax]) - t) > 1e-6:
                        continue  # an opening of a wall across this one
                    if op.kind == "door":
                        cuts.append((op.lo[o] - DOOR_SPAN_CLEARANCE_M, op.hi[o] + DOOR_SPAN_CLEARANCE_M, None))
                    else:
                        cuts.append((op.lo[o], op.hi[o], WINDOW_SILL_M))
                cuts.sort(key=lambda c: c[0])
                pieces = []
                cursor = r.lo[o]
                for a, b, mh in cuts:
                    a2, b2 = max(a, r.lo[o]), min(b, r.hi[o])
                    if a2 > cursor:
                        pieces.append((cursor, a2, pl.height))
                    if mh is not None and b2 > a2:
                        pieces.append((a2, b2, mh))
                    cursor = max(cursor, b2)
                if cursor < r.hi[o]:
                    pieces.append((cursor, r.hi[o], pl.height))
                for a, b, mh in pieces:
                    if b - a < MIN_WALL_SPAN_M:
                        continue
                    pa, pb = np.zeros(2), np.zeros(2)
                    pa[ax] = pb[ax] = face
                    pa[o], pb[o] = a, b
                    spans.append(WallSpan(r.index, pa, pb, inward.copy(), float(mh)))
    return spans


# ---------------------------------------------------------------------------------------------------------------
# homes: the union of a home's variants


def home_inputs(variant_dicts: list[dict]) -> tuple[list[dict], list[np.ndarray]]:
    """The floor-plan inputs of a home from its variants' loaded ground-truth JSON dicts: the union of their objects
    (an object in several variants counts once: same class, centroid and extent to 1 mm) and one xy path per
    variant (start pose then trajectory).

    Raises:
        BackendError: a pose is malformed.
    """
    objects: list[dict] = []
    seen = set()
    paths = []
    for v, data in enumerate(variant_dicts):
        for o in (data.get("ground_truth") or {}).get("objects", []):
            key = (str(o.get("class")), tuple(np.round(np.asarray(o.get("centroid"), dtype=float), 3).tolist()),
                   tuple(np.round(np.asarray(o.get("extent"), dtype=float), 3).tolist()))
            if key not in seen:
                seen.add(key)
                objects.append(o)
        env = data.get("environment") or {}
        poses = ([env["start_pose"]] if env.get("start_pose") is not None else []) + list(env.get("trajectory_poses")
                                                                                           or [])
        try:
            xy = np.array([pose7_to_se2(p)[:2] for p in poses], dtype=np.float64).reshape(-1, 2)
        except (ValueError, TypeError) as e:
            raise BackendError(f"floor plan: variant {v + 1} ({env.get('name')}:{env.get('variant')}) has a bad pose "
                               f"({e})", "poses are [qw,qx,qy,qz,x,y,z] with a non-zero quaternion") from e
        if len(xy):
            paths.append(xy)
    return objects, paths


#: The environment field of a procedural home's layout (:func:`benchbot_worlds.procedural.layout.layout_to_dict`).
LAYOUT_FIELD = "layout"


def home_layout(variant_dicts: list[dict]) -> dict | None:
    """The layout (``environment.layout``, map frame) its variants' loaded ground-truth JSON dicts declare, None
    when none does (BEAR's homes: the plan is searched for).

    Raises:
        BackendError: two variants declare different layouts, or a layout is no dict.
    """
    found = None
    for v, data in enumerate(variant_dicts):
        lay = (data.get("environment") or {}).get(LAYOUT_FIELD)
        if lay is None:
            continue
        if not isinstance(lay, dict):
            raise BackendError(f"floor plan: variant {v + 1}'s environment.{LAYOUT_FIELD} is not an object",
                               "layout: {outer, cuts, rooms} (benchbot_worlds.procedural.layout.layout_to_dict)")
        if found is not None and json.dumps(lay, sort_keys=True) != json.dumps(found, sort_keys=True):
            raise BackendError(f"floor plan: variant {v + 1} declares another layout than the variants before it",
                               "every variant of a home has the same layout")
        found = lay
    return found


def home_plan(objects: list[dict], paths: list, *, seed: int = 0, robot_radius_m: float = 0.35,
              layout: dict | None = None):
    """(frame, plan): a home's :class:`~benchbot_worlds.homes.home_frame.HomeFrame`
    (:func:`~benchbot_worlds.homes.home_frame.home_frame`, with an origin of the home's own) and its floor plan
    derived in that frame (:func:`derive_floor_plan` of the objects and paths carried there, their xy rounded to
    :data:`~benchbot_worlds.homes.home_frame.HOME_GRID_M`), so that a turned, mirrored or moved layout gets the
    same plan turned, mirrored or moved. ``objects``, ``paths``: map frame, as :func:`derive_floor_plan` takes them;
    the plan returned is in the home frame (:meth:`~benchbot_worlds.homes.home_frame.HomeFrame.plan_to_map`
    carries it to the map). ``layout`` (map frame, :func:`home_layout`) is carried to the home frame
    (:meth:`~benchbot_worlds.homes.home_frame.HomeFrame.layout_to_home`) and its cuts are the walls.

    Raises:
        BackendError: as :func:`derive_floor_plan`.
    """
    from benchbot_worlds.homes.home_frame import home_frame

    frame = home_frame(objects, paths, own_origin=True)
    if not frame.is_identity:
        objects, paths = frame.objects_to_home(objects), [frame.points_to_home(p) for p in paths]
        try:
            layout = frame.layout_to_home(layout)
        except (KeyError, TypeError, ValueError) as e:
            raise BackendError(f"floor plan: malformed layout ({e!r})",
                               "layout: {outer, cuts, rooms} (benchbot_worlds.procedural.layout.layout_to_dict)") from e
    return frame, derive_floor_plan(objects, paths, seed=seed, robot_radius_m=robot_radius_m, layout=layout)


def plan_for_home(variant_dicts: list[dict], *, seed: int = 0, robot_radius_m: float = 0.35) -> FloorPlan:
    """The floor plan (map frame) shared by a home's variants (their loaded ground-truth JSON dicts):
    :func:`home_inputs`, :func:`home_plan` (with their :func:`home_layout`, if any), then the plan carried to the map
    frame."""
    frame, plan = home_plan(*home_inputs(variant_dicts), seed=seed, robot_radius_m=robot_radius_m,
                            layout=home_layout(variant_dicts))
    return frame.plan_to_map(plan)


#: The environment field that names the ground-truth files of every variant of its home (see :func:`home_files`).
HOME_FILES_FIELD = "home_files"


def home_files(environment: dict, base_dir: Path | None = None) -> list[Path]:
    """The ground-truth JSON files whose union the furnished floor plan of ``environment`` is derived from.

    An environment declares its home's variants in the field ``home_files``: a list of ground-truth files, absolute
    or relative to ``base_dir`` (the environment file's folder; default the folder of its ``_file_path``, else the
    working directory; a content pack's are resolved at install). Its own
    ``map_path`` belongs to the home: when the list does not name it, it comes first. Variants that list the same
    files in the same order share one plan (:func:`plan_for_files`). Without ``home_files`` the plan is the
    environment's own: ``[map_path]`` (and ``[]`` without a map_path).

    Returns:
        Absolute paths, in the declared order, without repeats.

    Raises:
        BackendError: ``home_files`` is not a non-empty list of paths, or a file it names does not exist.
    """
    if base_dir is None:
        fp = environment.get("_file_path")
        base_dir = Path(fp).resolve().parent if fp else Path.cwd()
    where = f"environment {environment.get('name')}:{environment.get('variant')}"
    map_path = environment.get("map_path")
    own = [Path(map_path).expanduser().resolve()] if isinstance(map_path, str) and map_path else []
    declared = environment.get(HOME_FILES_FIELD)
    if declared is None:
        return own
    if not isinstance(declared, list) or not declared or not all(isinstance(f, str) and f for f in declared):
        raise BackendError(f"{where}: {HOME_FILES_FIELD} is not a non-empty list of file paths",
                           f"{HOME_FILES_FIELD}: [house_1.json, house_2.json, ...] (relative to the environment file)")
    files = []
    for i, name in enumerate(declared):
        path = Path(name).expanduser()
        path = (path if path.is_absolute() else Path(base_dir) / path).resolve()
        if not path.is_file():
            raise BackendError(f"{where}: {HOME_FILES_FIELD}[{i}] {path} does not exist",
                               "list the ground-truth files of the home's variants, relative to the environment file")
        files.append(path)
    if own and own[0] not in files:
        files.insert(0, own[0])
    return list(dict.fromkeys(files))


def _checked_ground_truth(data) -> dict:
    """``data`` (a loaded JSON value) when it is a ground truth whose objects :func:`home_inputs` can read: a dict
    with ``ground_truth.objects``, a list of dicts with a ``centroid`` and an ``extent`` of 3 numbers each.

    Raises:
        ValueError: one line saying what is missing.
    """
    gt = data.get("ground_truth") if isinstance(data, dict) else None
    if not isinstance(gt, dict) or not isinstance(gt.get("objects"), list):
        raise ValueError("it has no ground_truth.objects list")
    for i, o in enumerate(gt["objects"]):
        try:
            ok = all(np.asarray(o[k], dtype=np.float64).shape == (3,) for k in ("centroid", "extent"))
        except (KeyError, TypeError, ValueError):
            ok = False
        if not ok:
            raise ValueError(f"ground_truth.objects[{i}] has no centroid and extent of 3 numbers")
    return data


@functools.lru_cache(maxsize=16)
def _plan_cached(key: tuple, seed: int, robot_radius_m: float):
    """(frame, home-frame plan, map-frame plan) of the files in ``key``."""
    dicts = []
    for path, _, _ in key:
        try:
            with open(path, encoding="utf-8") as f:
                dicts.append(_checked_ground_truth(json.load(f)))
        except (OSError, ValueError) as e:
            raise BackendError(f"floor plan: cannot read the ground-truth file {path} ({e})",
                               "check that the file exists and is a ground-truth JSON {environment, format, "
                               "ground_truth}") from e
    frame, plan = home_plan(*home_inputs(dicts), seed=seed, robot_radius_m=robot_radius_m, layout=home_layout(dicts))
    return frame, plan, frame.plan_to_map(plan)


def _files_key(files) -> tuple:
    key = []
    for f in files:
        p = Path(f).resolve()
        try:
            st = p.stat()
        except OSError as e:
            raise BackendError(f"floor plan: cannot read the ground-truth file {p} ({e})",
                               "check that the file exists") from e
        key.append((str(p), st.st_mtime_ns, st.st_size))
    return tuple(key)


def plan_for_files(files, *, seed: int = 0, robot_radius_m: float = 0.35) -> FloorPlan:
    """:func:`plan_for_home` of ground-truth JSON files (the plan in the map frame), cached by (paths, modification
    times, sizes, seed, radius): a home's variants share one plan object.

    Raises:
        BackendError: a file is missing or not JSON, or :func:`plan_for_home` fails.
    """
    return _plan_cached(_files_key(files), int(seed), float(robot_radius_m))[2]


def home_plan_for_files(files, *, seed: int = 0, robot_radius_m: float = 0.35):
    """(frame, plan in that frame) of ground-truth JSON files: :func:`home_plan` of their :func:`home_inputs`,
    cached as :func:`plan_for_files` is (the furnishing works in the home frame).

    Raises:
        BackendError: as :func:`plan_for_files`.
    """
    frame, plan, _ = _plan_cached(_files_key(files), int(seed), float(robot_radius_m))
    return frame, plan
