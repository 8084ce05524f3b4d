"""Furnishing a floor plan: real models for the ground-truth objects, supports under floating ones, distractors.

:func:`furnish` turns the ground-truth (GT) objects of an environment, its :class:`~benchbot_sim_taichi.floorplan.
FloorPlan` and an :class:`~benchbot.core.assets.AssetLibrary` into :class:`Placement` s: an asset id and the (4, 4)
transform that takes the asset's map-frame model (z up, front −y, origin at the centre of the bottom of its bounds)
to the map. Pure NumPy, deterministic per ``seed``; GT is never changed.

Rules (the constants below are the knobs):

* **Fitting** (:func:`fit_to_cuboid`): ``T = Translate(cuboid bottom centre) · Rz(k·90°) · Scale(s) ·
  Translate(−asset bottom centre)``, ``s`` chosen so the transformed asset bounds EQUAL the cuboid (k odd swaps the
  x and y extents). Quarter turns only, so the axis-aligned bounds stay exact.
* **Model and facing**: for each model of the class and each of the 4 turns, ``score = distortion +
  weight · (1 − cos Δ) / 2``; ``distortion = Σ_axes |log(s_axis / geometric-mean(s))|`` (0 for a uniform scale),
  ``Δ`` the angle between the model's front after the turn and the preferred facing, ``weight`` =
  :data:`FACING_WEIGHT` for a rule-given facing (:data:`RANDOM_FACING_WEIGHT` for a seeded random one). So facing
  decides between turns that distort alike, and yields to proportions once the facing it wants would distort
  by more than ~``weight`` (a 1.8× aspect change for the default 0.6). The model is drawn (seeded by the object's
  class and ``ID_name``) among the :data:`CHOICE_TOP` best whose score is within :data:`CHOICE_MARGIN` of the best.
  Facings: chairs toward the nearest GT table within :data:`CHAIR_TABLE_RANGE_M` (else the room centre);
  :data:`BACK_TO_WALL` classes with their back to the nearest wall; ``person`` toward the room centre; the rest a
  seeded random turn.
* **Book rows** (``isgroup`` books): standing books side by side along the cuboid's long horizontal axis (a stack
  of lying books when the cuboid is flat), seeded thicknesses/heights/depths, union bounds = the cuboid, all with
  the object's index.
* **Supports**: a GT object whose bottom is above :data:`FLOAT_MIN_Z_M` that does not rest on another GT object
  (footprint overlap ≥ :data:`REST_MIN_OVERLAP`, that object's top within :data:`REST_TOL_M` of its bottom) and does
  not hang on a wall (:data:`HANGING_CLASSES` within :data:`HANG_WALL_DIST_M` of a wall) gets one. Neighbouring
  floating objects (gap ≤ :data:`SUPPORT_GROUP_GAP_M`, bottoms within :data:`REST_TOL_M`, same room) share one, its
  top at their lowest bottom (exactly that object's bottom; the others rest within :data:`REST_TOL_M`). Tried in
  order: a floor unit (counter, cabinet, nightstand, dresser, bookcase … by room and height) backed onto a wall
  within :data:`SUPPORT_TO_WALL_M`; the same unit just under the objects (+ :data:`SUPPORT_MARGIN_M`); a thin wall
  shelf against a wall within :data:`WALL_SHELF_REACH_M`; a slim pedestal. Each must not intersect any GT cuboid,
  wall, door zone, other support or distractor, and floor units must be clear of the robot corridor (a wall shelf
  whose underside is above :data:`OVERHEAD_CLEAR_Z_M` may overhang it). Objects left without are reported
  (:attr:`Furnishing.unsupported`, with why).
* **Distractors**: along ``plan.wall_spans``, kinds by room (:data:`ROOM_DISTRACTORS`, never a GT class), natural
  size, back to the wall; pictures on free wall above :data:`OVERHEAD_CLEAR_Z_M`; radiators under and curtains
  beside windows; door and window models fitted to ``plan.openings`` (a doorway on the robot's path gets a frame,
  never a closed door); ceiling lamps above ``plan.lights``. Each clear of every GT cuboid, support, wall and other
  distractor; floor-standing ones clear of the corridor and of doorways.
"""

from __future__ import annotations

import logging
import math
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

log = logging.getLogger(__name__)

#: GT classes (BEAR); no support or distractor is ever of one of these kinds.
GT_CLASSES = frozenset((
    "bottle", "cup", "knife", "bowl", "wine glass", "fork", "spoon", "banana", "apple", "orange", "cake",
    "potted plant", "mouse", "keyboard", "laptop", "cell phone", "book", "clock", "chair", "table", "couch", "bed",
    "toilet", "tv", "microwave", "toaster", "refrigerator", "oven", "sink", "person"))

#: Weight of a rule-given facing against the proportion distortion (see the module docstring).
FACING_WEIGHT = 0.6
#: Weight of a seeded random facing (only breaks ties between turns that distort alike).
RANDOM_FACING_WEIGHT = 0.05
#: The model is drawn among at most this many best-scoring models ...
CHOICE_TOP = 3
#: ... whose score is within this of the best one.
CHOICE_MARGIN = 0.15
#: Chairs face the nearest GT table whose footprint is within this distance (m), else the room centre.
CHAIR_TABLE_RANGE_M = 1.5
#: Classes placed with their back to the nearest wall (front toward the room).
BACK_TO_WALL = frozenset(("couch", "bed", "toilet", "refrigerator", "oven", "tv", "sink", "microwave", "toaster",
                          "clock", "laptop", "keyboard"))
#: Classes drawn facing the room centre.
FACE_ROOM = frozenset(("person",))

#: A GT object whose bottom is above this height (m) needs something under it.
FLOAT_MIN_Z_M = 0.05
#: An object rests on another if that one's top is within this of its bottom (m) ...
REST_TOL_M = 0.02
#: ... and their footprints overlap by at least this fraction of the object's footprint.
REST_MIN_OVERLAP = 0.3
#: ... or sinks into it by at most this much (m): a bowl in a basin, a clock on a bed's headboard.
REST_SINK_M = 0.08
#: Classes that may hang on a wall (no support) when one of their sides is within HANG_WALL_DIST_M of a wall face,
#: with the most depth (m, across the wall) they may have for that (a monitor on its stand stands on a desk).
HANGING_CLASSES = {"clock": 0.15, "tv": 0.12, "sink": math.inf, "toilet": math.inf}
#: See HANGING_CLASSES (m).
HANG_WALL_DIST_M = 0.15
#: Floating objects this close (xy gap, m) at similar heights share one support.
SUPPORT_GROUP_GAP_M = 0.5
#: Margin (m) of a support's top around the objects it carries.
SUPPORT_MARGIN_M = 0.04
#: A floor support is extended back to a wall face at most this far (m) from the objects.
SUPPORT_TO_WALL_M = 0.6
#: Narrowest side (m) of a support (it is trimmed around GT cuboids that stand in its way, down to this).
SUPPORT_MIN_SIDE_M = 0.1
#: Free floor (m) a floor support keeps on both sides of a doorway (less than DOOR_CLEARANCE_M: it stands under
#: a GT object that is there anyway).
SUPPORT_DOOR_CLEARANCE_M = 0.3
#: Objects at most this high (m) get a rug or plinth of that thickness instead (LOW_SUPPORT_KINDS), reaching
#: LOW_SUPPORT_MARGIN_M around them.
LOW_SUPPORT_Z_M = 0.15
LOW_SUPPORT_MARGIN_M = 0.12
LOW_SUPPORT_KINDS = ("rug", "plinth", "cabinet")
#: Kinds of wall shelves and boards, and of pedestals.
SHELF_KINDS = ("wall_shelf", "shelf")
PEDESTAL_KINDS = ("pedestal", "plant_stand", "nightstand", "cabinet")
#: A floor support trimmed to less than this fraction of its area ranks below a wall shelf.
TRIMMED_FLOOR_AREA = 0.7
#: Kinds of a riser: a unit standing on a GT object or support under the objects (a thin one is a board).
RISER_KINDS = ("shelf", "bookcase", "cabinet")
#: Smallest depth (m) of a floor support backed onto a wall.
SUPPORT_MIN_DEPTH_M = 0.35
#: A wall shelf is used when a wall face is at most this far (m) from the objects.
WALL_SHELF_REACH_M = 0.6
#: Thickness (m) of a wall shelf.
WALL_SHELF_THICKNESS_M = 0.04
#: The tallest robot (m): carter's ``max_height_m``.
ROBOT_HEIGHT_M = 1.0
#: Things whose underside is at least this high (m) may overhang the robot corridor.
OVERHEAD_CLEAR_Z_M = ROBOT_HEIGHT_M + 0.2
#: Most units (side by side) in one counter/cabinet run.
MAX_SUPPORT_UNITS = 8
#: Kinds of units that are tiled side by side along a long support.
TILED_KINDS = frozenset(("counter", "cabinet", "kitchen_cabinet"))

