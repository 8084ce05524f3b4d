"""A procedural home's passive trajectory: a start pose and poses that visit every room through the doors' centres
and turn to look at the objects, so that every ground-truth object is seen (:mod:`.visibility`) from at least one
pose (NumPy; metres, radians, ``map`` frame, z up).

Poses are BenchBot's 7-number ``[qw, qx, qy, qz, x, y, z]`` (a yaw-only quaternion, z = :data:`ROBOT_Z_M`). The
motion between consecutive poses is either a turn on the spot or a straight drive along the robot's heading (the
pose controller then drives straight: its goal lies dead ahead with the same yaw), at most :data:`MAX_STEP_M` long,
every point of it in free space (:meth:`~.free_space.FreeSpace.segment_free`).

How: viewpoints on a grid of reachable free cells in each room are chosen greedily (a seeded tie-break) until every
object of the room is seen from one, each looked at from there (turns that cover the objects' bearings); then the
room is swept: one more stop per :data:`COVER_SPACING_M` square of its reachable floor (smaller squares in a home of
little reachable floor, :data:`COVER_MIN_STOPS`; farther than half a square from the other stops), looking at the nearest objects (:data:`COVER_NEAR_M`, :data:`COVER_LOOKS`), so that the
poses grow with the floor's area as BEAR's hand-made ones do (procedural homes under 40 m²: about 65 poses; 90-120
m²: about 240; BEAR's miniroom 33-56, house 237-286). A room's stops are visited nearest first, from the first of
which the robot looks all around; the rooms are toured in a seeded depth-first order of the door graph; paths
between stops are straight when every step of the drive, as rounded, is free, else shortest grid paths with
corners cut. Objects that no reachable pose sees are listed in the result's ``unseen`` and
``notes``, never looped on.
"""

from __future__ import annotations

import math

import numpy as np

from .free_space import FreeSpace, free_space, grid_path, main_component, rects_near, room_cells, shortcut, wall_rects
from .layout import Layout
from .visibility import CARTER_CAMERA, ROBOT_Z_M, Camera, poses_to_se2, sample_points, seen_pairs, unseen_objects

__all__ = ["PassiveTrajectory", "passive_trajectory", "unseen_objects", "MAX_STEP_M", "VIEWPOINT_SPACING_M"]

#: Longest straight drive between two poses, metres (BEAR's hand-made poses are 0.3–1 m apart).
MAX_STEP_M = 1.0
#: Spacing of the candidate viewpoints in a room, metres.
VIEWPOINT_SPACING_M = 0.3
#: Width of the arc of bearings one look covers, degrees (the 90° field of view less a margin).
LOOK_ARC_DEG = 70.0
#: At the first viewpoint of each room the robot looks all around, turning at most this much at a time (degrees).
LOOK_AROUND_DEG = 90.0
#: The robot also sweeps each room: one stop per square of this side (m) of the room's reachable floor (at the
#: reachable cell nearest the square's reachable middle; squares laid from the room's low corner), so that the
#: poses grow with the floor's area as BEAR's hand-made ones do (miniroom ~30 m²: 33-56 poses; house ~100 m²:
#: 237-286).
COVER_SPACING_M = 1.5
#: A home with little reachable floor gets smaller squares: about :data:`COVER_MIN_STOPS` of them over the home, at
#: least :data:`COVER_MIN_SIDE_M` a side (a cluttered studio is still swept).
COVER_MIN_STOPS = 5
COVER_MIN_SIDE_M = 0.6
#: At a sweep stop the robot looks at the room's objects within this distance (m), at most :data:`COVER_LOOKS` of
#: them, nearest first.
COVER_NEAR_M = 2.5
COVER_LOOKS = 2
#: How far beyond the wall's face the robot stops before and after a doorway, metres (plus its radius).
DOOR_CLEAR_M = 0.1


class PassiveTrajectory(tuple):
    """``(start_pose, trajectory_poses)`` — a 7-list and a list of 7-lists — with attributes ``unseen`` (indices
    of the objects seen from no trajectory pose, ascending), ``notes`` (list[str], why) and ``free`` (the
    :class:`~.free_space.FreeSpace` it was planned in)."""

    def __new__(cls, start: list[float], poses: list[list[float]], unseen: list[int], notes: list[str],
                free: FreeSpace):
        self = super().__new__(cls, (start, poses))
        self.unseen, self.notes, self.free = unseen, notes, free
        return self


