"""Supports under floating ground-truth objects: counters, cabinets, shelves, pedestals, risers (pure NumPy).

A GT object whose bottom is above :data:`FLOAT_MIN_Z_M` that does not rest on another GT object (:func:`rests_on`)
and does not hang on a wall (:data:`HANGING_CLASSES`) gets a support. Neighbouring floating objects (gap ≤
:data:`SUPPORT_GROUP_GAP_M`, bottoms within :data:`REST_TOL_M`, same room) share one, its top at their lowest bottom
(exactly that object's bottom; the others rest within :data:`REST_TOL_M`); groups are served lowest first. The
candidates, each trimmed around GT cuboids and furniture in its way: a floor unit (kinds by room and height) backed
onto a wall within :data:`SUPPORT_TO_WALL_M`; a floor unit just under the objects (+ :data:`SUPPORT_MARGIN_M`); one
exactly under a single object; a thin wall shelf against a wall within :data:`WALL_SHELF_REACH_M`; a slim pedestal;
a riser standing on a support or a flat-topped GT object under them (:data:`FLAT_TOP_CLASSES`). The one carrying the
most objects wins; among equals an untrimmed floor unit, a wall shelf, a much-trimmed, slim or low floor unit, a
pedestal, a riser. Floor furniture (:data:`FLOOR_CLASSES`) at most :data:`LOW_SUPPORT_Z_M` up gets a rug or plinth.
Each support avoids every GT cuboid, the room kept open above a basin (:data:`OPEN_ABOVE_M`; an object floating
in it gets a support of its own, a board on the basin's top), wall, other furniture, window and door hole and the
doorways (:data:`SUPPORT_DOOR_CLEARANCE_M`; not for one inside a single object's footprint), and stays out of the robot
corridor except where GT objects below the robot's height already take the floor
(:meth:`~benchbot_worlds.homes.furnish_space.Space.blocked_beyond_gt`), or, for a shelf, when its underside is above
:data:`~benchbot_worlds.homes.furnish_space.OVERHEAD_CLEAR_Z_M`. Objects left without one are reported with why.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from benchbot_worlds.homes.fitting import FACING_WEIGHT, RANDOM_FACING_WEIGHT, choose_model, fit_to_cuboid
from benchbot_worlds.homes.furnish_space import (
    OVERHEAD_CLEAR_Z_M, ROBOT_HEIGHT_M, Furnishing, Placement, Space, boxes_hit, furniture_of_kinds,
    nearest_wall_away, overlap_area, rect_gap, room_of, seeded_rng, wall_faces)

#: A GT object whose bottom is above this height (m) needs something under it.
FLOAT_MIN_Z_M = 0.05

#: Classes that stand on their own foot: BEAR boxes only the bowl of two of house:1's toilets (0.08 and 0.16 m over
#: the floor, no cistern), so a support under them was a plinth or a cabinet carrying a toilet. An object of one of
#: these classes whose bottom is at most :data:`OWN_FOOT_MAX_Z_M` up gets no support: its model is fitted from the floor
#: to the cuboid's top (:func:`standing_box`), its foot under the cuboid. The cuboid (ground truth) is unchanged.
OWN_FOOT_CLASSES = frozenset(("toilet",))

#: See OWN_FOOT_CLASSES (m): a toilet's bowl starts at most this high over the floor.
OWN_FOOT_MAX_Z_M = 0.25

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

#: Narrowest side (m) of a support (it is trimmed around GT cuboids and furniture in its way, down to this).
SUPPORT_MIN_SIDE_M = 0.1

#: Free floor (m) a floor support keeps on both sides of a doorway (less than DOOR_CLEARANCE_M: it stands under
#: a GT object that is there anyway).
SUPPORT_DOOR_CLEARANCE_M = 0.3

#: Objects at most this high (m) get a rug or plinth of that thickness instead of a piece of furniture ...
LOW_SUPPORT_Z_M = 0.15
#: ... reaching this far (m) around them ...
LOW_SUPPORT_MARGIN_M = 0.12
#: ... of the first of these kinds the library has.
LOW_SUPPORT_KINDS = ("rug", "plinth", "cabinet")
#: Kinds of wall shelves and boards (the first the library has).
SHELF_KINDS = ("wall_shelf", "shelf")
#: Kinds of pedestals (the first the library has).
PEDESTAL_KINDS = ("pedestal", "plant_stand", "nightstand", "cabinet")

#: A floor support trimmed to less than this fraction of its area ranks below a wall shelf ...
TRIMMED_FLOOR_AREA = 0.7
#: ... and so does one with a side narrower than this (m) ...
SLIM_UNIT_SIDE_M = 0.25
#: ... or lower than this (m).
LOW_UNIT_TOP_M = 0.3

#: GT classes with a flat top a riser may stand on (besides supports and distractors).
FLAT_TOP_CLASSES = frozenset(("table", "refrigerator", "oven", "microwave", "sink"))
#: GT classes that stand on the floor: a few centimetres up, they get a rug or plinth (LOW_SUPPORT_KINDS); other
#: objects that low get the usual candidates (a low wall shelf: the bottom board of a shelving unit).
FLOOR_CLASSES = frozenset(("chair", "table", "couch", "bed", "toilet", "refrigerator", "oven", "person",
                           "potted plant", "sink"))
#: GT classes whose top stays open (the room, m, above their cuboid) to a support that does not stand on them: a
#: basin and its tap. A wall shelf 1 cm over the minirooms' sink once covered its basin, the tap through the board; the
#: objects beside the basin now get shelves beside it. A board standing on the sink's top (a riser) is still allowed:
#: it carries an object that floats over the basin (:func:`_over_open`).
OPEN_ABOVE_M = {"sink": 0.3}

#: Kinds of a riser: a unit standing on a GT object or support under the objects (a thin one is a board).
RISER_KINDS = ("shelf", "bookcase", "cabinet")

#: Smallest depth (m) of a floor support backed onto a wall.
SUPPORT_MIN_DEPTH_M = 0.35

#: A wall shelf is used when a wall face is at most this far (m) from the objects.
WALL_SHELF_REACH_M = 0.6

#: Thickness (m) of a wall shelf.
WALL_SHELF_THICKNESS_M = 0.04

#: Most units (side by side) in one counter/cabinet run.
MAX_SUPPORT_UNITS = 8

#: Kinds of units that are tiled side by side along a long support.
TILED_KINDS = frozenset(("counter", "cabinet", "kitchen_cabinet"))


def stands_on_own_foot(obj: dict, box) -> bool:
    """Whether a GT object (its dict and its box (lo (3,), hi (3,)), map frame, metres) floats a little and stands on
    its own foot instead of a support (:data:`OWN_FOOT_CLASSES`, bottom over :data:`FLOAT_MIN_Z_M` and at most
    :data:`OWN_FOOT_MAX_Z_M`)."""
    lo, _ = box
    return str(obj.get("class", "")) in OWN_FOOT_CLASSES and FLOAT_MIN_Z_M < float(lo[2]) <= OWN_FOOT_MAX_Z_M


def standing_box(obj: dict, box) -> tuple[np.ndarray, np.ndarray]:
    """The box (lo (3,), hi (3,)) float64, map frame, metres, that a GT object's model fills: its cuboid, reaching
    down to the floor (z = 0) when it :func:`stands_on_own_foot`."""
    lo, hi = (np.asarray(b, dtype=np.float64).copy() for b in box)
    if stands_on_own_foot(obj, (lo, hi)):
        lo[2] = 0.0
    return lo, hi


def rests_on(i: int, boxes) -> bool:
    """Whether GT box ``i`` rests on another one: that one starts lower, its top is within REST_TOL_M below to
    REST_SINK_M above box i's bottom, and it carries at least REST_MIN_OVERLAP of box i's footprint."""
    lo, hi = boxes[i]
    area = max((hi[0] - lo[0]) * (hi[1] - lo[1]), 1e-12)
    for j, (blo, bhi) in enumerate(boxes):
        if (j != i and blo[2] < lo[2] - 1e-6 and lo[2] - REST_TOL_M <= bhi[2] <= lo[2] + REST_SINK_M
                and overlap_area(lo, hi, blo, bhi) >= REST_MIN_OVERLAP * area):
            return True
    return False


def _hangs(obj: dict, box, space: Space) -> bool:
    if str(obj.get("class", "")) not in HANGING_CLASSES:
        return False
    lo, hi = box
    faces = wall_faces(space, lo, hi, (lo[2], hi[2]))
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
            if abs(alo[2] - blo[2]) > REST_TOL_M or rect_gap(alo, ahi, blo, bhi) > SUPPORT_GROUP_GAP_M:
                continue
            ra, rb = room_of(plan, (alo[:2] + ahi[:2]) / 2), room_of(plan, (blo[:2] + bhi[:2]) / 2)
            if ra is not rb:
                continue
            parent[find(i)] = find(j)
    groups: dict[int, list[int]] = {}
    for i in need:
        groups.setdefault(find(i), []).append(i)
    return sorted(groups.values())


def _trim(lo: np.ndarray, hi: np.ndarray, space: Space, keep: Callable[[np.ndarray, np.ndarray], float]):
    """Shrink the box lo..hi until it intersects no GT cuboid, no support/distractor and no room kept open above a GT
    cuboid (:func:`_open_above`), each time cutting the side that keeps the most ``keep(lo, hi)`` (then area). None if
    that leaves a sliver (< SUPPORT_MIN_SIDE_M)."""
    lo, hi = lo.copy(), hi.copy()
    alo, ahi = _open_above(lo, space)
    olo = np.vstack([space.gt_lo, space.placed_lo, alo])
    ohi = np.vstack([space.gt_hi, space.placed_hi, ahi])
    for _ in range(24):
        hit = np.flatnonzero(boxes_hit(lo, hi, olo, ohi, -1e-6))
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


def _open_rooms(space: Space) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lo (K, 3), hi (K, 3), rows (K,) int), the frame of ``space``, m: the room kept open above each GT cuboid of
    ``space`` whose class is in :data:`OPEN_ABOVE_M`, from its top up by its headroom, and that cuboid's row."""
    rows = np.array([k for k, c in enumerate(space.gt_classes) if c in OPEN_ABOVE_M], dtype=int)
    alo, ahi = space.gt_lo[rows].reshape(-1, 3).copy(), space.gt_hi[rows].reshape(-1, 3).copy()
    alo[:, 2] = ahi[:, 2]
    ahi[:, 2] += [OPEN_ABOVE_M[space.gt_classes[k]] for k in rows]
    return alo, ahi, rows