#: Floor-standing distractors keep this clearance (m) from GT cuboids, supports and each other.
DISTRACTOR_CLEARANCE_M = 0.05
#: Free floor (m) kept on both sides of a doorway (no floor furniture there).
DOOR_CLEARANCE_M = 0.7
#: Probability of trying a distractor at each free position of a wall span.
DISTRACTOR_FILL = 0.7
#: Distractor kinds per room kind: (kind, weight). Never a GT class (checked).
ROOM_DISTRACTORS: dict[str, tuple[tuple[str, float], ...]] = {
    "kitchen": (("counter", 3.0), ("cabinet", 2.0), ("kitchen_cabinet", 2.0), ("shelf", 1.0)),
    "bathroom": (("bathtub", 2.0), ("shower", 1.0), ("washing_machine", 1.5), ("cabinet", 1.5)),
    "bedroom": (("wardrobe", 2.0), ("dresser", 2.0), ("nightstand", 1.0), ("bookcase", 1.0)),
    "living_room": (("bookcase", 2.0), ("cabinet", 2.0), ("floor_lamp", 1.0), ("plant_stand", 0.5),
                    ("dresser", 0.5)),
    "office": (("bookcase", 2.0), ("shelf", 2.0), ("cabinet", 1.0), ("floor_lamp", 0.5)),
    "hall": (("cabinet", 1.0), ("shelf", 1.0), ("coat_rack", 1.0)),
}
#: Wall-hung distractor kinds (everywhere), their centre height range (m).
WALL_DISTRACTORS = ("picture", "mirror")
PICTURE_CENTRE_Z_M = (1.45, 1.75)
#: Tallest ceiling lamp (m); bigger models are scaled down uniformly.
LAMP_MAX_DROP_M = 0.5
#: Thinnest book (m) of a row, its mean thickness, and the most books in one row/stack.
BOOK_THICKNESS_M = 0.035
MAX_BOOKS_PER_GROUP = 40

ROLES = ("object", "support", "distractor", "door", "window", "light")


@dataclass(frozen=True)
class Placement:
    """One model in the scene.

    Attributes:
        asset_id: the :class:`~benchbot.core.assets.AssetInfo` id.
        transform: (4, 4) float64, the asset's map-frame model (z up, front −y) → map, non-uniform scale included.
        object_index: index into the ``objects`` given to :func:`furnish` (several placements share it for a book
            row), −1 for everything that is not a GT object.
        role: one of :data:`ROLES`.
    """

    asset_id: str
    transform: np.ndarray
    object_index: int
    role: str


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


# ------------------------------------------------------------------------------------------------------ fitting
_FRONT = np.array([[0.0, -1.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]])  # model front after k quarter turns
_COS = (1.0, 0.0, -1.0, 0.0)
_SIN = (0.0, 1.0, 0.0, -1.0)


def asset_bounds(asset: Any) -> np.ndarray:
    """(2, 3) float64 bounds of an asset in its map frame from its ``size_m``: ``[[−w/2, −d/2, 0], [w/2, d/2, h]]``.

    Raises:
        ValueError: a size is not positive and finite.
    """
    size = np.asarray(asset.size_m, dtype=np.float64).reshape(3)
    if not (np.all(np.isfinite(size)) and np.all(size > 0)):
        raise ValueError(f"asset {getattr(asset, 'id', '?')}: size_m {size.tolist()} must be 3 positive numbers")
    return np.array([[-size[0] / 2, -size[1] / 2, 0.0], [size[0] / 2, size[1] / 2, size[2]]])


def front_of(k: int) -> np.ndarray:
    """(2,) unit xy direction the model's front (−y in its frame) faces after ``k`` quarter turns about z."""
    return _FRONT[int(k) % 4].copy()


def turns_facing(direction: Sequence[float]) -> int:
    """The quarter turn ``k`` whose :func:`front_of` is closest to ``direction`` (2,)."""
    d = np.asarray(direction, dtype=np.float64)[:2]
    return int(np.argmax(_FRONT @ d))


def fit_to_cuboid(asset: Any, lo: Sequence[float], hi: Sequence[float], yaw_quarter_turns: int, *,
                  bounds: np.ndarray | None = None) -> np.ndarray:
    """The transform that puts ``asset`` exactly into the axis-aligned box ``lo``..``hi``.

    ``T = Translate(box bottom centre) · Rz(k·90°) · Scale(s) · Translate(−model bottom centre)`` with ``s`` such
    that the model's bounds map onto the box (to rounding): with ``k`` odd the model's x extent spans the box's y.

    Args:
        asset: an :class:`~benchbot.core.assets.AssetInfo` (its ``size_m`` gives the bounds unless ``bounds``).
        lo, hi: (3,) box corners, map frame, metres; ``hi > lo`` on every axis.
        yaw_quarter_turns: k (any integer; taken mod 4); the model's front faces :func:`front_of` (k).
        bounds: (2, 3) the model's true bounds in its map frame (e.g. its mesh's), if they differ from ``size_m``.

    Returns:
        (4, 4) float64 model → map.

    Raises:
        ValueError: the box is empty or flat on an axis, or the model's bounds are.
    """
    lo = np.asarray(lo, dtype=np.float64).reshape(3)
    hi = np.asarray(hi, dtype=np.float64).reshape(3)
    b = asset_bounds(asset) if bounds is None else np.asarray(bounds, dtype=np.float64).reshape(2, 3)
    size = b[1] - b[0]
    ext = hi - lo
    if not (np.all(np.isfinite(ext)) and np.all(ext > 0)):
        raise ValueError(f"box {lo.tolist()}..{hi.tolist()} must have positive finite extents")
    if not (np.all(np.isfinite(size)) and np.all(size > 0)):
        raise ValueError(f"asset {getattr(asset, 'id', '?')}: bounds {b.tolist()} must have positive extents")
    k = int(yaw_quarter_turns) % 4
    s = np.empty(3)
    if k % 2 == 0:
        s[0], s[1] = ext[0] / size[0], ext[1] / size[1]
    else:
        s[0], s[1] = ext[1] / size[0], ext[0] / size[1]
    s[2] = ext[2] / size[2]
    c, sn = _COS[k], _SIN[k]
    pre = -np.array([(b[0, 0] + b[1, 0]) / 2, (b[0, 1] + b[1, 1]) / 2, b[0, 2]])
    post = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])
    R = np.array([[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]])
    M = R * s[None, :]  # R · diag(s)
    T = np.eye(4)
    T[:3, :3] = M
    T[:3, 3] = M @ pre + post
    return T


