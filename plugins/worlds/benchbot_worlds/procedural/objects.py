"""Ground-truth objects of a procedural home, placed by rules per room type (pure NumPy; metres, ``map`` frame, z up,
floor at z = 0; axis-aligned cuboids as BEAR's are).

Data: the class counts and sizes are BEAR's (Hall et al., "The Robotic Vision Scene Understanding Challenge",
arXiv:2009.05246; ground truths of benchbot-addons ``ground_truths_isaac_develop``, bundled as
``benchbot_worlds/data/bear/*.json``): :data:`BEAR_CLASS_COUNTS` are the counts over its 10 files (369 objects) and
:data:`BEAR_SIZES` the (min, median, max) of each class's (shorter side, longer side, height), measured with::

    python -c "import json,glob,numpy as np; ..."   # per class: min/median/max of sorted xy extents and z extent

and :data:`BEAR_FORMS` the same per form of a class whose objects differ in shape (laptops: closed or open), told
apart by height, and :data:`BEAR_GROUPS` the same for single objects and groups (BEAR's ``isgroup``: a row or a pile
of books as one cuboid) of a class that has both (plugins/worlds/tests/test_procedural_homes.py recomputes all four
from the bundled files). An object's size is BEAR's median of its class, or of a form or kind drawn in BEAR's
proportion, ± 15 % (:func:`draw_object`); a group is marked ``isgroup`` in the ground truth, as BEAR's are (since
generator version 4). The seven classes BEAR never has (knife, wine glass, fork, cake, cell phone, microwave, oven)
are not generated: a goodness-of-fit test against BEAR's proportions has zero expected counts for them.

How many of each class: a quota of ``N`` objects apportioned by BEAR's proportions (floor of ``N p`` plus the
remainders drawn by weight), ``N`` large enough that every bedroom gets a bed and every bathroom a toilet
(``N >= beds / p_bed``, ``N >= toilets / p_toilet``) and at least :data:`DENSITY_PER_M2` per m² of floor, but at
most :data:`MAX_OBJECTS` (120; BEAR's homes hold 18-57); a capped home still gets a bed per bedroom and a toilet per
bathroom, taken from the classes most above their share. (A quota, not a promise: a bed that fits in no place of
its bedroom goes to the leftovers; over seeds 0-199, 83 of 588 bedrooms and bathrooms miss theirs.)

Where (a designer's rules): a bed against a wall of a bedroom (head to the wall; BEAR's smallest bed, with
:data:`BED_RETRY_FACTOR` times the draws, when the drawn one finds no place); a toilet and a sink against
bathroom walls; a refrigerator and a sink against kitchen walls, the fridge with :data:`FRIDGE_FRONT_M` of floor
in front of it that no floor object takes (since generator version 3); a couch against a living-room wall facing a
tv standing on a low table (tv stand) against the opposite wall, a coffee table between; a dining table (kitchen,
dining room) free-standing with chairs around it; an office desk (table) against a wall with a chair, and a
workstation on it: a keyboard at its front edge, a monitor (tv) behind it against the wall, a mouse at its right
(a home with keyboards and no office gets its desk in a bedroom, else a living room, since generator version 5),
a laptop beside; side tables in bedrooms; potted plants and persons standing on the floor; small objects
(cup, bowl, bottle, book, apple, orange, banana, spoon, toaster, clock) on table tops (their bottom exactly on the
top); potted plants on the floor or a table. Every floor object lies inside its room's clear floor, overlaps no
other object, keeps the door approaches (:data:`DOOR_APPROACH_M` deep on both sides of each door) clear, and the
room's floor stays connected for a robot of radius :data:`ROBOT_RADIUS_M` plus :data:`CHECK_MARGIN_M` (every
door's approach in one free component of an occupancy grid, holding :data:`MAIN_FREE_FRACTION` of the free floor);
the generator then checks the whole home against the trajectory's own free-space model and drops what still
blocks the robot (:func:`benchbot_worlds.procedural.generator.generate_home`). An object that finds no place in :data:`PLACE_TRIES` draws is dropped and noted.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from benchbot_worlds.procedural.layout import Layout, RoomBox

#: BEAR's class counts over its 10 ground-truth files (369 objects).
BEAR_CLASS_COUNTS = {
    "chair": 57, "bowl": 46, "potted plant": 41, "book": 38, "table": 36, "cup": 28, "bottle": 22, "toilet": 14,
    "couch": 11, "bed": 10, "tv": 10, "sink": 9, "clock": 7, "laptop": 7, "keyboard": 5, "mouse": 5, "apple": 4,
    "toaster": 4, "orange": 4, "person": 4, "spoon": 3, "refrigerator": 3, "banana": 1,
}
#: Per class: (min, median, max) of (shorter side, longer side, height), metres, over BEAR's objects.
BEAR_SIZES = {
    "chair": ((0.366, 0.371, 0.386), (0.504, 0.543, 0.509), (0.783, 0.825, 1.292)),
    "bowl": ((0.146, 0.146, 0.048), (0.227, 0.229, 0.113), (0.521, 0.547, 0.254)),
    "potted plant": ((0.236, 0.286, 0.347), (0.379, 0.425, 0.686), (0.933, 1.012, 2.046)),
    "book": ((0.049, 0.166, 0.036), (0.247, 0.294, 0.131), (0.337, 0.339, 0.305)),
    "table": ((0.405, 0.454, 0.301), (0.817, 0.955, 0.345), (1.505, 1.601, 0.906)),
    "cup": ((0.065, 0.066, 0.065), (0.117, 0.149, 0.119), (0.119, 0.155, 0.15)),
    "bottle": ((0.06, 0.06, 0.13), (0.101, 0.104, 0.382), (0.236, 0.307, 0.384)),
    "toilet": ((0.369, 0.574, 0.262), (0.399, 0.603, 0.376), (0.4, 0.621, 0.873)),
    "couch": ((0.864, 1.959, 0.782), (0.914, 1.959, 0.782), (1.187, 2.069, 0.782)),
    "bed": ((1.636, 2.051, 0.766), (1.744, 2.175, 0.831), (1.852, 2.299, 0.896)),
    "tv": ((0.059, 0.534, 0.532), (0.195, 0.534, 0.532), (0.195, 1.467, 0.907)),
    "sink": ((0.275, 0.329, 0.145), (0.565, 0.568, 1.014), (0.565, 0.568, 1.014)),
    "clock": ((0.07, 0.17, 0.17), (0.17, 0.229, 0.228), (0.237, 0.237, 0.237)),
    "laptop": ((0.25, 0.34, 0.026), (0.25, 0.34, 0.026), (0.42, 0.433, 0.296)),
    "keyboard": ((0.142, 0.311, 0.017), (0.142, 0.311, 0.017), (0.142, 0.311, 0.017)),
    "mouse": ((0.061, 0.113, 0.016), (0.061, 0.113, 0.016), (0.061, 0.113, 0.016)),
    "apple": ((0.068, 0.07, 0.078), (0.068, 0.07, 0.078), (0.068, 0.07, 0.078)),
    "orange": ((0.088, 0.089, 0.089), (0.092, 0.092, 0.092), (0.096, 0.096, 0.096)),
    "person": ((0.438, 0.671, 1.333), (0.454, 0.713, 1.607), (0.474, 0.75, 1.882)),
    "toaster": ((0.15, 0.253, 0.143), (0.172, 0.253, 0.2), (0.172, 0.308, 0.2)),
    "refrigerator": ((0.854, 0.945, 1.919), (0.854, 0.945, 1.919), (0.854, 0.945, 1.919)),
    "spoon": ((0.084, 0.121, 0.262), (0.084, 0.121, 0.262), (0.084, 0.121, 0.262)),
    "banana": ((0.038, 0.226, 0.113), (0.038, 0.226, 0.113), (0.038, 0.226, 0.113)),
}
#: Classes whose BEAR objects come in forms of distinct shape, told apart by height: per form, its upper height bound
#: (m), BEAR's count and the (min, median, max) of its (shorter side, longer side, height). Five of BEAR's seven
#: laptops are closed (2.6 cm high), two open (24 and 30 cm), so the class's median is a closed one.
BEAR_FORMS = {
    "laptop": {
        "closed": (0.1, 5, ((0.25, 0.34, 0.026), (0.25, 0.34, 0.026), (0.25, 0.34, 0.026))),
        "open": (1.0, 2, ((0.386, 0.389, 0.237), (0.403, 0.411, 0.266), (0.42, 0.433, 0.296))),
    },
}
#: Classes whose BEAR objects are single objects or groups (``isgroup``): per kind (False: single, True: group),
#: BEAR's count and the (min, median, max) of its (shorter side, longer side, height). All 29 of BEAR's groups are
#: books (rows and piles); its 9 single books lie flat (3.6 cm) but one, which stands (18.9 cm).
BEAR_GROUPS = {
    "book": {
        False: (9, ((0.049, 0.166, 0.036), (0.297, 0.311, 0.036), (0.297, 0.311, 0.189))),
        True: (29, ((0.188, 0.26, 0.055), (0.247, 0.289, 0.131), (0.337, 0.339, 0.305))),
    },
}
#: Table heights by role (m), inside BEAR's table heights (0.30-0.91).
TABLE_HEIGHT_M = {"dining": (0.72, 0.78), "desk": (0.72, 0.76), "coffee": (0.35, 0.45), "side": (0.45, 0.6),
                  "stand": (0.4, 0.55)}
#: Table tops by role: (shorter, longer) side ranges (m), inside BEAR's (0.41-1.6).
TABLE_TOP_M = {"dining": ((0.8, 1.0), (1.1, 1.6)), "desk": ((0.6, 0.75), (1.1, 1.4)), "coffee": ((0.5, 0.7),
               (0.9, 1.2)), "side": ((0.45, 0.6), (0.6, 1.0)), "stand": ((0.4, 0.5), (1.0, 1.5))}
SMALL_CLASSES = ("bowl", "book", "cup", "bottle", "clock", "apple", "orange", "banana", "spoon", "toaster")
DESK_CLASSES = ("laptop", "keyboard", "mouse")
#: Rooms, in order, that take a desk for the keyboards of a home with no office (:func:`_workstations`).
WORKSTATION_ROOMS = ("bedroom", "living_room", "dining_room", "hall")
#: Least objects per m² of floor; the robot's radius (m); door approach depth (m); gaps (m); draws per object.
DENSITY_PER_M2 = 0.8
ROBOT_RADIUS_M = 0.35
#: The room check's radius exceeds the robot's by this (m), so that a passage it keeps open is open in the
#: trajectory's free-space model too (:mod:`.free_space`: other grid, exact distances), whatever the grids' offsets.
CHECK_MARGIN_M = 0.05
DOOR_APPROACH_M = 0.85  # >= the 0.7 m asked; the trajectory stops 0.1 m + its radius beyond a wall's face
#: Floor kept clear in front of a refrigerator (m, across its width): its doors swing out 0.45-0.8 m and someone
#: stands at them, so no table or chair stands there (the NKBA's kitchen planning guidelines ask a walkway of at least
#: 36 in, 0.91 m).
FRIDGE_FRONT_M = 0.9
WALL_GAP_M = 0.03
OBJECT_GAP_M = 0.05
PLACE_TRIES = 30
#: A bedroom whose bed finds no place tries BEAR's smallest bed with this many times :data:`PLACE_TRIES` draws.
BED_RETRY_FACTOR = 3
#: Rooms tried for a leftover floor object; emptiest table tops tried for an object on a table.
ROOM_TRIES = 4
TOP_TRIES = 8
GRID_M = 0.05
#: The door's free component holds at least this fraction of a room's free floor.
MAIN_FREE_FRACTION = 0.9
#: Most objects in a home's quota (variants add a few).
MAX_OBJECTS = 120


def bear_proportions() -> tuple[list[str], np.ndarray]:
    """(classes, (C,) float64 proportions) of :data:`BEAR_CLASS_COUNTS`, classes in its order."""
    names = list(BEAR_CLASS_COUNTS)
    c = np.array([BEAR_CLASS_COUNTS[k] for k in names], dtype=np.float64)
    return names, c / c.sum()


def quota(rng: np.random.Generator, layout: Layout) -> dict[str, int]:
    """Class counts of a home (see the module docstring): {class: count} over :data:`BEAR_CLASS_COUNTS`' classes."""
    names, p = bear_proportions()
    kinds = [r.kind for r in layout.rooms]
    area = sum(float(np.prod(r.hi - r.lo)) for r in layout.rooms)
    need = [kinds.count("bedroom") / p[names.index("bed")], kinds.count("bathroom") / p[names.index("toilet")],
            DENSITY_PER_M2 * area]
    n = int(min(MAX_OBJECTS, np.ceil(max(need) - 1e-9)))
    base = np.floor(n * p + 1e-9).astype(int)
    rest = n - int(base.sum())
    rem = n * p - base
    if rest > 0:
        extra = rng.choice(len(p), size=rest, replace=False, p=rem / rem.sum())
        base[extra] += 1
    for cls, kind in (("bed", "bedroom"), ("toilet", "bathroom")):  # capped homes: the room rules first
        k = names.index(cls)
        while base[k] < kinds.count(kind):  # bounded: each pass moves one object from the class most in excess
            give = int(np.argmax(np.where(base > 0, base - n * p, -np.inf) - 1e9 * np.isin(names, ("bed", "toilet"))))
            base[give] -= 1
            base[k] += 1
    return {k: int(v) for k, v in zip(names, base)}