def _open_above(lo: np.ndarray, space: Space) -> tuple[np.ndarray, np.ndarray]:
    """(lo (K, 3), hi (K, 3)) of :func:`_open_rooms` that a support whose bottom is at height ``lo[2]`` (m) must keep
    clear of: all but those above a cuboid it stands on (its top within 1 mm of ``lo[2]``, as
    :func:`_rests_on_something`)."""
    alo, ahi, _ = _open_rooms(space)
    keep = np.abs(alo[:, 2] - float(lo[2])) > 1e-3
    return alo[keep], ahi[keep]


def _over_open(box, space: Space) -> bool:
    """Whether the GT ``box`` (lo (3,), hi (3,), m) floats in a room of :func:`_open_rooms`: its bottom from
    REST_TOL_M under that room's bottom to its top, and at least REST_MIN_OVERLAP of its footprint over the cuboid's
    (miniroom_2's toaster over its sink). It then gets a support of its own, a board standing on that cuboid, and its
    neighbours' support stays clear of the room."""
    lo, hi = box
    area = max((hi[0] - lo[0]) * (hi[1] - lo[1]), 1e-12)
    alo, ahi, rows = _open_rooms(space)
    return any(alo[j, 2] - REST_TOL_M <= lo[2] < ahi[j, 2]
               and overlap_area(lo, hi, space.gt_lo[k], space.gt_hi[k]) >= REST_MIN_OVERLAP * area
               for j, k in enumerate(rows))