def transformed_bounds(T: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """(2, 3) axis-aligned bounds of the 8 corners of ``bounds`` (2, 3) under ``T`` (4, 4)."""
    b = np.asarray(bounds, dtype=np.float64)
    corners = np.array([[b[i, 0], b[j, 1], b[l, 2]] for i in (0, 1) for j in (0, 1) for l in (0, 1)])
    p = corners @ T[:3, :3].T + T[:3, 3]
    return np.stack([p.min(axis=0), p.max(axis=0)])


def distortion(size: Sequence[float], ext: Sequence[float], k: int) -> float:
    """How non-uniform the scale fitting a model of ``size`` (3,) into a box of ``ext`` (3,) with ``k`` quarter
    turns is: ``Σ |log(s_i / geometric mean(s))|`` (0 for a uniform scale)."""
    size = np.asarray(size, dtype=np.float64)
    ext = np.asarray(ext, dtype=np.float64)
    if k % 2:
        size = size[[1, 0, 2]]
    ls = np.log(ext / size)
    return float(np.abs(ls - ls.mean()).sum())


def _rng(seed: int, *key: object) -> np.random.Generator:
    return np.random.default_rng(zlib.crc32("|".join(str(x) for x in (seed, *key)).encode("utf-8")))


def choose_model(assets: Sequence[Any], ext: Sequence[float], prefer: np.ndarray | None, weight: float,
                 rng: np.random.Generator) -> tuple[Any, int] | None:
    """Seeded choice of (asset, quarter turns) for a box of extents ``ext`` (3,), ``prefer`` the wanted facing (2,)
    or None (see the module docstring for the score). ``None`` when ``assets`` is empty."""
    ext = np.asarray(ext, dtype=np.float64)
    rows = []
    for i, a in enumerate(assets):
        size = np.asarray(a.size_m, dtype=np.float64)
        best = None
        for k in range(4):
            sc = distortion(size, ext, k)
            if prefer is not None:
                sc += weight * (1.0 - float(front_of(k) @ prefer)) / 2.0
            if best is None or sc < best[0] - 1e-12:
                best = (sc, k)
        rows.append((best[0], i, best[1]))
    if not rows:
        return None
    rows.sort()
    pool = [r for r in rows[:CHOICE_TOP] if r[0] <= rows[0][0] + CHOICE_MARGIN]
    _, i, k = pool[int(rng.integers(len(pool)))]
    return assets[i], k


# ------------------------------------------------------------------------------------------------------ geometry
def _boxes_hit(lo: np.ndarray, hi: np.ndarray, blo: np.ndarray, bhi: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """(N,) bool: which boxes blo/bhi (N, 3) the box lo..hi (3,) intersects with positive volume (after growing
    it by ``margin``; a negative margin lets boxes touch and overlap slightly)."""
    if len(blo) == 0:
        return np.zeros(0, dtype=bool)
    return np.all((lo - margin < bhi) & (blo < hi + margin), axis=1)


def _overlap_area(alo, ahi, blo, bhi) -> float:
    d = np.minimum(ahi[:2], bhi[:2]) - np.maximum(alo[:2], blo[:2])
    return float(max(d[0], 0.0) * max(d[1], 0.0))


def _rect_gap(alo, ahi, blo, bhi) -> float:
    d = np.maximum(np.maximum(blo[:2] - ahi[:2], alo[:2] - bhi[:2]), 0.0)
    return float(math.hypot(d[0], d[1]))


class _Space:
    """Occupied boxes (GT cuboids, walls, supports, distractors) and the keep-out zones of a plan."""

    def __init__(self, plan: Any, gt_boxes: list[tuple[np.ndarray, np.ndarray]], gt_names: Sequence[str] = ()):
        self.plan = plan
        self.gt_names = list(gt_names)
        self.gt_lo = np.array([b[0] for b in gt_boxes]).reshape(-1, 3)
        self.gt_hi = np.array([b[1] for b in gt_boxes]).reshape(-1, 3)
        walls = list(getattr(plan, "walls", []) or [])
        self.wall_lo = np.array([np.asarray(w.lo, dtype=np.float64) for w in walls]).reshape(-1, 3)
        self.wall_hi = np.array([np.asarray(w.hi, dtype=np.float64) for w in walls]).reshape(-1, 3)
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

    def add(self, lo: np.ndarray, hi: np.ndarray) -> None:
        self.placed_lo = np.vstack([self.placed_lo, lo[None]])
        self.placed_hi = np.vstack([self.placed_hi, hi[None]])

    def why_not(self, lo: np.ndarray, hi: np.ndarray, *, gt_margin: float = 0.0, placed_margin: float = 0.0,
                corridor: bool = True, doors: float | bool = True, openings: bool = False) -> str | None:
        """None if the box lo..hi is free, else a short reason. ``gt_margin``/``placed_margin``: clearance kept from
        GT cuboids / supports and distractors; ``doors``: stay out of the free floor at doorways; ``openings``: do
        not stand in front of a window or door hole (a low item under a window sill is fine); ``doors`` True means
        DOOR_CLEARANCE_M, a number that clearance."""
        hit = _boxes_hit(lo, hi, self.gt_lo, self.gt_hi, gt_margin)
        if hit.any():
            j = int(np.flatnonzero(hit)[0])
            return f"it would intersect GT object {self.gt_names[j] if j < len(self.gt_names) else j}"
        if _boxes_hit(lo, hi, self.wall_lo, self.wall_hi, -1e-4).any():
            return "it would cut a wall"
        if _boxes_hit(lo, hi, self.placed_lo, self.placed_hi, placed_margin - 1e-6).any():
            return "it would intersect a support or distractor"
        if doors is not False and len(self.door_lo):
            clear = DOOR_CLEARANCE_M if doors is True else float(doors)
            m = np.zeros((len(self.door_lo), 3))
            m[np.arange(len(self.door_lo)), self.door_axis] = clear
            if np.all((lo < self.door_hi + m - 1e-4) & (self.door_lo - m < hi - 1e-4), axis=1).any():
                return "it would stand in a doorway"
        if openings and _boxes_hit(lo, hi, self.hole_lo, self.hole_hi, np.array([0.06, 0.06, 0.0])).any():
            return "it would cover a window or door"
        if corridor and self.blocked(lo, hi):
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


def _room_of(plan: Any, xy: np.ndarray) -> Any | None:
    rooms = list(getattr(plan, "rooms", []) or [])
    best, best_d = None, math.inf
    for r in rooms:
        rlo, rhi = np.asarray(r.lo, dtype=np.float64), np.asarray(r.hi, dtype=np.float64)
        d = float(np.linalg.norm(np.maximum(np.maximum(rlo - xy, xy - rhi), 0.0)))
        if d < best_d:
            best, best_d = r, d
    return best


def _room_centre(plan: Any, xy: np.ndarray) -> np.ndarray:
    r = _room_of(plan, xy)
    if r is not None:
        return (np.asarray(r.lo, dtype=np.float64) + np.asarray(r.hi, dtype=np.float64)) / 2
    return (np.asarray(plan.outer_lo, dtype=np.float64) + np.asarray(plan.outer_hi, dtype=np.float64)) / 2


def _unit(v: np.ndarray) -> np.ndarray | None:
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-9 else None


def _wall_faces(space: _Space, lo: np.ndarray, hi: np.ndarray, z: tuple[float, float] | None = None):
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


def _nearest_wall_away(space: _Space, lo: np.ndarray, hi: np.ndarray) -> np.ndarray | None:
    faces = _wall_faces(space, lo, hi)
    if faces:
        return faces[0][1]
    plan = space.plan
    olo, ohi = np.asarray(plan.outer_lo, dtype=np.float64), np.asarray(plan.outer_hi, dtype=np.float64)
    gaps = [lo[0] - olo[0], ohi[0] - hi[0], lo[1] - olo[1], ohi[1] - hi[1]]
    return np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])[int(np.argmin(gaps))]