def draw_object(rng: np.random.Generator, cls: str,
                form_rng: np.random.Generator | None = None) -> tuple[np.ndarray, bool]:
    """((3,) float64 (shorter side, longer side, height) in metres, ``isgroup``) of a ``cls`` object: BEAR's median
    scaled by exp(U(-0.15, 0.15)) per dimension, clipped to BEAR's range (:data:`BEAR_SIZES`), rounded to 1 mm. A
    class of :data:`BEAR_FORMS` first draws its form with BEAR's proportions (an open laptop 2 times in 7), a class
    of :data:`BEAR_GROUPS` whether it is a group (a book 29 times in 38), from ``form_rng`` (default ``rng``), then
    a size of that form or kind the same way; ``isgroup`` is False for every other class.

    Raises:
        KeyError: ``cls`` is not one of :data:`BEAR_SIZES`' classes.
    """
    sizes, group = BEAR_SIZES[cls], False
    if cls in BEAR_FORMS:
        forms = list(BEAR_FORMS[cls].values())
        counts = np.array([f[1] for f in forms], dtype=np.float64)
        sizes = forms[int((form_rng or rng).choice(len(forms), p=counts / counts.sum()))][2]
    elif cls in BEAR_GROUPS:
        counts = np.array([BEAR_GROUPS[cls][False][0], BEAR_GROUPS[cls][True][0]], dtype=np.float64)
        group = bool((form_rng or rng).choice(2, p=counts / counts.sum()))
        sizes = BEAR_GROUPS[cls][group][1]
    lo, med, hi = (np.asarray(v) for v in sizes)
    s = np.clip(med * np.exp(rng.uniform(-0.15, 0.15, 3)), lo, hi)
    s[:2] = np.sort(s[:2])
    return np.round(s, 3), group