def _support_attempt(group, boxes, names, classes, space: Space, library, plan, rng, bounds_of, out: Furnishing):
    """Try to place one support under the objects ``group``: (indices it carries, reasons for what failed).

    Candidates (each trimmed around GT cuboids and placed furniture in its way): a floor unit backed onto a wall
    within SUPPORT_TO_WALL_M, a floor unit just under the objects, a wall shelf, a slim pedestal, and last a riser
    standing on whatever is under them (a GT object or a support). The candidate carrying the
    most objects wins; among equals: an untrimmed floor unit, a wall shelf, a floor unit trimmed to less than
    TRIMMED_FLOOR_AREA of itself (or slimmer than SLIM_UNIT_SIDE_M, or lower than LOW_UNIT_TOP_M), a pedestal, a
    riser. Floor furniture at most LOW_SUPPORT_Z_M up gets a rug or plinth. A support within a single object's
    footprint below ROBOT_HEIGHT_M skips the doorway test."""
    glo = np.min([boxes[i][0] for i in group], axis=0)
    ghi = np.max([boxes[i][1] for i in group], axis=0)
    top = float(glo[2])
    room = room_of(plan, (glo[:2] + ghi[:2]) / 2)
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
            if blo[2] - hi[2] <= REST_TOL_M and overlap_area(lo, hi, blo, bhi) >= REST_MIN_OVERLAP * area:
                got.append(i)
        return got

    def keep(lo, hi) -> float:
        return sum(overlap_area(lo, hi, *boxes[i]) for i in group)

    floor_kw = {"doors": SUPPORT_DOOR_CLEARANCE_M, "corridor": "beyond_gt"}
    candidates = []  # (label, rank, lo, hi, kinds, away, why_not kwargs)
    low = top <= LOW_SUPPORT_Z_M
    if low and all(str(classes[i]) in FLOOR_CLASSES for i in group):
        rlo, rhi = flo.copy(), fhi.copy()
        rlo[:2] -= LOW_SUPPORT_MARGIN_M - SUPPORT_MARGIN_M
        rhi[:2] += LOW_SUPPORT_MARGIN_M - SUPPORT_MARGIN_M
        candidates.append(("rug", 0.0, rlo, rhi, LOW_SUPPORT_KINDS, None, floor_kw))
        candidates.append(("rug", 0.5, flo.copy(), fhi.copy(), LOW_SUPPORT_KINDS, None, floor_kw))
    else:
        kinds = _support_kinds(room_kind, top)
        faces = wall_faces(space, flo, fhi)
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
    shelf_kw = {"corridor": "beyond_gt" if zr[0] < OVERHEAD_CLEAR_Z_M else False, "doors": False, "openings": True}
    wfaces = [f for f in wall_faces(space, flo, fhi, zr) if f[0] <= WALL_SHELF_REACH_M]
    if wfaces and zr[0] > 0.0:
        _, away, ax, face = wfaces[0]
        for rank, (fl, fh) in ((1.0, (flo, fhi)), (1.2, (glo, ghi))):  # with the margin, and without
            blo, bhi = fl.copy(), fh.copy()
            blo[2], bhi[2] = zr
            if away[ax] > 0:
                blo[ax] = face
            else:
                bhi[ax] = face
            candidates.append(("wall shelf", rank, blo, bhi, SHELF_KINDS, away, shelf_kw))
    if not low:
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
                               {**shelf_kw, "corridor": "beyond_gt" if base < OVERHEAD_CLEAR_Z_M else False}))

    reasons: list[str] = []
    best = None
    for label, rank, blo, bhi, kinds, away, kw in candidates:
        assets = furniture_of_kinds(library, kinds)
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
            # use (the object is already there), so the doorway test does not apply
            kw = {**kw, "doors": False}
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
        if label == "floor unit" and (float(np.min((thi - tlo)[:2])) < SLIM_UNIT_SIDE_M or top < LOW_UNIT_TOP_M):
            rank = max(rank, 2.0)  # a sliver or a squashed cabinet looks worse than a shelf board
        key = (len(got), -rank)
        if best is None or key > best[0]:
            best = (key, got, label, tlo, thi, assets, away)
    if best is None:
        return [], reasons
    _, got, label, tlo, thi, assets, away = best
    if away is None:
        away = nearest_wall_away(space, tlo, thi)
    tiled = label == "floor unit" and assets[0].kind in TILED_KINDS
    _place_unit_run(library, assets, tlo, thi, away, rng, bounds_of, out, "support", tiled)
    space.add(tlo, thi)
    out.boxes.setdefault("support", []).append((tlo, thi))
    return got, reasons


