"""Rooms of a procedural home: room count and types, areas, guillotine cuts of an outer rectangle, and doors (pure
NumPy; metres, ``map`` frame, the outer rectangle's low corner at the origin).

Rules (a designer's, stated once here):

* 1-12 rooms, skewed to 3-7 (:data:`ROOM_COUNT_WEIGHTS`). One room: a living room (a studio). Two or more: at least
  one bedroom and one living room; three or more: a bathroom; four or more: a kitchen (at most one); the rest from
  :data:`EXTRA_KIND_WEIGHTS` (at most one bathroom per three rooms, one dining room, one office per four rooms).
* Areas by type (:data:`AREA_M2`, uniform in the range). A bathroom is 6.25-8 m²: the 3 m² lower end is below
  :data:`~benchbot_worlds.homes.floorplan.MIN_ROOM_SIDE_M` squared (2.5 m a side), which wins.
* The outer rectangle has the rooms' total area and an aspect of 1-1.6; it is cut recursively (a guillotine): a
  cell's rooms are split into two groups of balanced area, the cut runs across the cell's longer side at the groups'
  area ratio, clamped so that every room is at least ``MIN_ROOM_SIDE_M`` a side. Positions are rounded to 1 mm.
* Doors (0.9-1.0 m wide, jambs >= :data:`~benchbot_worlds.homes.floorplan.DOOR_JAMB_M` from the wall ends and the
  walls they meet): a spanning tree of the adjacency graph of the rooms other than bathrooms (drawn by a seeded
  random order of the edges), each bathroom one door to a neighbour that is no bathroom, and with probability
  :data:`EXTRA_DOOR_P` one more door between two rooms that are no bathrooms. A bathroom whose removal would cut the
  other rooms apart, or that has only bathrooms as neighbours, becomes a hall (a hall where needed to connect).

Every loop is bounded (:data:`MAX_LAYOUT_TRIES`); when no partition satisfies the side rule, the home loses a room
(the last drawn that is no bedroom or living room) and tries again, and that is recorded in the notes.
"""

from __future__ import annotations

import numpy as np

from benchbot_worlds.homes.floorplan import DOOR_JAMB_M, MIN_ROOM_SIDE_M, WALL_THICKNESS_M
from benchbot_worlds.procedural.layout import Cut, Door, Layout, RoomBox

#: Weights of 1..12 rooms.
ROOM_COUNT_WEIGHTS = (2, 4, 9, 12, 13, 11, 9, 5, 3, 2, 1, 1)
#: Room areas by type (m², uniform between the two).
AREA_M2 = {"bedroom": (9.0, 16.0), "bathroom": (6.25, 8.0), "kitchen": (8.0, 14.0), "living_room": (16.0, 30.0),
           "dining_room": (10.0, 16.0), "office": (7.5, 12.0), "hall": (6.25, 12.0)}
#: Weights of the rooms beyond the required ones.
EXTRA_KIND_WEIGHTS = {"bedroom": 4.0, "bathroom": 2.0, "office": 1.5, "dining_room": 1.5, "hall": 1.0}
#: Door widths (m), uniform.
DOOR_WIDTH_M = (0.9, 1.0)
#: Probability of one door beyond the spanning tree.
EXTRA_DOOR_P = 0.3
#: Attempts at a partition before a room is dropped.
MAX_LAYOUT_TRIES = 24
#: Outer aspect ratio range (long / short side).
ASPECT = (1.0, 1.6)