# ------------------------------------------------------------------------------------------------------ GT objects
def _facing(i: int, obj: dict, box, space: _Space, tables: list, rng: np.random.Generator) -> tuple[np.ndarray, float]:
    """(preferred facing (2,), weight) of a GT object."""
    lo, hi = box
    c = (lo[:2] + hi[:2]) / 2
    cls = str(obj.get("class", ""))
    if cls == "chair":
        best, best_d = None, math.inf
        for tlo, thi in tables:
            d = _rect_gap(lo, hi, tlo, thi)
            if d < best_d:
                best, best_d = (tlo, thi), d
        if best is not None and best_d <= CHAIR_TABLE_RANGE_M:
            target = np.clip(c, best[0][:2], best[1][:2])
            v = _unit(target - c) if np.linalg.norm(target - c) > 1e-3 else _unit((best[0][:2] + best[1][:2]) / 2 - c)
            if v is not None:
                return v, FACING_WEIGHT
        v = _unit(_room_centre(space.plan, c) - c)
        return (v if v is not None else front_of(int(rng.integers(4)))), FACING_WEIGHT
    if cls in BACK_TO_WALL:
        away = _nearest_wall_away(space, lo, hi)
        if away is not None:
            return away, FACING_WEIGHT
    if cls in FACE_ROOM:
        v = _unit(_room_centre(space.plan, c) - c)
        if v is not None:
            return v, FACING_WEIGHT
    return front_of(int(rng.integers(4))), RANDOM_FACING_WEIGHT


def _book_boxes(lo: np.ndarray, hi: np.ndarray, rng: np.random.Generator, front_sign: float) -> list:
    """Boxes of the books of an ``isgroup`` book cuboid: a row of standing books along its long horizontal axis,
    or a stack of lying ones when it is flat (height < 0.6 × its shorter side). Union = the cuboid."""
    ext = hi - lo
    u = 0 if ext[0] >= ext[1] else 1
    w = 1 - u
    if ext[2] < 0.6 * min(ext[0], ext[1]):  # a stack
        n = int(np.clip(round(ext[2] / BOOK_THICKNESS_M), 1, MAX_BOOKS_PER_GROUP))
        t = rng.uniform(0.7, 1.3, n)
        edges = lo[2] + ext[2] * np.concatenate([[0.0], np.cumsum(t) / t.sum()])
        edges[-1] = hi[2]
        fu, fw = rng.uniform(0.75, 1.0, n), rng.uniform(0.75, 1.0, n)
        fu[int(rng.integers(n))] = 1.0
        fw[int(rng.integers(n))] = 1.0
        out = []
        for i in range(n):
            blo, bhi = lo.copy(), hi.copy()
            for ax, f in ((u, fu[i]), (w, fw[i])):
                off = rng.uniform(0.0, 1.0 - f) * ext[ax]
                blo[ax] = lo[ax] + off if f < 1.0 else lo[ax]
                bhi[ax] = blo[ax] + f * ext[ax] if f < 1.0 else hi[ax]
            blo[2], bhi[2] = edges[i], edges[i + 1]
            out.append((blo, bhi))
        return out
    n = int(np.clip(round(ext[u] / BOOK_THICKNESS_M), 1, MAX_BOOKS_PER_GROUP))
    t = rng.uniform(0.7, 1.3, n)
    edges = lo[u] + ext[u] * np.concatenate([[0.0], np.cumsum(t) / t.sum()])
    edges[-1] = hi[u]
    fh, fd = rng.uniform(0.72, 1.0, n), rng.uniform(0.8, 1.0, n)
    fh[int(rng.integers(n))] = 1.0
    fd[int(rng.integers(n))] = 1.0
    out = []
    for i in range(n):
        blo, bhi = lo.copy(), hi.copy()
        blo[u], bhi[u] = edges[i], edges[i + 1]
        if fd[i] < 1.0:  # spines flush at the front (hi[w] if front_sign > 0), shorter books stop short of the back
            if front_sign > 0:
                blo[w] = hi[w] - fd[i] * ext[w]
            else:
                bhi[w] = lo[w] + fd[i] * ext[w]
        bhi[2] = lo[2] + fh[i] * ext[2] if fh[i] < 1.0 else hi[2]
        out.append((blo, bhi))
    return out


def _gt_box(obj: dict) -> tuple[np.ndarray, np.ndarray]:
    c = np.asarray(obj["centroid"], dtype=np.float64)
    e = np.asarray(obj["extent"], dtype=np.float64)
    return c - e / 2, c + e / 2


def _place_objects(objects, boxes, space, library, seed, bounds_of, out: Furnishing) -> None:
    tables = [boxes[j] for j, o in enumerate(objects) if o.get("class") == "table"]
    for i, obj in enumerate(objects):
        lo, hi = boxes[i]
        cls = str(obj.get("class", ""))
        assets = [a for a in library.by_class(cls) if getattr(a, "role", "object") == "object"]
        if not assets or np.any(hi - lo <= 1e-6):
            out.without_model.append(i)
            continue
        key = (cls, obj.get("ID_name", i))
        rng = _rng(seed, "object", *key)
        prefer, weight = _facing(i, obj, (lo, hi), space, tables, rng)
        if cls == "book" and obj.get("isgroup"):
            # spines toward the room: the row's front is the side away from the nearest wall
            w = 1 if (hi - lo)[0] >= (hi - lo)[1] else 0
            away = _nearest_wall_away(space, lo, hi)
            if away is not None and abs(away[w]) > 0.5:
                prefer, weight = away, FACING_WEIGHT
            else:
                prefer = np.zeros(2)
                prefer[w] = 1.0 if rng.random() < 0.5 else -1.0
            for blo, bhi in _book_boxes(lo, hi, rng, float(np.sign(prefer[w]))):
                pick = choose_model(assets, bhi - blo, prefer, weight, rng)
                a, k = pick
                out.placements.append(Placement(a.id, fit_to_cuboid(a, blo, bhi, k, bounds=bounds_of(a)), i, "object"))
            continue
        a, k = choose_model(assets, hi - lo, prefer, weight, rng)
        out.placements.append(Placement(a.id, fit_to_cuboid(a, lo, hi, k, bounds=bounds_of(a)), i, "object"))


# ------------------------------------------------------------------------------------------------------ supports
def _rests_on(i: int, boxes) -> bool:
    """Whether GT box ``i`` rests on another one: that one starts lower, its top is within REST_TOL_M below to
    REST_SINK_M above box i's bottom, and it carries at least REST_MIN_OVERLAP of box i's footprint."""
    lo, hi = boxes[i]
    area = max((hi[0] - lo[0]) * (hi[1] - lo[1]), 1e-12)
    for j, (blo, bhi) in enumerate(boxes):
        if (j != i and blo[2] < lo[2] - 1e-6 and lo[2] - REST_TOL_M <= bhi[2] <= lo[2] + REST_SINK_M
                and _overlap_area(lo, hi, blo, bhi) >= REST_MIN_OVERLAP * area):
            return True
    return False