def pose7(x: float, y: float, yaw: float) -> list[float]:
    """``[qw, 0, 0, qz, x, y, ROBOT_Z_M]`` of a yaw (rad), rounded to 1e-6."""
    return [round(v, 6) + 0.0 for v in (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2), x, y, ROBOT_Z_M)]


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def _room_of(layout: Layout, xy: np.ndarray) -> int:
    """The room whose box holds ``xy`` (the first), else the nearest room box."""
    d = [float(np.hypot(*np.maximum(np.maximum(np.asarray(r.lo) - xy, xy - np.asarray(r.hi)), 0.0)))
         for r in layout.rooms]
    return int(np.argmin(d))


def _candidates(fs: FreeSpace, mask: np.ndarray, room: int) -> np.ndarray:
    """(C, 2) xy of the reachable free cells of a room on a :data:`VIEWPOINT_SPACING_M` lattice (all of its
    reachable cells, thinned, when the lattice misses them)."""
    w = room_cells(fs, room)
    ij = np.argwhere(mask[w]) + np.array([w[0].start, w[1].start])
    k = max(1, int(round(VIEWPOINT_SPACING_M / fs.cell_m)))
    on = ij[(ij[:, 0] % k == 0) & (ij[:, 1] % k == 0)]
    if not len(on):
        on = ij[::max(1, len(ij) // 16)]
    return fs.centres(on)


def _cover_points(fs: FreeSpace, mask: np.ndarray, room: int, side: float) -> np.ndarray:
    """(S, 2) xy of a room's sweep stops: per square of ``side`` (m) of its reachable cells, the reachable cell
    nearest the mean of the square's reachable cells; squares in x-major order."""
    w = room_cells(fs, room)
    ij = np.argwhere(mask[w])
    if not len(ij):
        return np.zeros((0, 2))
    k = max(1, int(round(side / fs.cell_m)))
    sq = ij // k
    keys, inv = np.unique(sq, axis=0, return_inverse=True)
    out = []
    for q in range(len(keys)):
        cells = ij[inv.ravel() == q]
        mid = cells.mean(axis=0)
        out.append(cells[int(np.argmin(((cells - mid) ** 2).sum(axis=1)))])
    return fs.centres(np.array(out) + np.array([w[0].start, w[1].start]))


def _add_sweep(views, fs: FreeSpace, mask: np.ndarray, points: np.ndarray, home: np.ndarray) -> None:
    """Append each room's sweep stops (:func:`_cover_points`; squares of :data:`COVER_SPACING_M`, smaller in a home
    of little reachable floor: :data:`COVER_MIN_STOPS`) farther than half a square from its viewpoints to
    ``views`` (per room, [(xy, objects to look at)]), each looking at its nearest objects (:data:`COVER_NEAR_M`,
    :data:`COVER_LOOKS`)."""
    side = min(COVER_SPACING_M, max(COVER_MIN_SIDE_M, math.sqrt(mask.sum() * fs.cell_m ** 2 / COVER_MIN_STOPS)))
    side = max(1, int(round(side / fs.cell_m))) * fs.cell_m
    for r in range(len(views)):
        have = [v[0] for v in views[r]]
        objs = np.nonzero(home == r)[0]
        for p in _cover_points(fs, mask, r, side):
            if have and min(float(np.hypot(*(p - q))) for q in have) < side / 2:
                continue
            d = np.hypot(*(points[objs, 0, :2] - p).T) if len(objs) else np.zeros(0)
            near = [int(objs[i]) for i in np.argsort(d, kind="stable")[:COVER_LOOKS] if d[i] <= COVER_NEAR_M]
            views[r].append((p, near))
            have.append(p)


def _greedy(cov: np.ndarray, rng: np.random.Generator) -> list[tuple[int, np.ndarray]]:
    """Greedy set cover of the columns of ``cov`` (C, N) bool by rows: [(row, the columns it newly covers)], the
    row covering most first (ties broken by ``rng``); stops when no row covers another column."""
    left = np.ones(cov.shape[1], dtype=bool)
    out = []
    for _ in range(cov.shape[1]):
        gain = cov[:, left].sum(axis=1)
        if not len(gain) or gain.max() == 0:
            break
        c = int(np.argmax(gain + 0.5 * rng.random(len(gain))))
        new = np.nonzero(cov[c] & left)[0]
        left[new] = False
        out.append((c, new))
    return out


def _coverage(cands: np.ndarray, objs: np.ndarray, points: np.ndarray, walls, camera: Camera) -> np.ndarray:
    """(C, len(objs)) bool: an object is seen from candidate position c when the robot there faces its centroid."""
    pts = points[objs].reshape(-1, 3)[:, :2]
    walls = rects_near(*walls, np.minimum(cands.min(axis=0), pts.min(axis=0)),
                       np.maximum(cands.max(axis=0), pts.max(axis=0)))
    cc, oo = np.meshgrid(np.arange(len(cands)), objs, indexing="ij")
    cc, oo = cc.ravel(), oo.ravel()
    d = points[oo, 0, :2] - cands[cc]
    se2 = np.concatenate([cands[cc], np.arctan2(d[:, 1], d[:, 0])[:, None]], axis=1)
    return seen_pairs(se2, oo, points, walls, camera).reshape(len(cands), len(objs))


def _viewpoints(layout, fs, mask, points, walls, camera, rng, notes) -> list[list[tuple[np.ndarray, list[int]]]]:
    """Per room, the chosen viewpoints: [(xy (2,), the objects looked at from there)]; objects no candidate sees
    go to ``notes``."""
    rooms = len(layout.rooms)
    home = np.array([_room_of(layout, p[0, :2]) for p in points], dtype=np.int64)
    cands = [_candidates(fs, mask, r) for r in range(rooms)]
    views: list[list] = [[] for _ in range(rooms)]
    left = []
    for r in range(rooms):
        objs = np.nonzero(home == r)[0]
        if not len(objs):
            continue
        cov = _coverage(cands[r], objs, points, walls, camera) if len(cands[r]) else np.zeros((0, len(objs)), bool)
        picks = _greedy(cov, rng)
        views[r] += [(cands[r][c], objs[new].tolist()) for c, new in picks]
        done = np.zeros(len(objs), dtype=bool)
        for _, new in picks:
            done[new] = True
        left += objs[~done].tolist()
    for r in range(rooms):  # a room without objects: a look around from its most central reachable point
        if not views[r] and len(cands[r]):
            centre = (fs.room_lo[r] + fs.room_hi[r]) / 2
            views[r].append((cands[r][int(np.argmin(np.hypot(*(cands[r] - centre).T)))], []))
    if left:  # seen from no candidate of their own room: from another room's
        every = np.concatenate(cands)
        owner = np.concatenate([np.full(len(c), r) for r, c in enumerate(cands)]).astype(np.int64)
        objs = np.array(left, dtype=np.int64)
        picks = _greedy(_coverage(every, objs, points, walls, camera), rng) if len(every) else []
        for c, new in picks:
            views[int(owner[c])].append((every[c], objs[new].tolist()))
        got = {int(o) for _, new in picks for o in objs[new]}
        notes += [f"object {o} is seen from no reachable viewpoint" for o in left if o not in got]
    return views


def _look_yaws(bearings: list[float]) -> list[float]:
    """Yaws (rad) whose arcs of :data:`LOOK_ARC_DEG` cover every bearing (fewest arcs; each centred on the bearings
    it covers)."""
    b = sorted(v % (2 * math.pi) for v in bearings)
    arc = math.radians(LOOK_ARC_DEG)
    best = None
    for s in range(len(b)):
        ring = b[s:] + [v + 2 * math.pi for v in b[:s]]
        yaws, i = [], 0
        while i < len(ring):
            j = i
            while j + 1 < len(ring) and ring[j + 1] - ring[i] <= arc:
                j += 1
            yaws.append(_wrap((ring[i] + ring[j]) / 2))
            i = j + 1
        if best is None or len(yaws) < len(best):
            best = yaws
    return best or []


class _Driver:
    """Appends poses: turns on the spot and straight drives of at most :data:`MAX_STEP_M`; ``xy``/``yaw`` are the
    last pose's (as rounded)."""

    def __init__(self, fs: FreeSpace, xy: np.ndarray, yaw: float) -> None:
        self.fs, self.poses = fs, []
        self.start = pose7(float(xy[0]), float(xy[1]), yaw)
        self.xy, self.yaw = np.array(self.start[4:6]), yaw

    def turn(self, yaw: float) -> None:
        if abs(_wrap(yaw - self.yaw)) > 1e-4:
            self.poses.append(pose7(float(self.xy[0]), float(self.xy[1]), yaw))
            self.yaw = yaw

    def steps(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(n, 2) xy of the poses a straight drive from ``a`` to ``b`` adds (steps of at most :data:`MAX_STEP_M`,
        rounded as :func:`pose7` rounds them); (0, 2) when ``b`` is ``a``."""
        d = np.asarray(b, dtype=np.float64) - a
        length = float(np.hypot(*d))
        if length < 1e-6:
            return np.zeros((0, 2))
        n = int(math.ceil(length / MAX_STEP_M - 1e-9))
        return np.round(a + d * (np.arange(1, n + 1)[:, None] / n), 6) + 0.0

    def drivable(self, a: np.ndarray, b: np.ndarray) -> bool:
        """Whether every step of the straight drive ``a``→``b`` (:meth:`steps`, as rounded) is free
        (:meth:`~.free_space.FreeSpace.segment_free`)."""
        pts = np.concatenate([np.asarray(a, dtype=np.float64)[None, :2], self.steps(a, b)])
        return all(self.fs.segment_free(p, q) for p, q in zip(pts[:-1], pts[1:]))

    def straight(self, b: np.ndarray) -> None:
        d = np.asarray(b, dtype=np.float64) - self.xy
        pts = self.steps(self.xy, b)
        if not len(pts):
            return
        heading = math.atan2(d[1], d[0])
        self.turn(heading)
        for p in pts:
            self.poses.append(pose7(float(p[0]), float(p[1]), heading))
        self.xy = np.array(self.poses[-1][4:6])

    def go(self, b: np.ndarray, window=None) -> bool:
        """Drive to ``b``: straight when free, else along a grid path (``window`` first, then the whole grid) with
        its corners cut. False (no pose added) when no free path reaches it."""
        b = np.asarray(b, dtype=np.float64)
        if self.drivable(self.xy, b):
            path = np.array([self.xy, b])
        else:
            path = grid_path(self.fs, self.xy, b, window) if window is not None else None
            path = grid_path(self.fs, self.xy, b) if path is None else path
            if path is None:
                return False
            # judged at the positions the poses will hold (rounded as pose7 rounds them): a cell centre's last bit
            # can move a sample point across a cell's edge (generator version 5)
            path = shortcut(np.round(path, 6) + 0.0, self.drivable)  # the next point: a neighbouring free cell
        for p in path[1:]:
            self.straight(p)
        return True


def _door_route(layout: Layout, a: int, b: int, ok: list[bool]) -> list[tuple[int, int, int]]:
    """The doors (door index, from room, to room) of a fewest-doors route from room ``a`` to ``b`` through rooms
    that ``ok`` allows (breadth first, doors in index order); [] when none."""
    pred = {a: None}
    queue = [a]
    for r in queue:  # grows while iterating: a bounded BFS (each room enters once)
        for k, d in enumerate(layout.doors):
            if r in d.rooms:
                n = d.rooms[1] if d.rooms[0] == r else d.rooms[0]
                if ok[n] and n not in pred:
                    pred[n] = (k, r)
                    queue.append(n)
    if b not in pred:
        return []
    route, r = [], b
    while pred[r] is not None:
        k, p = pred[r]
        route.append((k, p, r))
        r = p
    return route[::-1]


def _cross(drv: _Driver, layout: Layout, door: int, frm: int, to: int) -> bool:
    """Drive through a door: to a point ahead of it in ``frm``, straight through its centre into ``to`` (through
    another point of a wide opening when furniture blocks the centre). False (no pose added) when no way is free."""
    fs, d = drv.fs, layout.doors[door]
    c, ax = d.centre, d.axis
    sign = 1.0 if fs.room_lo[to][ax] >= d.pos - 1e-6 else -1.0
    half = max(0.0, d.width / 2 - fs.robot_radius_m)  # a wide opening: other crossings when its centre is blocked
    along = [0.0] + [v for k in range(1, 9) for v in (k * half / 8, -k * half / 8)] if half > 0.05 else [0.0]
    for shift in along:
        for extra in (0.0, 0.2, 0.4, 0.8):
            s = layout.wall_thickness / 2 + fs.robot_radius_m + DOOR_CLEAR_M + extra
            pa, pb = c.copy(), c.copy()
            pa[1 - ax] += shift
            pb[1 - ax] += shift
            pa[ax] -= sign * s
            pb[ax] += sign * s
            if fs.is_free(np.array([pa, pb])).all() and drv.drivable(pa, pb) and drv.go(pa, room_cells(fs, frm)) \
                    and drv.drivable(drv.xy, pb):
                drv.straight(pb)
                return True
    return False


def _visit(drv: _Driver, views, points, walls, camera: Camera, room: int, notes: list[str]) -> set[int]:
    """Drive to a room's viewpoints (nearest first) and look at their objects from each (all around from the first:
    :func:`_around`); returns the objects seen
    (each checked from the poses added, as :func:`~.visibility.unseen_objects` would)."""
    todo, seen = list(range(len(views))), set()
    first = min(todo, key=lambda i: (float(np.hypot(*(views[i][0] - drv.xy))), i)) if todo else -1
    while todo:
        k = min(todo, key=lambda i: (float(np.hypot(*(views[i][0] - drv.xy))), i))
        todo.remove(k)
        xy, objs = views[k]
        if not drv.go(xy, room_cells(drv.fs, room)):
            notes.append(f"room {room}: no free path to the viewpoint at {np.round(xy, 3).tolist()}")
            continue
        bearing = {o: math.atan2(points[o, 0, 1] - drv.xy[1], points[o, 0, 0] - drv.xy[0]) for o in objs}
        yaws = _look_yaws(list(bearing.values()))
        yaws = sorted(_around(yaws, drv.yaw) if k == first else yaws, key=lambda y: (y - drv.yaw - 1e-6) % (2 * math.pi))
        got = _seen_from(drv.xy, yaws, objs, points, walls, camera)
        missed = [o for o in objs if o not in got]
        got |= _seen_from(drv.xy, [bearing[o] for o in missed], missed, points, walls, camera)
        for y in yaws + [bearing[o] for o in missed]:
            drv.turn(y)
        seen |= got
    return seen


def _around(yaws: list[float], current: float) -> list[float]:
    """``yaws`` (rad) with yaws added so that, with ``current``, no two neighbours on the circle are more than
    :data:`LOOK_AROUND_DEG` apart (a look all around the room)."""
    ring = sorted({round(y % (2 * math.pi), 9) for y in yaws + [current]})
    step, out = math.radians(LOOK_AROUND_DEG), list(yaws)
    for a, b in zip(ring, ring[1:] + [ring[0] + 2 * math.pi]):
        n = int(math.ceil((b - a) / step - 1e-9))
        out += [_wrap(a + (b - a) * i / n) for i in range(1, n)]
    if len(ring) == 1:
        out.append(_wrap(current))  # a full turn: back to where it looked first
    return out


def _seen_from(xy: np.ndarray, yaws: list[float], objs: list[int], points, walls, camera: Camera) -> set[int]:
    """The objects of ``objs`` seen from the poses (``xy``, each of ``yaws``) as :func:`pose7` rounds them."""
    if not yaws or not objs:
        return set()
    se2 = poses_to_se2([pose7(float(xy[0]), float(xy[1]), y) for y in yaws for _ in objs])
    which = np.array([o for _ in yaws for o in objs], dtype=np.int64)
    return {int(o) for o in which[seen_pairs(se2, which, points, walls, camera)]}


def _room_order(layout: Layout, ok: list[bool], start: int, rng: np.random.Generator) -> list[int]:
    """The rooms ``ok`` allows, in a depth-first order of the door graph from ``start`` (neighbours shuffled by
    ``rng``); rooms the doors do not reach from ``start`` come last, in index order."""
    adj = [sorted({d.rooms[1 - d.rooms.index(r)] for d in layout.doors if r in d.rooms}) for r in
           range(len(layout.rooms))]
    order, stack, done = [], [start], [False] * len(layout.rooms)
    while stack:
        r = stack.pop()
        if done[r]:
            continue
        done[r] = True
        order.append(r)
        nbrs = [n for n in adj[r] if ok[n] and not done[n]]
        stack += [nbrs[i] for i in rng.permutation(len(nbrs))]
    return order + [r for r in range(len(layout.rooms)) if ok[r] and not done[r]]


def passive_trajectory(layout: Layout, objects: list[dict], seed: int, *, robot_radius_m: float = 0.35,
                       camera: Camera = CARTER_CAMERA, cell_m: float = 0.05) -> PassiveTrajectory:
    """A passive trajectory of a procedural home that sees every object (as :mod:`.visibility` defines it).

    Args:
        layout: the home's rooms and doors.
        objects: ground-truth dicts (``centroid``, ``extent``, metres, map frame); objects whose bottom is below
            :data:`~.free_space.OBSTRUCT_BELOW_M` obstruct the robot.
        seed: the seed of the NumPy PCG64 generator that picks the start room, the room order, the start yaw and
            the ties between viewpoints; equal inputs give equal trajectories.
        robot_radius_m: the footprint radius (m) the free space is made for.
        camera: the robot's camera (:class:`~.visibility.Camera`).
        cell_m: the free-space grid's cell (m).

    Returns:
        :class:`PassiveTrajectory`: ``(start_pose, trajectory_poses)``, 7-number poses ``[qw, 0, 0, qz, x, y,
        z]`` rounded to 1e-6 (z = :data:`~.visibility.ROBOT_Z_M`), the start pose in a room, then poses from it
        (tens to a few hundred); ``.unseen`` the objects seen from no trajectory pose and ``.notes`` why (rooms
        the robot cannot reach, viewpoints no path reaches), both empty when every object is seen.

    Raises:
        ValueError: no room has free floor for the robot, or an object lacks centroid/extent.
    """
    rng = np.random.Generator(np.random.PCG64(seed))
    fs = free_space(layout, objects, robot_radius_m, cell_m)
    mask, reach = main_component(fs)
    rooms = [r for r in range(len(layout.rooms)) if reach[r]]
    if not rooms:
        raise ValueError("passive_trajectory: no room has free floor for the robot")
    notes = [f"room {r} is not reachable" for r in range(len(layout.rooms)) if not reach[r]]
    walls, points = wall_rects(layout), sample_points(objects)
    views = _viewpoints(layout, fs, mask, points, walls, camera, rng, notes)
    _add_sweep(views, fs, mask, points, np.array([_room_of(layout, p[0, :2]) for p in points], dtype=np.int64))
    here = rooms[int(rng.integers(len(rooms)))]
    order = _room_order(layout, reach, here, rng)
    first = views[here][0][0] if views[here] else _candidates(fs, mask, here)[0]
    drv, seen = _Driver(fs, first, float(rng.uniform(-math.pi, math.pi))), set()
    for room in order:
        for door, a, b in _door_route(layout, here, room, reach):
            if not _cross(drv, layout, door, a, b):
                notes.append(f"door {door} (rooms {a}, {b}): no free way through")
                break
            here = b
        if here != room:
            notes.append(f"room {room}: not entered")
            continue
        seen |= _visit(drv, views[room], points, walls, camera, room, notes)
    if not drv.poses:  # nothing to look at: look around the start
        for _ in range(4):
            drv.turn(_wrap(drv.yaw + math.pi / 2))
    unseen = [o for o in range(len(objects)) if o not in seen]
    notes += [f"object {o} ({objects[o].get('class')}) is not seen" for o in unseen]
    return PassiveTrajectory(drv.start, drv.poses, unseen, notes, fs)