def _flat_gt(space: Space) -> np.ndarray:
    """(N,) which GT cuboids of ``space`` have a flat top something may stand on (FLAT_TOP_CLASSES)."""
    flat = [c in FLAT_TOP_CLASSES for c in space.gt_classes]
    return np.array(flat + [False] * (len(space.gt_lo) - len(flat)), dtype=bool)


def _base_under(lo: np.ndarray, hi: np.ndarray, top: float, space: Space) -> float:
    """The highest top (m) under ``top`` of a flat-topped GT cuboid or a placed box overlapping the footprint lo..hi
    (0: the floor)."""
    base = 0.0
    flat = _flat_gt(space)
    for blo, bhi in ((space.gt_lo[flat], space.gt_hi[flat]), (space.placed_lo, space.placed_hi)):
        for b0, b1 in zip(blo, bhi):
            if b1[2] <= top + 1e-9 and overlap_area(lo, hi, b0, b1) > 1e-6:
                base = max(base, float(b1[2]))
    return base


def _rests_on_something(lo: np.ndarray, hi: np.ndarray, space: Space) -> bool:
    """Whether a box lo..hi stands on GT cuboids / placed boxes (tops within 1 mm of its bottom) carrying at least
    half of its footprint."""
    area = 0.0
    flat = _flat_gt(space)
    for blo, bhi in ((space.gt_lo[flat], space.gt_hi[flat]), (space.placed_lo, space.placed_hi)):
        for b0, b1 in zip(blo, bhi):
            if abs(b1[2] - lo[2]) <= 1e-3:
                area += overlap_area(lo, hi, b0, b1)
    return area >= 0.5 * float(np.prod((hi - lo)[:2]))