def _hangs(obj: dict, box, space: _Space) -> bool:
    if str(obj.get("class", "")) not in HANGING_CLASSES:
        return False
    lo, hi = box
    faces = _wall_faces(space, lo, hi, (lo[2], hi[2]))
    if not faces or faces[0][0] > HANG_WALL_DIST_M:
        return False
    return float((hi - lo)[faces[0][2]]) <= HANGING_CLASSES[str(obj.get("class", ""))]


def _support_kinds(room_kind: str | None, top: float) -> tuple[str, ...]:
    if top > 1.15:
        return ("bookcase", "shelf", "wardrobe", "cabinet")
    if room_kind == "kitchen":
        return ("counter", "kitchen_cabinet", "cabinet")
    if room_kind == "bathroom":
        return ("cabinet", "counter", "nightstand")
    if room_kind == "bedroom":
        return ("nightstand", "dresser", "cabinet") if top < 0.75 else ("dresser", "cabinet", "nightstand")
    if top < 0.6:
        return ("cabinet", "nightstand", "dresser")
    return ("cabinet", "dresser", "counter", "bookcase")


def _library_kind(library, kinds: Sequence[str]) -> list:
    for kd in kinds:
        assets = [a for a in library.by_kind(kd) if a.cls is None and a.kind not in GT_CLASSES]
        if assets:
            return assets
    return []