def draw_size(rng: np.random.Generator, cls: str, form_rng: np.random.Generator | None = None) -> np.ndarray:
    """The size of :func:`draw_object` alone: (3,) float64 (shorter side, longer side, height), metres.

    Raises:
        KeyError: ``cls`` is not one of :data:`BEAR_SIZES`' classes.
    """
    return draw_object(rng, cls, form_rng)[0]


def table_size(rng: np.random.Generator, role: str) -> np.ndarray:
    """(3,) float64 (shorter side, longer side, height) of a table of ``role`` (:data:`TABLE_TOP_M`)."""
    (a0, a1), (b0, b1) = TABLE_TOP_M[role]
    return np.round(np.array([rng.uniform(a0, a1), rng.uniform(b0, b1), rng.uniform(*TABLE_HEIGHT_M[role])]), 3)


class RoomSpace:
    """The free floor of one room: its clear floor box, door approach boxes, placed floor boxes and an occupancy
    check for the robot (every door approach in one free component)."""

    def __init__(self, room: RoomBox, layout: Layout):
        t = layout.wall_thickness
        self.room = room
        self.lo = np.array([room.lo[k] + (0.0 if room.lo[k] <= layout.outer_lo[k] else t / 2) for k in range(2)])
        self.hi = np.array([room.hi[k] - (0.0 if room.hi[k] >= layout.outer_hi[k] else t / 2) for k in range(2)])
        self.keep_out, self.doors = [], []
        for d in layout.doors:
            if room.index not in d.rooms:
                continue
            lo, hi = np.zeros(2), np.zeros(2)
            lo[d.axis], hi[d.axis] = d.pos - t / 2 - DOOR_APPROACH_M, d.pos + t / 2 + DOOR_APPROACH_M
            lo[1 - d.axis], hi[1 - d.axis] = d.lo - 0.1, d.hi + 0.1
            self.keep_out.append((lo, hi))
            p = d.centre.copy()
            p[d.axis] += (0.5 if room.lo[d.axis] >= d.pos - 1e-9 else -0.5) * 1.1  # (the stop: 0.51)
            self.doors.append(p)
        self.boxes: list[tuple[np.ndarray, np.ndarray]] = []  # floor objects' xy boxes
        self._cache = None

    def fits(self, lo: np.ndarray, hi: np.ndarray, gap: float = OBJECT_GAP_M) -> bool:
        """Whether the xy box lo..hi lies in the clear floor and clear of door approaches and floor boxes."""
        if (lo[0] < self.lo[0] + WALL_GAP_M - 1e-9 or lo[1] < self.lo[1] + WALL_GAP_M - 1e-9
                or hi[0] > self.hi[0] - WALL_GAP_M + 1e-9 or hi[1] > self.hi[1] - WALL_GAP_M + 1e-9):
            return False
        for a, b in self.keep_out:
            if lo[0] < b[0] and lo[1] < b[1] and hi[0] > a[0] and hi[1] > a[1]:
                return False
        if not self.boxes:
            return True
        a, b = self._arrays()
        return not bool(np.any(np.all(lo < b + gap, axis=1) & np.all(hi > a - gap, axis=1)))

    def clear_floor(self, lo: np.ndarray, hi: np.ndarray) -> bool:
        """Whether the xy box lo..hi ((2,) float64 each, metres, map frame) lies in the room's clear floor and
        overlaps no floor object placed, contact allowed (it may overlap a door's approach: both stay free)."""
        if np.any(lo < self.lo - 1e-9) or np.any(hi > self.hi + 1e-9):
            return False
        if not self.boxes:
            return True
        a, b = self._arrays()
        return not bool(np.any(np.all(lo < b, axis=1) & np.all(hi > a, axis=1)))

    def _arrays(self) -> tuple[np.ndarray, np.ndarray]:
        if self._cache is None or len(self._cache[0]) != len(self.boxes):
            self._cache = (np.array([a for a, _ in self.boxes]), np.array([b for _, b in self.boxes]))
        return self._cache

    def connected_with(self, lo: np.ndarray, hi: np.ndarray) -> bool:
        """Whether, once lo..hi is occupied, every door approach lies in one free component of the room's floor
        for the robot (occupancy grid of :data:`GRID_M`, obstacles grown by :data:`ROBOT_RADIUS_M` + :data:`CHECK_MARGIN_M`) holding at
        least :data:`MAIN_FREE_FRACTION` of its free cells (no pocket at a door cut off from the room)."""
        n = np.maximum(1, np.ceil((self.hi - self.lo) / GRID_M).astype(int))
        xs = self.lo[0] + (np.arange(n[0]) + 0.5) * GRID_M
        ys = self.lo[1] + (np.arange(n[1]) + 0.5) * GRID_M
        X, Y = np.meshgrid(xs, ys, indexing="ij")
        r = ROBOT_RADIUS_M + CHECK_MARGIN_M
        free = (X > self.lo[0] + r) & (X < self.hi[0] - r) & (Y > self.lo[1] + r) & (Y < self.hi[1] - r)
        for a, b in self.boxes + [(lo, hi)]:
            dx = np.maximum(np.maximum(a[0] - X, X - b[0]), 0.0)
            dy = np.maximum(np.maximum(a[1] - Y, Y - b[1]), 0.0)
            free &= dx * dx + dy * dy > r * r
        lab, count = ndimage.label(free)
        if count == 0:
            return False
        sizes = np.bincount(lab.ravel(), minlength=count + 1)
        ids = set()
        for p in self.doors:
            i = np.clip(((p - self.lo) / GRID_M).astype(int), 0, n - 1)
            ids.add(int(lab[i[0], i[1]]))
        if 0 in ids or len(ids) > 1:
            return False
        main = ids.pop() if ids else int(np.argmax(sizes[1:])) + 1
        return sizes[main] >= MAIN_FREE_FRACTION * sizes[1:].sum()

    def try_box(self, lo: np.ndarray, hi: np.ndarray, gap: float = OBJECT_GAP_M) -> bool:
        """Occupy lo..hi when it :meth:`fits` and keeps the room :meth:`connected_with`; True when done."""
        if self.fits(lo, hi, gap) and self.connected_with(lo, hi):
            self.boxes.append((lo.copy(), hi.copy()))
            return True
        return False