def room_kinds(rng: np.random.Generator) -> list[str]:
    """The room types of a home (list of :data:`~benchbot_worlds.procedural.layout.ROOM_TYPES` names, 1-12 long),
    drawn from ``rng`` by the module's rules."""
    w = np.asarray(ROOM_COUNT_WEIGHTS, dtype=np.float64)
    n = int(rng.choice(len(w), p=w / w.sum())) + 1
    if n == 1:
        return ["living_room"]
    kinds = ["bedroom", "living_room"] + (["bathroom"] if n >= 3 else []) + (["kitchen"] if n >= 4 else [])
    names = list(EXTRA_KIND_WEIGHTS)
    while len(kinds) < n:  # bounded: every pass adds a room (a bedroom and a hall are never capped)
        ok = [k for k in names if not ((k == "bathroom" and kinds.count(k) >= max(1, n // 3))
                                       or (k == "dining_room" and k in kinds)
                                       or (k == "office" and kinds.count(k) >= max(1, n // 4)))]
        p = np.array([EXTRA_KIND_WEIGHTS[k] for k in ok])
        kinds.append(ok[int(rng.choice(len(ok), p=p / p.sum()))])
    return kinds


def _split(rng, lo, hi, items, areas, cuts, leaves) -> bool:
    """Cut the cell lo..hi holding ``items`` (room indices) recursively; False when a room would be too narrow."""
    size = hi - lo
    if len(items) == 1:
        leaves.append((items[0], lo, hi))
        return bool(np.all(size >= MIN_ROOM_SIDE_M - 1e-9))
    ax = int(np.argmax(size)) if abs(size[0] - size[1]) > 1e-9 else int(rng.integers(2))
    order = [items[i] for i in rng.permutation(len(items))]
    tot = sum(areas[i] for i in order)
    acc, k = 0.0, 1
    for j in range(1, len(order)):  # the group boundary closest to half the area
        acc += areas[order[j - 1]]
        if abs(acc - tot / 2) < abs(sum(areas[i] for i in order[:k]) - tot / 2):
            k = j
    a, b = order[:k], order[k:]
    frac = sum(areas[i] for i in a) / tot
    pos = lo[ax] + frac * size[ax]
    pos = min(max(pos, lo[ax] + MIN_ROOM_SIDE_M), hi[ax] - MIN_ROOM_SIDE_M)
    pos = round(pos, 3)
    if pos - lo[ax] < MIN_ROOM_SIDE_M - 1e-9 or hi[ax] - pos < MIN_ROOM_SIDE_M - 1e-9:
        return False
    o = 1 - ax
    cuts.append(Cut(ax, pos, float(lo[o]), float(hi[o])))
    h1, l2 = hi.copy(), lo.copy()
    h1[ax] = l2[ax] = pos
    return _split(rng, lo, h1, a, areas, cuts, leaves) and _split(rng, l2, hi, b, areas, cuts, leaves)


def _partition(rng, kinds: list[str]):
    """(outer_hi, cuts, rooms) of one attempt, or None."""
    areas = [float(rng.uniform(*AREA_M2[k])) for k in kinds]
    total = sum(areas)
    aspect = float(rng.uniform(*ASPECT))
    w = round(max(np.sqrt(total * aspect), MIN_ROOM_SIDE_M), 3)
    h = round(max(total / w, MIN_ROOM_SIDE_M), 3)
    if rng.integers(2):
        w, h = h, w
    hi = np.array([w, h])
    cuts: list[Cut] = []
    leaves: list = []
    if not _split(rng, np.zeros(2), hi, list(range(len(kinds))), areas, cuts, leaves):
        return None
    leaves.sort(key=lambda t: (round(float(t[1][1]), 6), round(float(t[1][0]), 6)))  # as the floor plan sorts rooms
    rooms = [RoomBox(i, kinds[k], lo.copy(), h2.copy()) for i, (k, lo, h2) in enumerate(leaves)]
    return hi, cuts, rooms


def adjacency(rooms: list[RoomBox], min_shared_m: float) -> list[tuple[int, int, int, float, float, float]]:
    """Pairs of rooms sharing a wall at least ``min_shared_m`` long: (a, b, axis, pos, lo, hi), a < b, the shared
    stretch ``lo``..``hi`` (between wall centre lines) of the wall line x[axis] = pos; sorted."""
    out = []
    for a in rooms:
        for b in rooms:
            for ax in (0, 1):
                if abs(a.hi[ax] - b.lo[ax]) > 1e-9:
                    continue
                o = 1 - ax
                lo, hi = max(a.lo[o], b.lo[o]), min(a.hi[o], b.hi[o])
                if hi - lo >= min_shared_m:
                    i, j = sorted((a.index, b.index))
                    out.append((i, j, ax, float(a.hi[ax]), float(lo), float(hi)))
    return sorted(out)


def _connected(n: int, edges, allowed: set) -> bool:
    parent = list(range(n))

    def find(i):
        while parent[i] != i:
            i = parent[i]
        return i

    for a, b, *_ in edges:
        if a in allowed and b in allowed:
            parent[find(a)] = find(b)
    return len({find(i) for i in sorted(allowed)}) <= 1


def _doors(rng, rooms: list[RoomBox]) -> tuple[list[RoomBox], list[Door]] | None:
    """Doors by the module's rules; bathrooms that must connect others become halls. None when the doors cannot
    connect every room."""
    t = WALL_THICKNESS_M
    edges = adjacency(rooms, DOOR_WIDTH_M[1] + 2 * DOOR_JAMB_M + t)
    n = len(rooms)
    kinds = [r.kind for r in rooms]
    for i in range(n):  # bounded: one pass over the rooms
        if kinds[i] != "bathroom":
            continue
        others = {j for j in range(n) if kinds[j] != "bathroom"}
        nbr = {b if a == i else a for a, b, *_ in edges if i in (a, b)}
        if not _connected(n, edges, others) or not (nbr & others):
            kinds[i] = "hall"
    rooms = [RoomBox(r.index, kinds[r.index], r.lo, r.hi) for r in rooms]
    normal = {j for j in range(n) if kinds[j] != "bathroom"}
    order = [edges[i] for i in rng.permutation(len(edges))]
    parent = list(range(n))

    def find(i):
        while parent[i] != i:
            i = parent[i]
        return i

    chosen, spare = [], []
    for e in order:
        a, b = e[0], e[1]
        if a in normal and b in normal:
            if find(a) != find(b):
                parent[find(a)] = find(b)
                chosen.append(e)
            else:
                spare.append(e)
    for i in range(n):
        if i not in normal:
            cand = [e for e in order if i in e[:2] and (e[0] in normal or e[1] in normal)]
            if not cand:
                return None
            chosen.append(cand[0])
    if spare and rng.random() < EXTRA_DOOR_P:
        chosen.append(spare[0])
    doors = []
    for a, b, ax, pos, lo, hi in sorted(chosen):
        w = round(float(rng.uniform(*DOOR_WIDTH_M)), 3)
        s0, s1 = lo + t / 2 + DOOR_JAMB_M, hi - t / 2 - DOOR_JAMB_M - w
        s = round(float(rng.uniform(s0, s1)), 3)
        s = min(max(s, s0), s1)
        doors.append(Door((a, b), ax, pos, s, round(s + w, 6)))
    if not _connected(n, [d.rooms for d in doors], set(range(n))):
        return None  # rooms meeting only in stretches too short for a door
    return rooms, doors


def generate_layout(rng: np.random.Generator, notes: list[str] | None = None) -> Layout:
    """A procedural home's :class:`~benchbot_worlds.procedural.layout.Layout` drawn from ``rng`` (a
    ``numpy.random.Generator``, PCG64 from a 64-bit seed): rooms tiling the outer rectangle (low corner at the
    origin, metres, map frame), each at least ``MIN_ROOM_SIDE_M`` a side, sorted by (lo y, lo x) as the floor plan
    sorts its rooms, and doors connecting them all. Relaxed rules (a room dropped) are appended to ``notes``.
    Never raises for a valid generator: a single room always fits."""
    kinds = room_kinds(rng)
    for _ in range(len(kinds)):  # bounded: every failed round drops a room
        for _ in range(MAX_LAYOUT_TRIES):
            got = _partition(rng, kinds)
            if got is not None:
                hi, cuts, rooms = got
                got = _doors(rng, rooms)
                if got is None:
                    continue
                rooms, doors = got
                return Layout(np.zeros(2), hi, cuts, rooms, doors, WALL_THICKNESS_M)
        drop = max(i for i, k in enumerate(kinds) if k not in ("bedroom", "living_room") or i >= 2)
        if notes is not None:
            notes.append(f"layout: no partition of {len(kinds)} rooms in {MAX_LAYOUT_TRIES} tries; "
                         f"dropped a {kinds[drop]}")
        kinds = kinds[:drop] + kinds[drop + 1:]
    raise AssertionError("unreachable: one room always fits")