def _place_unit_run(library, assets, lo, hi, away: np.ndarray | None, rng, bounds_of, out: Furnishing, role: str,
                    tiled: bool) -> None:
    """Fill the box lo..hi with one unit, or several side by side along the wall (``tiled``), facing ``away``."""
    ext = hi - lo
    along = 0 if away is None or abs(away[1]) > abs(away[0]) else 1  # the axis parallel to the wall
    if away is None:
        along = 0 if ext[0] >= ext[1] else 1
    n = 1
    if tiled:
        widths = sorted(float(a.size_m[0]) for a in assets)
        n = int(np.clip(round(ext[along] / max(widths[len(widths) // 2], 0.2)), 1, MAX_SUPPORT_UNITS))
    edges = lo[along] + ext[along] * np.arange(n + 1) / n
    edges[-1] = hi[along]
    unit = ext.copy()
    unit[along] = ext[along] / n
    a, k = choose_model(assets, unit, away, FACING_WEIGHT if away is not None else RANDOM_FACING_WEIGHT, rng)
    for j in range(n):
        ulo, uhi = lo.copy(), hi.copy()
        ulo[along], uhi[along] = edges[j], edges[j + 1]
        out.placements.append(Placement(a.id, fit_to_cuboid(a, ulo, uhi, k, bounds=bounds_of(a)), -1, role))


def _group_floating(objects, boxes, need: list[int], plan) -> list[list[int]]:
    parent = {i: i for i in need}

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for x, i in enumerate(need):
        for j in need[x + 1:]:
            (alo, ahi), (blo, bhi) = boxes[i], boxes[j]
            if abs(alo[2] - blo[2]) > REST_TOL_M or _rect_gap(alo, ahi, blo, bhi) > SUPPORT_GROUP_GAP_M:
                continue
            ra, rb = _room_of(plan, (alo[:2] + ahi[:2]) / 2), _room_of(plan, (blo[:2] + bhi[:2]) / 2)
            if ra is not rb:
                continue
            parent[find(i)] = find(j)
    groups: dict[int, list[int]] = {}
    for i in need:
        groups.setdefault(find(i), []).append(i)
    return sorted(groups.values())


def _trim(lo: np.ndarray, hi: np.ndarray, space: _Space, keep: Callable[[np.ndarray, np.ndarray], float]):
    """Shrink the box lo..hi until it intersects no GT cuboid and no support/distractor, each time cutting the side
    that keeps the most ``keep(lo, hi)`` (then area). None if that leaves a sliver (< SUPPORT_MIN_SIDE_M)."""
    lo, hi = lo.copy(), hi.copy()
    olo = np.vstack([space.gt_lo, space.placed_lo])
    ohi = np.vstack([space.gt_hi, space.placed_hi])
    for _ in range(24):
        hit = np.flatnonzero(_boxes_hit(lo, hi, olo, ohi, -1e-6))
        if not len(hit):
            return lo, hi
        g = int(hit[0])
        options = []
        for ax in (0, 1):
            if olo[g, ax] > lo[ax] + SUPPORT_MIN_SIDE_M:
                h2 = hi.copy()
                h2[ax] = olo[g, ax]
                options.append((lo.copy(), h2))
            if ohi[g, ax] < hi[ax] - SUPPORT_MIN_SIDE_M:
                l2 = lo.copy()
                l2[ax] = ohi[g, ax]
                options.append((l2, hi.copy()))
        if not options:
            return None
        lo, hi = max(options, key=lambda o: (round(keep(*o), 9), float(np.prod((o[1] - o[0])[:2]))))
    return None


def _support_attempt(group, boxes, names, space: _Space, library, plan, rng, bounds_of, out: Furnishing):
    """Try to place one support under the objects ``group``: (indices it carries, reasons for what failed).

    Candidates (each trimmed around GT cuboids and placed furniture in its way): a floor unit backed onto a wall
    within SUPPORT_TO_WALL_M, a floor unit just under the objects, a wall shelf, a slim pedestal, and last a riser
    standing on whatever is under them (a GT object or a support). The candidate carrying the
    most objects wins; among equals: an untrimmed floor unit, a wall shelf, a floor unit trimmed to less than
    TRIMMED_FLOOR_AREA of itself, a pedestal, a riser. Objects at most LOW_SUPPORT_Z_M up get a rug or plinth.
    A support within a single object's footprint below ROBOT_HEIGHT_M skips the corridor and doorway tests."""
    glo = np.min([boxes[i][0] for i in group], axis=0)
    ghi = np.max([boxes[i][1] for i in group], axis=0)
    top = float(glo[2])
    room = _room_of(plan, (glo[:2] + ghi[:2]) / 2)
    room_kind = getattr(room, "kind", None)
    flo, fhi = glo.copy(), ghi.copy()
    flo[:2] -= SUPPORT_MARGIN_M
    fhi[:2] += SUPPORT_MARGIN_M
    flo[2], fhi[2] = 0.0, top

    def carried(lo, hi) -> list[int]:
        got = []
        for i in group:
            blo, bhi = boxes[i]
            area = max((bhi[0] - blo[0]) * (bhi[1] - blo[1]), 1e-12)
            if blo[2] - hi[2] <= REST_TOL_M and _overlap_area(lo, hi, blo, bhi) >= REST_MIN_OVERLAP * area:
                got.append(i)
        return got

    def keep(lo, hi) -> float:
        return sum(_overlap_area(lo, hi, *boxes[i]) for i in group)

    floor_kw = {"doors": SUPPORT_DOOR_CLEARANCE_M}
    candidates = []  # (label, rank, lo, hi, kinds, away, why_not kwargs)
    if top <= LOW_SUPPORT_Z_M:
        rlo, rhi = flo.copy(), fhi.copy()
        rlo[:2] -= LOW_SUPPORT_MARGIN_M - SUPPORT_MARGIN_M
        rhi[:2] += LOW_SUPPORT_MARGIN_M - SUPPORT_MARGIN_M
        candidates.append(("rug", 0.0, rlo, rhi, LOW_SUPPORT_KINDS, None, floor_kw))
        candidates.append(("rug", 0.5, flo.copy(), fhi.copy(), LOW_SUPPORT_KINDS, None, floor_kw))
    else:
        kinds = _support_kinds(room_kind, top)
        faces = _wall_faces(space, flo, fhi)
        if faces and faces[0][0] <= SUPPORT_TO_WALL_M:
            _, away, ax, face = faces[0]
            blo, bhi = flo.copy(), fhi.copy()
            if away[ax] > 0:
                blo[ax], bhi[ax] = face, max(bhi[ax], face + SUPPORT_MIN_DEPTH_M)
            else:
                bhi[ax], blo[ax] = face, min(blo[ax], face - SUPPORT_MIN_DEPTH_M)
            candidates.append(("floor unit", 0.0, blo, bhi, kinds, away, floor_kw))
        candidates.append(("floor unit", 0.1, flo.copy(), fhi.copy(), kinds, None, floor_kw))
        if len(group) == 1:
            candidates.append(("floor unit", 2.5, glo * [1, 1, 0], ghi * [1, 1, 0] + [0, 0, top], kinds, None,
                               floor_kw))
    zr = (top - WALL_SHELF_THICKNESS_M, top)
    shelf_kw = {"corridor": zr[0] < OVERHEAD_CLEAR_Z_M, "doors": False, "openings": True}
    wfaces = [f for f in _wall_faces(space, flo, fhi, zr) if f[0] <= WALL_SHELF_REACH_M]
    if wfaces and zr[0] > LOW_SUPPORT_Z_M:
        _, away, ax, face = wfaces[0]
        blo, bhi = flo.copy(), fhi.copy()
        blo[2], bhi[2] = zr
        if away[ax] > 0:
            blo[ax] = face
        else:
            bhi[ax] = face
        candidates.append(("wall shelf", 1.0, blo, bhi, SHELF_KINDS, away, shelf_kw))
    if top > LOW_SUPPORT_Z_M:
        plo, phi = flo.copy(), fhi.copy()
        c = (glo[:2] + ghi[:2]) / 2
        half = np.maximum((ghi[:2] - glo[:2]) * 0.35, SUPPORT_MIN_SIDE_M / 2)
        plo[:2], phi[:2] = c - half, c + half
        candidates.append(("pedestal", 3.0, plo, phi, PEDESTAL_KINDS, None, floor_kw))
    for fl, fh in ((flo, fhi), (glo, ghi)):  # a riser (or board) on whatever is under the objects
        base = _base_under(fl, fh, top, space)
        if base > LOW_SUPPORT_Z_M:
            blo, bhi = fl.copy(), fh.copy()
            blo[2], bhi[2] = base, top
            candidates.append(("riser", 3.5, blo, bhi, SHELF_KINDS if top - base < 0.1 else RISER_KINDS, None,
                               {"corridor": base < OVERHEAD_CLEAR_Z_M, "doors": False, "openings": True}))

    reasons: list[str] = []
    best = None
    for label, rank, blo, bhi, kinds, away, kw in candidates:
        assets = _library_kind(library, kinds)
        if not assets:
            reasons.append(f"{label}: no model of kind {'/'.join(kinds)}")
            continue
        trimmed = _trim(blo, bhi, space, keep)
        if trimmed is None:
            reasons.append(f"{label}: {space.why_not(blo, bhi) or 'no room'}")
            continue
        tlo, thi = trimmed
        if len(group) == 1 and top < ROBOT_HEIGHT_M and np.all(tlo[:2] >= glo[:2] - 1e-9) \
                and np.all(thi[:2] <= ghi[:2] + 1e-9):
            # within the object's own footprint, below the robot's height: it takes no floor the robot could
            # use (the object is already there), so the corridor and doorway tests do not apply
            kw = {**kw, "corridor": False, "doors": False}
        why = space.why_not(tlo, thi, **kw)
        if why is not None:
            reasons.append(f"{label}: {why}")
            continue
        if label == "riser" and not _rests_on_something(tlo, thi, space):
            reasons.append("riser: what is left does not rest on anything")
            continue
        got = carried(tlo, thi)
        if not got:
            reasons.append(f"{label}: what is left between the other objects carries too little")
            continue
        area0 = float(np.prod((bhi - blo)[:2]))
        if label in ("floor unit", "rug") and float(np.prod((thi - tlo)[:2])) < TRIMMED_FLOOR_AREA * area0:
            rank = 2.0
        key = (len(got), -rank)
        if best is None or key > best[0]:
            best = (key, got, label, tlo, thi, assets, away)
    if best is None:
        return [], reasons
    _, got, label, tlo, thi, assets, away = best
    if away is None:
        away = _nearest_wall_away(space, tlo, thi)
    tiled = label == "floor unit" and assets[0].kind in TILED_KINDS
    _place_unit_run(library, assets, tlo, thi, away, rng, bounds_of, out, "support", tiled)
    space.add(tlo, thi)
    out.boxes.setdefault("support", []).append((tlo, thi))
    return got, reasons


def _base_under(lo: np.ndarray, hi: np.ndarray, top: float, space: _Space) -> float:
    """The highest top (m) of a GT cuboid or placed box overlapping the footprint lo..hi below ``top`` (0: floor)."""
    base = 0.0
    for blo, bhi in ((space.gt_lo, space.gt_hi), (space.placed_lo, space.placed_hi)):
        for b0, b1 in zip(blo, bhi):
            if b1[2] <= top + 1e-9 and _overlap_area(lo, hi, b0, b1) > 1e-6:
                base = max(base, float(b1[2]))
    return base


def _rests_on_something(lo: np.ndarray, hi: np.ndarray, space: _Space) -> bool:
    """Whether a box lo..hi stands on GT cuboids / placed boxes (tops within 1 mm of its bottom) carrying at least
    half of its footprint."""
    area = 0.0
    for blo, bhi in ((space.gt_lo, space.gt_hi), (space.placed_lo, space.placed_hi)):
        for b0, b1 in zip(blo, bhi):
            if abs(b1[2] - lo[2]) <= 1e-3:
                area += _overlap_area(lo, hi, b0, b1)
    return area >= 0.5 * float(np.prod((hi - lo)[:2]))


def _support_group(group, boxes, names, space: _Space, library, plan, seed, bounds_of, out: Furnishing) -> dict:
    """Supports under ``group``: one for all if possible, then one per object left; {index: why} of those left."""
    rng = _rng(seed, "support", *(names[i] for i in group))
    got, reasons = _support_attempt(group, boxes, names, space, library, plan, rng, bounds_of, out)
    left = {}
    for i in group:
        if i in got:
            continue
        if len(group) == 1:
            left[i] = "; ".join(reasons)
            continue
        g1, r1 = _support_attempt([i], boxes, names, space, library, plan, _rng(seed, "support1", names[i]),
                                  bounds_of, out)
        if not g1:
            left[i] = "; ".join(dict.fromkeys(r1))
    return left


def _place_supports(objects, boxes, present: set[int], space: _Space, library, plan, seed, bounds_of,
                    out: Furnishing) -> None:
    need = []
    for i, obj in enumerate(objects):
        lo, hi = boxes[i]
        if lo[2] <= FLOAT_MIN_Z_M or np.any(hi - lo <= 1e-6) or _rests_on(i, boxes):
            continue
        if _hangs(obj, boxes[i], space):
            if i in present:
                out.hanging.append(i)
            continue
        need.append(i)
    names = [f"{o.get('class')} {o.get('ID_name', i)}" for i, o in enumerate(objects)]
    for group in _group_floating(objects, boxes, need, plan):
        left = _support_group(group, boxes, names, space, library, plan, seed, bounds_of, out)
        out.unsupported.extend((i, why) for i, why in sorted(left.items()) if i in present)


# ------------------------------------------------------------------------------------------------------ distractors
def _natural_box(asset, a: np.ndarray, t: np.ndarray, n: np.ndarray, s: float, z0: float, scale: float):
    """Box of an asset at natural size × scale with its back on the line a + t·s (the wall face), front along n."""
    w, d, h = (float(v) * scale for v in asset.size_m)
    p0 = a + t * s
    p1 = p0 + t * w + n * d
    lo = np.array([min(p0[0], p1[0]), min(p0[1], p1[1]), z0])
    hi = np.array([max(p0[0], p1[0]), max(p0[1], p1[1]), z0 + h])
    return lo, hi, w


def _weighted_kind(rng, table, library) -> list:
    avail = [(k, wt, _library_kind(library, (k,))) for k, wt in table]
    avail = [x for x in avail if x[2]]
    if not avail:
        return []
    p = np.array([x[1] for x in avail], dtype=np.float64)
    return avail[int(rng.choice(len(avail), p=p / p.sum()))][2]


def _add(out: Furnishing, space: _Space, a, lo, hi, k, role, bounds_of) -> None:
    out.placements.append(Placement(a.id, fit_to_cuboid(a, lo, hi, k, bounds=bounds_of(a)), -1, role))
    space.add(lo, hi)
    out.boxes.setdefault(role, []).append((lo, hi))


def _place_span(span, idx: int, space: _Space, library, plan, seed, bounds_of, out: Furnishing) -> None:
    a = np.asarray(span.a, dtype=np.float64)[:2]
    b = np.asarray(span.b, dtype=np.float64)[:2]
    n = np.asarray(span.inward, dtype=np.float64)[:2]
    length = float(np.linalg.norm(b - a))
    if length < 0.3:
        return
    t = (b - a) / length
    k = turns_facing(n)
    rng = _rng(seed, "span", idx)
    room = next((r for r in plan.rooms if int(getattr(r, "index", -2)) == int(span.room)), None)
    if room is None:
        room = _room_of(plan, (a + b) / 2 + n * 0.1)
    table = ROOM_DISTRACTORS.get(getattr(room, "kind", "hall"), ROOM_DISTRACTORS["hall"])
    max_h = float(getattr(span, "max_height", math.inf))  # under a window: its sill
    s = float(rng.uniform(0.05, 0.4))
    while s < length - 0.3:
        if rng.random() > DISTRACTOR_FILL:
            s += float(rng.uniform(0.3, 1.0))
            continue
        assets = _weighted_kind(rng, table, library)
        if not assets:
            break
        asset = assets[int(rng.integers(len(assets)))]
        lo, hi, w = _natural_box(asset, a, t, n, s, 0.0, float(rng.uniform(0.95, 1.05)))
        if s + w <= length and hi[2] <= max_h and space.why_not(lo, hi, gt_margin=DISTRACTOR_CLEARANCE_M,
                                             placed_margin=DISTRACTOR_CLEARANCE_M, openings=True) is None:
            _add(out, space, asset, lo, hi, k, "distractor", bounds_of)
            s += w + float(rng.uniform(0.05, 0.5))
        else:
            s += 0.2
    # pictures / mirrors on the wall above the robot
    pics = _library_kind(library, WALL_DISTRACTORS)
    s = float(rng.uniform(0.2, 0.8))
    while pics and s < length - 0.3:
        asset = pics[int(rng.integers(len(pics)))]
        zc = float(rng.uniform(*PICTURE_CENTRE_Z_M))
        sc = float(rng.uniform(0.9, 1.1))
        h = float(asset.size_m[2]) * sc
        z0 = max(zc - h / 2, OVERHEAD_CLEAR_Z_M)
        lo, hi, w = _natural_box(asset, a, t, n, s, z0, sc)
        if (s + w <= length and hi[2] < float(getattr(plan, "wall_height", 2.6)) - 0.05
                and space.why_not(lo, hi, gt_margin=DISTRACTOR_CLEARANCE_M, placed_margin=DISTRACTOR_CLEARANCE_M,
                                  corridor=False, doors=False, openings=True) is None):
            _add(out, space, asset, lo, hi, k, "distractor", bounds_of)
            s += w + float(rng.uniform(0.8, 2.0))
        else:
            s += 0.3


def _place_openings(space: _Space, library, plan, seed, bounds_of, out: Furnishing) -> None:
    H = float(getattr(plan, "wall_height", 2.6))
    for idx, o in enumerate(getattr(plan, "openings", []) or []):
        lo, hi = np.asarray(o.lo, dtype=np.float64), np.asarray(o.hi, dtype=np.float64)
        outward = np.asarray(o.outward, dtype=np.float64)[:2]
        rng = _rng(seed, "opening", idx)
        if o.kind == "door":
            if not getattr(o, "leaf", True):
                continue  # an open passage (open plan): no door model
            ax = int(np.argmax(np.abs(outward)))
            zlo, zhi = lo.copy(), hi.copy()
            zlo[ax] -= 0.5
            zhi[ax] += 0.5
            on_path = space.blocked(zlo, zhi)  # the robot passes (or passes by): no closed door leaf
            kinds = ("door_frame", "doorway") if on_path else ("door", "door_frame", "doorway")
            assets = next((list(library.by_kind(kd)) for kd in kinds if library.by_kind(kd)), [])
            role = "door"
        else:
            assets = list(library.by_kind("window"))
            role = "window"
        if assets and np.all(hi - lo > 1e-6):
            pick = choose_model(assets, hi - lo, -outward, FACING_WEIGHT, rng)
            a, k = pick
            out.placements.append(Placement(a.id, fit_to_cuboid(a, lo, hi, k, bounds=bounds_of(a)), -1, role))
            out.boxes.setdefault(role, []).append((lo, hi))
        if o.kind != "window":
            continue
        ax = int(np.argmax(np.abs(outward)))
        along = 1 - ax
        inward = -outward
        face = lo[ax] if inward[ax] < 0 else hi[ax]  # the hole's face on the room side
        # a radiator under the window
        rads = _library_kind(library, ("radiator",))
        sill = float(lo[2])
        if rads and sill > 0.45:
            asset = rads[int(rng.integers(len(rads)))]
            w0, d0, h0 = (float(v) for v in asset.size_m)
            sc = min(1.0, (sill - 0.2) / h0, (hi[along] - lo[along]) * 0.9 / w0)
            w, d, h = w0 * sc, d0 * sc, h0 * sc
            c = (lo[along] + hi[along]) / 2
            blo, bhi = np.zeros(3), np.zeros(3)
            blo[along], bhi[along] = c - w / 2, c + w / 2
            blo[ax], bhi[ax] = (face, face + d) if inward[ax] > 0 else (face - d, face)
            blo[2], bhi[2] = 0.12, 0.12 + h
            if space.why_not(blo, bhi, gt_margin=DISTRACTOR_CLEARANCE_M, placed_margin=0.0) is None:
                _add(out, space, asset, blo, bhi, turns_facing(inward), "distractor", bounds_of)
        # curtains beside the window
        curtains = _library_kind(library, ("curtain",))
        if curtains:
            asset = curtains[int(rng.integers(len(curtains)))]
            width = float(np.clip(asset.size_m[0], 0.25, 0.5))
            depth = float(np.clip(asset.size_m[1], 0.05, 0.15))
            top = min(H - 0.02, float(hi[2]) + 0.15)
            for side in (-1.0, 1.0):
                blo, bhi = np.zeros(3), np.zeros(3)
                edge = lo[along] if side < 0 else hi[along]
                blo[along], bhi[along] = (edge - width, edge) if side < 0 else (edge, edge + width)
                blo[ax], bhi[ax] = (face, face + depth) if inward[ax] > 0 else (face - depth, face)
                blo[2], bhi[2] = 0.02, top
                if space.why_not(blo, bhi, gt_margin=DISTRACTOR_CLEARANCE_M, placed_margin=0.0) is None:
                    _add(out, space, asset, blo, bhi, turns_facing(inward), "distractor", bounds_of)


def _place_lights(space: _Space, library, plan, seed, bounds_of, out: Furnishing) -> None:
    lamps = _library_kind(library, ("ceiling_lamp",))
    if not lamps:
        return
    H = float(getattr(plan, "wall_height", 2.6))
    for idx, p in enumerate(getattr(plan, "lights", []) or []):
        p = np.asarray(p, dtype=np.float64).reshape(3)
        rng = _rng(seed, "light", idx)
        asset = lamps[int(rng.integers(len(lamps)))]
        w, d, h = (float(v) for v in asset.size_m)
        drop = min(LAMP_MAX_DROP_M, max(H - p[2] - 0.02, 0.03))
        sc = min(1.0, drop / h)
        lo = np.array([p[0] - w * sc / 2, p[1] - d * sc / 2, H - h * sc])
        hi = np.array([p[0] + w * sc / 2, p[1] + d * sc / 2, H])
        if space.why_not(lo, hi, gt_margin=DISTRACTOR_CLEARANCE_M, corridor=False, doors=False) is None:
            _add(out, space, asset, lo, hi, int(rng.integers(4)), "light", bounds_of)


# ------------------------------------------------------------------------------------------------------ entry points
def _default_bounds_of(asset: Any) -> np.ndarray:
    return asset_bounds(asset)


def _dedupe(objs: Sequence[dict]) -> list[dict]:
    seen, out = set(), []
    for o in objs:
        key = (str(o.get("class")), str(o.get("ID_name")), tuple(np.round(np.asarray(o["centroid"], float), 6)),
               tuple(np.round(np.asarray(o["extent"], float), 6)))
        if key not in seen:
            seen.add(key)
            out.append(o)
    return out


def furnish_home(objects: Sequence[dict], plan: Any, library: Any, *, seed: int = 0,
                 context_objects: Sequence[dict] | None = None,
                 bounds_of: Callable[[Any], np.ndarray] | None = None) -> Furnishing:
    """Models, supports, distractors, doors, windows and lamps for one environment (see the module docstring).

    Args:
        objects: the environment's GT objects (dicts with ``class``, ``centroid`` (3,), ``extent`` (3,), optional
            ``ID_name``, ``isgroup``), map frame, metres.
        plan: its :class:`~benchbot_sim_taichi.floorplan.FloorPlan`.
        library: an :class:`~benchbot.core.assets.AssetLibrary`.
        seed: the same seed gives the same placements.
        context_objects: every GT object of the home (the union over its variants). Supports and distractors are
            derived from these, so the variants of a home share their furniture; default ``objects``.
        bounds_of: the (2, 3) true model-frame bounds of an asset (e.g. its mesh's) for exact fits; default from
            ``size_m``.

    Returns:
        A :class:`Furnishing`.
    """
    bounds_of = bounds_of or _default_bounds_of
    objects = list(objects)
    context = _dedupe(list(context_objects or []) + objects) if context_objects is not None else list(objects)
    ctx_boxes = [_gt_box(o) for o in context]
    space = _Space(plan, ctx_boxes, [f"{o.get('class')} {o.get('ID_name', '')}".strip() for o in context])
    out = Furnishing()
    boxes = [_gt_box(o) for o in objects]
    _place_objects(objects, boxes, space, library, seed, bounds_of, out)
    # supports for the whole home (stable across variants), then distractors
    ctx_out = Furnishing()
    _place_supports(context, ctx_boxes, set(range(len(context))), space, library, plan, seed, bounds_of, ctx_out)
    _place_openings(space, library, plan, seed, bounds_of, ctx_out)
    for idx, span in enumerate(getattr(plan, "wall_spans", []) or []):
        _place_span(span, idx, space, library, plan, seed, bounds_of, ctx_out)
    _place_lights(space, library, plan, seed, bounds_of, ctx_out)
    out.placements.extend(ctx_out.placements)
    for role, bl in ctx_out.boxes.items():
        out.boxes.setdefault(role, []).extend(bl)
    # report in terms of `objects`; an object that floats here although it rests on something in the home's
    # union (that something is absent in this variant) gets a support of its own
    ctx_index = {_key(o): j for j, o in enumerate(context)}
    unsupported_ctx = dict(ctx_out.unsupported)
    hanging_ctx = set(ctx_out.hanging)
    extra = []
    for i, o in enumerate(objects):
        j = ctx_index.get(_key(o))
        if j in hanging_ctx:
            out.hanging.append(i)
        elif j in unsupported_ctx:
            out.unsupported.append((i, unsupported_ctx[j]))
        elif boxes[i][0][2] > FLOAT_MIN_Z_M and np.all(boxes[i][1] - boxes[i][0] > 1e-6) \
                and not _rests_on(i, boxes) and not _supported_by(boxes[i], out.boxes.get("support", [])):
            extra.append(i)
    if extra:
        local = Furnishing()
        sub = [objects[i] for i in extra]
        _place_supports_local(sub, [boxes[i] for i in extra], space, library, plan, seed, bounds_of, local)
        out.placements.extend(local.placements)
        for role, bl in local.boxes.items():
            out.boxes.setdefault(role, []).extend(bl)
        out.unsupported.extend((extra[j], why) for j, why in local.unsupported)
        out.hanging.extend(extra[j] for j in local.hanging)
    out.unsupported.sort()
    out.hanging.sort()
    for i, why in out.unsupported:
        log.info("furnish: object %d (%s) has no support: %s", i, objects[i].get("class"), why)
    return out


def _key(o: dict):
    return (str(o.get("class")), str(o.get("ID_name")), tuple(np.round(np.asarray(o["centroid"], float), 6)),
            tuple(np.round(np.asarray(o["extent"], float), 6)))


def _supported_by(box, supports) -> bool:
    lo, hi = box
    area = max((hi[0] - lo[0]) * (hi[1] - lo[1]), 1e-12)
    return any(abs(shi[2] - lo[2]) <= REST_TOL_M and _overlap_area(lo, hi, slo, shi) >= REST_MIN_OVERLAP * area
               for slo, shi in supports)


def _place_supports_local(objs, boxes, space, library, plan, seed, bounds_of, out) -> None:
    _place_supports(objs, boxes, set(range(len(objs))), space, library, plan, seed, bounds_of, out)


def furnish(objects: Sequence[dict], plan: Any, library: Any, *, seed: int = 0,
            context_objects: Sequence[dict] | None = None,
            bounds_of: Callable[[Any], np.ndarray] | None = None) -> list[Placement]:
    """The placements of :func:`furnish_home` (which also reports objects without a model or support)."""
    return furnish_home(objects, plan, library, seed=seed, context_objects=context_objects,
                        bounds_of=bounds_of).placements