class _Home:
    """Placement state: per-room spaces, the objects placed (class, lo (3,), hi (3,), room, role), the tables' tops
    (index into objects, xy boxes of what stands on them), the notes. A class's form (:data:`BEAR_FORMS`) comes from
    a stream of its own (``rng``'s bit generator jumped, ``rng`` untouched), so forms leave every other draw as is;
    ``rng``'s bit generator must be one that jumps (the generator's PCG64 does; SFC64 would raise AttributeError)."""

    def __init__(self, rng: np.random.Generator, layout: Layout, notes: list[str]):
        self.rng, self.layout, self.notes = rng, layout, notes
        self.form_rng = np.random.Generator(rng.bit_generator.jumped())
        self.spaces = [RoomSpace(r, layout) for r in layout.rooms]
        self.objects: list[dict] = []
        self.tops: dict[int, list] = {}
        self.tries = PLACE_TRIES  # draws per placement

    def draw_size(self, cls: str) -> np.ndarray:
        """:func:`draw_size` of ``cls`` from this home's streams."""
        return draw_size(self.rng, cls, self.form_rng)

    def draw_object(self, cls: str) -> tuple[np.ndarray, bool]:
        """:func:`draw_object` of ``cls`` from this home's streams: (size, isgroup)."""
        return draw_object(self.rng, cls, self.form_rng)

    def add(self, cls: str, lo, hi, room: int, role: str = "", group: bool = False) -> int:
        self.objects.append({"class": cls, "lo": np.asarray(lo, float), "hi": np.asarray(hi, float), "room": room,
                             "role": role, "isgroup": group})
        if cls == "table":
            self.tops[len(self.objects) - 1] = []
        return len(self.objects) - 1

    def wall_box(self, room: int, along: float, depth: float, side=None, front: float = 0.0):
        """An xy box (lo, hi, (axis, sign)) against a wall of ``room``: ``along`` metres along the wall, ``depth``
        out of it, placed when it fits; None after :data:`PLACE_TRIES` draws. With ``front`` > 0 the floor strip
        ``front`` metres deep in front of it (across its width) must lie in the room and hold no floor object, and
        is then kept clear of later ones (added to the room's keep-out boxes, as a door's approach is)."""
        sp = self.spaces[room]
        for _ in range(self.tries):
            ax, sg = side if side is not None else (int(self.rng.integers(2)), int(self.rng.choice([-1, 1])))
            o = 1 - ax
            lo, hi = np.zeros(2), np.zeros(2)
            if sg < 0:
                lo[ax] = sp.lo[ax] + WALL_GAP_M
            else:
                lo[ax] = sp.hi[ax] - WALL_GAP_M - depth
            hi[ax] = lo[ax] + depth
            free = sp.hi[o] - sp.lo[o] - 2 * WALL_GAP_M - along
            if free < 0:
                continue
            lo[o] = sp.lo[o] + WALL_GAP_M + float(self.rng.uniform(0, free))
            hi[o] = lo[o] + along
            lo, hi = np.round(lo, 6), np.round(hi, 6)
            strip = _front_strip(lo, hi, ax, sg, front) if front > 0 else None
            if strip is not None and not sp.clear_floor(*strip):
                continue
            if sp.try_box(lo, hi):
                if strip is not None:
                    sp.keep_out.append(strip)
                return lo, hi, (ax, sg)
        return None

    def free_box(self, room: int, size_xy, near=None, spread: float = 0.0, gap: float = OBJECT_GAP_M):
        """An xy box of ``size_xy`` (2,) anywhere on ``room``'s floor (or centred within ``spread`` of ``near``)."""
        sp = self.spaces[room]
        size = np.asarray(size_xy, float)
        for _ in range(self.tries):
            if near is None:
                room_free = sp.hi - sp.lo - size - 2 * WALL_GAP_M
                if np.any(room_free < 0):
                    return None
                lo = sp.lo + WALL_GAP_M + self.rng.uniform(0, 1, 2) * room_free
            else:
                lo = np.asarray(near, float) - size / 2 + self.rng.uniform(-spread, spread, 2)
            lo = np.round(lo, 6)
            hi = np.round(lo + size, 6)
            if sp.try_box(lo, hi, gap):
                return lo, hi
        return None

    def floor(self, cls: str, room: int, size, box, role: str = ""):
        """Add a floor object (bottom at z = 0) filling the xy ``box`` (lo, hi) and ``size[2]`` high."""
        lo, hi = box[0], box[1]
        return self.add(cls, [lo[0], lo[1], 0.0], [hi[0], hi[1], float(size[2])], room, role)

    def on_table(self, cls: str, size, tables: list[int], group: bool = False) -> bool:
        """Stand a ``cls`` object of ``size`` (a group when ``group``: BEAR's ``isgroup``) on the top of one of
        ``tables`` (tried in a seeded order)."""
        def used(ti):
            return float(sum((b[0] - a[0]) * (b[1] - a[1]) for a, b in self.tops[ti])) / float(
                (self.objects[ti]["hi"][0] - self.objects[ti]["lo"][0])
                * (self.objects[ti]["hi"][1] - self.objects[ti]["lo"][1]))

        fill = self.rng.uniform(0, 0.2, len(tables)) + np.array([used(ti) for ti in tables])
        for ti in [tables[i] for i in np.argsort(fill, kind="stable")[:TOP_TRIES]]:  # the emptiest tops first
            t = self.objects[ti]
            xy = np.array(size[:2]) if self.rng.random() < 0.5 else np.array(size[1::-1])
            room_free = t["hi"][:2] - t["lo"][:2] - xy - 0.02
            if np.any(room_free < 0):
                continue
            items = self.tops[ti]
            xs = [t["lo"][0] + 0.01] + [b[0] + 0.01 for a, b in items]
            ys = [t["lo"][1] + 0.01] + [b[1] + 0.01 for a, b in items]
            cands = [(x, y) for x in xs for y in ys] + [tuple(t["lo"][:2] + 0.01 + self.rng.uniform(0, 1, 2)
                                                                * room_free) for _ in range(4)]
            order = self.rng.permutation(len(cands))
            los = np.round(np.array(cands, dtype=np.float64), 6)
            his = np.round(los + xy, 6)
            ok = np.all(his <= t["hi"][:2] - 0.01 + 1e-9, axis=1)
            if items:  # clear of the items on the top by 1 cm
                ia, ib = np.array([a for a, _ in items]), np.array([b for _, b in items])
                ok &= ~np.any(np.all(los[:, None] < ib[None] + 0.01, axis=2) & np.all(his[:, None] > ia[None] - 0.01,
                                                                                      axis=2), axis=1)
            free = order[ok[order]]
            if len(free):  # the first free candidate in a seeded order
                lo, hi = los[free[0]].copy(), his[free[0]].copy()
                self.tops[ti].append((lo, hi))
                z = float(t["hi"][2])
                self.add(cls, [lo[0], lo[1], z], [hi[0], hi[1], z + float(size[2])], t["room"], "on", group)
                return True
        if cls == "book":  # a stack: on a book of at least this footprint, at most three high
            for i, o in enumerate(self.objects):
                if o["class"] == "book" and o.get("stack", 0) < 2 and not o.get("covered"):
                    xy = np.minimum(np.array(size[:2]), np.sort(o["hi"][:2] - o["lo"][:2]))
                    xy = xy if (o["hi"][0] - o["lo"][0]) <= (o["hi"][1] - o["lo"][1]) else xy[::-1]
                    lo = np.round((o["lo"][:2] + o["hi"][:2]) / 2 - xy / 2, 6)
                    o["covered"] = True
                    z = float(o["hi"][2])
                    j = self.add(cls, [lo[0], lo[1], z], [lo[0] + xy[0], lo[1] + xy[1], z + float(size[2])],
                                 o["room"], "on", group)
                    self.objects[j]["stack"] = o.get("stack", 0) + 1
                    return True
        return False