def _support_group(group, boxes, names, classes, space: Space, library, plan, seed, bounds_of,
                   out: Furnishing) -> dict:
    """Supports under ``group``: one for all if possible, then one per object left; {index: why} of those left."""
    rng = seeded_rng(seed, "support", *(names[i] for i in group))
    got, reasons = _support_attempt(group, boxes, names, classes, space, library, plan, rng, bounds_of, out)
    left = {}
    for i in group:
        if i in got:
            continue
        if len(group) == 1:
            left[i] = "; ".join(reasons)
            continue
        g1, r1 = _support_attempt([i], boxes, names, classes, space, library, plan,
                                  seeded_rng(seed, "support1", names[i]), bounds_of, out)
        if not g1:
            left[i] = "; ".join(dict.fromkeys(r1))
    return left


def place_supports(objects: list[dict], boxes: list, space: Space, library, plan, seed: int,
                   bounds_of: Callable, out: Furnishing) -> None:
    """Supports for the GT ``objects`` (their boxes ``boxes``: (lo (3,), hi (3,)) each) that need one, added to
    ``out`` (placements, ``boxes['support']``) and to ``space``; ``out.hanging`` / ``out.unsupported`` get the
    indices of those that hang on a wall / were left without (with why)."""
    need = []
    for i, obj in enumerate(objects):
        lo, hi = boxes[i]
        if (lo[2] <= FLOAT_MIN_Z_M or np.any(hi - lo <= 1e-6) or rests_on(i, boxes)
                or stands_on_own_foot(obj, (lo, hi))):
            continue
        if _hangs(obj, boxes[i], space):
            out.hanging.append(i)
            continue
        need.append(i)
    names = [f"{o.get('class')} {o.get('ID_name', i)}" for i, o in enumerate(objects)]
    classes = [str(o.get("class", "")) for o in objects]
    groups = []
    for group in _group_floating(objects, boxes, need, plan):
        over = [i for i in group if _over_open(boxes[i], space)]
        groups += [[i] for i in over] + [[i for i in group if i not in over]] * (len(over) < len(group))
    # lowest first: furniture under the lower objects of a shelving column is placed before the boards above them
    for group in sorted(groups, key=lambda g: min(boxes[i][0][2] for i in g)):
        left = _support_group(group, boxes, names, classes, space, library, plan, seed, bounds_of, out)
        out.unsupported.extend(sorted(left.items()))


def supported_by(box, supports) -> bool:
    """Whether a support box (of ``supports``: (lo, hi) each) carries the GT ``box``: its top within REST_TOL_M
    under the box's bottom and at least REST_MIN_OVERLAP of its footprint."""
    lo, hi = box
    area = max((hi[0] - lo[0]) * (hi[1] - lo[1]), 1e-12)
    return any(abs(shi[2] - lo[2]) <= REST_TOL_M and overlap_area(lo, hi, slo, shi) >= REST_MIN_OVERLAP * area
               for slo, shi in supports)