def _front_strip(lo: np.ndarray, hi: np.ndarray, ax: int, sg: int, depth: float):
    """(lo, hi), (2,) float64 each: the xy box ``depth`` metres deep in front of a wall box lo..hi (metres, map frame)
    whose back is against the wall on side (``ax``, ``sg``) of its room (sign -1: the wall at the room's low ``ax``),
    across its width."""
    flo, fhi = lo.copy(), hi.copy()
    if sg < 0:
        flo[ax], fhi[ax] = hi[ax], hi[ax] + depth
    else:
        flo[ax], fhi[ax] = lo[ax] - depth, lo[ax]
    return flo, fhi


def _wall_object(h: _Home, cls: str, room: int, size, long_along: bool, role: str = "", side=None):
    """A floor object against a wall: its longer side along the wall (``long_along``) or into the room (a bed, a
    couch, a table that does not fit so: turned a quarter); a refrigerator with :data:`FRIDGE_FRONT_M` of free
    floor in front of it, kept free."""
    front = FRIDGE_FRONT_M if cls == "refrigerator" else 0.0
    for flip in (False, True) if cls in ("bed", "couch", "table") else (False,):  # then turned a quarter
        along, depth = (size[1], size[0]) if long_along != flip else (size[0], size[1])
        got = h.wall_box(room, along, depth, side, front)
        if got is not None:
            return h.floor(cls, room, size, got[:2], role), got[2]
    return None


def _chairs_around(h: _Home, table: int, room: int, want: int, desk_side=None) -> int:
    """Up to ``want`` chairs at the sides of ``table`` (facing it, 0.05 m off its edge); the number placed."""
    t = h.objects[table]
    lo, hi = t["lo"][:2], t["hi"][:2]
    spots = []
    for ax in (0, 1):
        o = 1 - ax
        n = max(1, int((hi[o] - lo[o]) // 0.6))
        for sg in (-1, 1):
            if desk_side is not None and (ax, sg) != desk_side:
                continue
            for k in range(n):
                c = np.zeros(2)
                c[o] = lo[o] + (k + 0.5) * (hi[o] - lo[o]) / n
                c[ax] = (lo[ax] - 0.3) if sg < 0 else (hi[ax] + 0.3)
                spots.append(c)
    placed = 0
    for i in h.rng.permutation(len(spots)):
        if placed >= want:
            break
        size = h.draw_size("chair")
        box = h.free_box(room, size[:2], near=spots[i], spread=0.03, gap=0.02)
        if box is not None:
            h.floor("chair", room, size, box)
            placed += 1
    return placed


def _table(h: _Home, room: int, role: str, against_wall: bool):
    size = table_size(h.rng, role)
    if against_wall:
        got = _wall_object(h, "table", room, size, True, role)
        return got
    box = h.free_box(room, size[:2] if h.rng.random() < 0.5 else size[1::-1])
    return None if box is None else (h.floor("table", room, size, box, role), None)


def _opposite(side):
    return (side[0], -side[1])


def _living(h: _Home, room: int, left: dict) -> None:
    """Couch against a wall, a tv on a stand against the opposite wall facing it, a coffee table between."""
    if left["couch"] <= 0:
        return
    got = _wall_object(h, "couch", room, h.draw_size("couch"), True)
    if got is None:
        return
    left["couch"] -= 1
    if left["tv"] > 0 and left["table"] > 0:
        size = table_size(h.rng, "stand")
        stand = _wall_object(h, "table", room, size, True, "stand", side=_opposite(got[1]))
        if stand is not None:
            left["table"] -= 1
            _tv_on(h, stand[0], stand[1], left)
    if left["table"] > 0:
        c = h.objects[got[0]]
        mid = (c["lo"][:2] + c["hi"][:2]) / 2
        ax, sg = got[1]
        mid[ax] += -sg * (0.5 * (c["hi"][ax] - c["lo"][ax]) + 0.75)
        size = table_size(h.rng, "coffee")
        xy = np.array([size[1], size[0]]) if ax == 1 else size[:2]
        box = h.free_box(room, xy, near=mid, spread=0.1)
        if box is not None:
            h.floor("table", room, size, box, "coffee")
            left["table"] -= 1


def _tv_on(h: _Home, stand: int, side, left: dict) -> None:
    """A tv standing on ``stand``, its thin side across the wall ``side``."""
    t = h.objects[stand]
    size = h.draw_size("tv")
    ax = side[0]
    xy = np.zeros(2)
    xy[ax], xy[1 - ax] = size[0], min(size[1], t["hi"][1 - ax] - t["lo"][1 - ax] - 0.02)
    mid = (t["lo"][:2] + t["hi"][:2]) / 2
    lo, hi = np.round(mid - xy / 2, 6), np.round(mid + xy / 2, 6)
    z = float(t["hi"][2])
    h.tops[stand].append((lo, hi))
    h.add("tv", [lo[0], lo[1], z], [hi[0], hi[1], z + float(size[2])], t["room"], "on")
    left["tv"] -= 1


def _furnish_room(h: _Home, room: int, kind: str, left: dict, share: dict) -> None:
    """The anchors of one room by its kind (module docstring); ``share`` [kind] = the room's share of its kind's
    beds / toilets / sinks when a home has several such rooms."""
    def wall(cls, long_along, role=""):
        if left[cls] > 0 and _wall_object(h, cls, room, h.draw_size(cls), long_along, role) is not None:
            left[cls] -= 1
            return True
        return False

    if kind == "bedroom":
        for k in range(share.get("bed", 1)):
            if not wall("bed", False) and k == 0 and left["bed"] > 0:  # a tight bedroom: BEAR's smallest bed
                h.tries = PLACE_TRIES * BED_RETRY_FACTOR
                if _wall_object(h, "bed", room, np.array(BEAR_SIZES["bed"][0]), False) is not None:
                    left["bed"] -= 1
                h.tries = PLACE_TRIES
        if left["table"] > 0 and _table(h, room, "side", True) is not None:
            left["table"] -= 1
    elif kind == "bathroom":
        for _ in range(share.get("toilet", 1)):
            wall("toilet", False)
        for _ in range(share.get("sink", 1)):
            wall("sink", True)
    elif kind == "kitchen":
        wall("refrigerator", True)
        for _ in range(share.get("sink", 0)):
            wall("sink", True)
        _dining(h, room, left, 4)
    elif kind == "living_room":
        _living(h, room, left)
    elif kind == "dining_room":
        _dining(h, room, left, 6)
    elif kind == "office":
        _desk(h, room, left)


def _desk(h: _Home, room: int, left: dict) -> bool:
    """A desk (a table of role "desk") against a wall of ``room`` with a chair at its free side, when the quota has a
    table left; its wall side ``(axis, sign)`` is kept as the desk's ``"wall"``. Whether one was placed."""
    if left["table"] <= 0:
        return False
    got = _table(h, room, "desk", True)
    if got is None:
        return False
    left["table"] -= 1
    h.objects[got[0]]["wall"] = got[1]
    if left["chair"] > 0:
        left["chair"] -= _chairs_around(h, got[0], room, 1, desk_side=_opposite(got[1]))
    return True


def _workstation(h: _Home, desk: int, left: dict) -> bool:
    """A keyboard at the front edge of ``desk`` (the side away from its wall), its long side along the wall, with a
    monitor (a ``tv`` of the quota, if one is left) behind it against the wall and a mouse (if one is left) at the
    typist's right, as BEAR's one desk stands (house:1-5: a monitor 0.34 m behind the keyboard, the mouse beside it).
    Sizes are BEAR's (:func:`draw_size`), in metres in the map frame; the keyboard sits 5-10 cm in from the front edge,
    the monitor 2-6 cm off the wall, no wider than the top and on it, the mouse 4-6 cm beside the keyboard. Footprints
    are kept in ``h.tops[desk]`` so that later objects keep clear of them. Nothing is placed (False) when the top is
    too short for the keyboard and the mouse's room or too shallow for the keyboard and the monitor; else True. Raises
    nothing."""
    t = h.objects[desk]
    ax, sg = t["wall"]
    o = 1 - ax
    top_lo, top_hi = t["lo"][:2], t["hi"][:2]
    kb = h.draw_size("keyboard")
    mon = h.draw_size("tv") if left["tv"] > 0 else None
    mouse = h.draw_size("mouse") if left["mouse"] > 0 else None
    right = -sg if ax == 0 else sg  # the typist's right along the wall: facing it (+sg along ax), right is (f_y, -f_x)
    span = float(top_hi[o] - top_lo[o]) - 0.04
    side_room = (float(mouse[1]) + 0.06) if mouse is not None else 0.0
    free = span - float(kb[1]) - side_room
    depth = float(kb[0]) + 0.1 + (float(mon[0]) + 0.08 if mon is not None else 0.0)  # the top's depth it needs
    if free < 0 or float(top_hi[ax] - top_lo[ax]) < depth:
        return False
    # the keyboard's centre along the wall: the mouse's room kept on the typist's right
    start = float(top_lo[o]) + 0.02 + (side_room if right < 0 else 0.0)
    c_o = start + float(h.rng.uniform(0, free)) + float(kb[1]) / 2
    front = float(top_hi[ax]) if sg < 0 else float(top_lo[ax])  # the edge away from the wall
    inset = float(h.rng.uniform(0.05, 0.1))

    def put(cls, size, centre_ax, centre_o):
        lo, hi = np.zeros(2), np.zeros(2)
        lo[ax], hi[ax] = centre_ax - size[0] / 2, centre_ax + size[0] / 2
        lo[o], hi[o] = centre_o - size[1] / 2, centre_o + size[1] / 2
        lo, hi = np.round(lo, 6), np.round(hi, 6)
        h.tops[desk].append((lo, hi))
        z = float(t["hi"][2])
        h.add(cls, [lo[0], lo[1], z], [hi[0], hi[1], z + float(size[2])], t["room"], "on")
        left[cls] -= 1

    inward = -sg  # from the wall toward the room
    kb_ax = front - inward * (inset + float(kb[0]) / 2)
    put("keyboard", kb, kb_ax, c_o)
    if mon is not None:  # as wide as the top at most, and on it: behind the keyboard as far as the top allows
        mon[1] = min(float(mon[1]), span)
        back = float(top_lo[ax]) if sg < 0 else float(top_hi[ax])
        m_o = float(np.clip(c_o, float(top_lo[o]) + 0.02 + mon[1] / 2, float(top_hi[o]) - 0.02 - mon[1] / 2))
        put("tv", mon, back + inward * (float(h.rng.uniform(0.02, 0.06)) + float(mon[0]) / 2), m_o)
    if mouse is not None:
        m_ax = front - inward * (inset + float(mouse[0]) / 2 + float(h.rng.uniform(0, 0.03)))
        gap = float(h.rng.uniform(0.04, 0.06))
        put("mouse", mouse, m_ax, c_o + right * (float(kb[1]) / 2 + gap + float(mouse[1]) / 2))
    return True


def _dining(h: _Home, room: int, left: dict, chairs: int) -> None:
    if left["table"] <= 0:
        return
    got = _table(h, room, "dining", False)
    if got is not None:
        left["table"] -= 1
        left["chair"] -= _chairs_around(h, got[0], room, min(chairs, left["chair"]))


def _shares(layout: Layout, left: dict) -> list[dict]:
    """Per room: how many beds (bedrooms), toilets and sinks (bathrooms; the kitchen gets one sink when the
    bathrooms have theirs) it takes, the counts spread evenly, larger rooms first."""
    out = [{} for _ in layout.rooms]
    sinks = left["sink"]
    for cls, kind in (("bed", "bedroom"), ("toilet", "bathroom"), ("sink", "bathroom")):
        idx = sorted((r.index for r in layout.rooms if r.kind == kind),
                     key=lambda i: (-float(np.prod(layout.rooms[i].hi - layout.rooms[i].lo)), i))
        for k in range(left[cls] if cls != "sink" else min(sinks, len(idx))):
            if idx:
                out[idx[k % len(idx)]][cls] = out[idx[k % len(idx)]].get(cls, 0) + 1
        if cls == "sink":
            sinks -= min(sinks, len(idx))
    for r in layout.rooms:
        if r.kind == "kitchen":
            out[r.index]["sink"] = sinks
    return out


def _floor_anywhere(h: _Home, cls: str, rooms: list[int]) -> bool:
    """One ``cls`` floor object in the first of ``rooms`` (a seeded order, at most :data:`ROOM_TRIES`) that takes
    it; a potted plant that no floor takes stands on a table."""
    for room in [rooms[i] for i in h.rng.permutation(len(rooms))[:ROOM_TRIES]]:
        size = table_size(h.rng, "side") if cls == "table" else h.draw_size(cls)
        if cls == "chair":
            tables = [i for i in sorted(h.tops) if h.objects[i]["room"] == room and h.objects[i]["role"] != "stand"]
            if any(_chairs_around(h, t, room, 1) for t in tables[:2]):
                return True
        if cls in ("couch", "bed", "refrigerator", "table", "potted plant"):
            if _wall_object(h, cls, room, size, cls != "bed", "side" if cls == "table" else "") is not None:
                return True
        else:
            box = h.free_box(room, size[:2])
            if box is not None:
                h.floor(cls, room, size, box)
                return True
    return cls == "potted plant" and h.on_table(cls, h.draw_size(cls), sorted(h.tops))


def _workstations(h: _Home, left: dict) -> None:
    """A :func:`_workstation` on each desk while keyboards are left; a home with keyboards and no desk first gets
    one (:func:`_desk`) in a bedroom, else a living room, dining room or hall (of :data:`WORKSTATION_ROOMS`, at most
    :data:`ROOM_TRIES` rooms tried), since generator version 5."""
    desks = [i for i in sorted(h.tops) if h.objects[i]["role"] == "desk"]
    if left["keyboard"] > 0 and not desks:
        rooms = sorted((r.index for r in h.layout.rooms if r.kind in WORKSTATION_ROOMS),
                       key=lambda i: (WORKSTATION_ROOMS.index(h.layout.rooms[i].kind), i))
        for room in rooms[:ROOM_TRIES]:
            if _desk(h, room, left):
                break
        desks = [i for i in sorted(h.tops) if h.objects[i]["role"] == "desk"]
    for desk in desks:
        if left["keyboard"] > 0:
            _workstation(h, desk, left)


def _leftovers(h: _Home, left: dict) -> None:
    """Everything the rooms' anchors did not take: tables (side tables), chairs, persons and potted plants on
    floors of rooms that are no bathrooms (each tried in every such room), then tvs, desk objects and small objects
    on tables (desks, kitchen tables first where they belong; in a seeded order of the objects); what finds no
    place is dropped and noted."""
    _workstations(h, left)
    rooms = [r.index for r in h.layout.rooms if r.kind != "bathroom"] or [r.index for r in h.layout.rooms]
    for cls in ("table", "couch", "bed", "refrigerator", "chair", "person", "potted plant"):
        for _ in range(left[cls]):
            if not _floor_anywhere(h, cls, rooms):
                h.notes.append(f"objects: no place for a {cls}; dropped")
        left[cls] = 0
    for cls in ("toilet", "sink"):
        for _ in range(left[cls]):
            h.notes.append(f"objects: no place for a {cls}; dropped")
        left[cls] = 0
    desks = [i for i in sorted(h.tops) if h.objects[i]["role"] == "desk"]
    kitchen = [i for i in sorted(h.tops) if h.layout.rooms[h.objects[i]["room"]].kind == "kitchen"]
    todo = [c for c in ("tv",) + DESK_CLASSES for _ in range(left[c])]
    small = [c for c in SMALL_CLASSES for _ in range(left[c])]
    todo += [small[i] for i in h.rng.permutation(len(small))]
    for cls in todo:
        size, group = h.draw_object(cls)
        first = desks if cls in DESK_CLASSES else kitchen if cls == "toaster" else []
        if not (first and h.on_table(cls, size, first, group)) and not h.on_table(cls, size, sorted(h.tops), group):
            h.notes.append(f"objects: no place for a {cls}; dropped")
        left[cls] -= 1


def place_home(rng: np.random.Generator, layout: Layout, notes: list[str]) -> _Home:
    """The placement state of a home with ``layout`` after its :func:`quota` is placed by the module's rules
    (``.objects``: see :func:`place_objects`; ``.tops``, ``.spaces``: what more objects need to be placed
    consistently, as :mod:`.variants` does). Dropped objects are appended to ``notes``. Never raises; every loop
    is bounded."""
    left = quota(rng, layout)
    h = _Home(rng, layout, notes)
    shares = _shares(layout, left)
    rank = ["bathroom", "kitchen", "living_room", "bedroom", "office", "dining_room", "hall"]
    for i in sorted(range(len(layout.rooms)), key=lambda i: (rank.index(layout.rooms[i].kind), i)):
        _furnish_room(h, i, layout.rooms[i].kind, left, shares[i])
    _leftovers(h, left)
    return h


def place_objects(rng: np.random.Generator, layout: Layout, notes: list[str]) -> list[dict]:
    """The ground-truth objects of a home with ``layout``: a :func:`quota` placed by the module's rules.

    Returns:
        Objects as dicts ``{"class", "lo": (3,) float64, "hi": (3,) float64, "room": int, "role": str}`` (metres,
        map frame, axis-aligned; ``role`` a table's role or "on" for an object standing on a table), in placing
        order. Dropped objects are appended to ``notes``. Never raises; every loop is bounded.
    """
    return place_home(rng, layout, notes).objects
