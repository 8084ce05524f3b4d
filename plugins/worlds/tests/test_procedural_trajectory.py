"""The procedural homes' free space, visibility and passive trajectories (benchbot_worlds.procedural.free_space,
.visibility, .trajectory) on hand-made layouts and on layouts built from BEAR's derived floor plans."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np
import pytest

from benchbot.core.motion import ControllerGains, PoseControllers, integrate_unicycles
from benchbot_worlds.homes import floorplan as fp
from benchbot_worlds.procedural.free_space import connected, free_space, wall_rects
from benchbot_worlds.procedural.layout import Cut, Door, Layout, RoomBox
from benchbot_worlds.procedural.trajectory import MAX_STEP_M, passive_trajectory, pose7, unseen_objects
from benchbot_worlds.procedural.visibility import poses_to_se2, seen_matrix

DATA = Path(fp.__file__).parents[1] / "data" / "bear"
A = lambda *v: np.array(v, dtype=np.float64)  # noqa: E731


def _obj(cls, c, e, i=0):
    return {"class": cls, "ID_name": f"{cls}_{i}", "centroid": list(map(float, c)), "extent": list(map(float, e)),
            "isgroup": False}


def _one_room():
    layout = Layout(A(0, 0), A(5, 4), [], [RoomBox(0, "living_room", A(0, 0), A(5, 4))], [], 0.12)
    objs = [_obj("sofa", (2.5, 0.5, 0.4), (2.0, 0.9, 0.8)), _obj("table", (2.5, 2.0, 0.375), (1.2, 0.7, 0.75)),
            _obj("cup", (2.3, 2.0, 0.8), (0.1, 0.1, 0.1)), _obj("tv", (2.5, 3.95, 1.2), (1.0, 0.08, 0.6)),
            _obj("plant", (0.25, 3.7, 0.5), (0.4, 0.4, 1.0)), _obj("clock", (4.97, 2.0, 1.9), (0.05, 0.3, 0.3))]
    return layout, objs


def _row():
    rooms = [RoomBox(0, "kitchen", A(0, 0), A(4, 4)), RoomBox(1, "hall", A(4, 0), A(8, 4)),
             RoomBox(2, "bedroom", A(8, 0), A(12, 4))]
    doors = [Door((0, 1), 0, 4.0, 1.5, 2.4), Door((1, 2), 0, 8.0, 2.0, 2.9)]
    layout = Layout(A(0, 0), A(12, 4), [Cut(0, 4, 0, 4), Cut(0, 8, 0, 4)], rooms, doors, 0.12)
    objs = [_obj("table", (1, 1, 0.375), (1.0, 0.8, 0.75)), _obj("cup", (1.1, 1.0, 0.8), (0.1, 0.1, 0.1)),
            _obj("bed", (10.5, 1, 0.3), (1.5, 2, 0.6)), _obj("chair", (6, 3.5, 0.45), (0.5, 0.5, 0.9)),
            _obj("clock", (11.9, 3, 1.8), (0.1, 0.2, 0.2)), _obj("fridge", (0.4, 3.6, 0.9), (0.7, 0.7, 1.8))]
    return layout, objs


def _ell():
    """Four rooms in an L: 0 | 1 | 2 along x, 3 above room 0."""
    rooms = [RoomBox(0, "kitchen", A(0, 0), A(4, 3.5)), RoomBox(1, "dining_room", A(4, 0), A(8, 3.5)),
             RoomBox(2, "living_room", A(8, 0), A(12, 3.5)), RoomBox(3, "bedroom", A(0, 3.5), A(4, 7.5))]
    doors = [Door((0, 1), 0, 4.0, 1.0, 1.9), Door((1, 2), 0, 8.0, 2.0, 3.0), Door((0, 3), 1, 3.5, 2.5, 3.4)]
    cuts = [Cut(1, 3.5, 0, 4), Cut(0, 4, 0, 3.5), Cut(0, 8, 0, 3.5)]
    layout = Layout(A(0, 0), A(12, 7.5), cuts, rooms, doors, 0.12)
    objs = [_obj("counter", (0.35, 1.5, 0.45), (0.6, 2.0, 0.9)), _obj("bowl", (0.35, 1.2, 0.95), (0.2, 0.2, 0.1)),
            _obj("table", (6, 1.7, 0.375), (1.6, 0.9, 0.75)), _obj("chair", (6, 0.9, 0.45), (0.45, 0.45, 0.9)),
            _obj("chair", (6, 2.5, 0.45), (0.45, 0.45, 0.9), 1), _obj("sofa", (10, 3.0, 0.4), (2.0, 0.8, 0.8)),
            _obj("lamp", (11.7, 0.3, 0.8), (0.3, 0.3, 1.6)), _obj("bed", (1.5, 6.5, 0.3), (1.6, 2.0, 0.6)),
            _obj("book", (3.7, 7.3, 0.6), (0.2, 0.15, 0.05))]
    return layout, objs


LAYOUTS = {"one_room": _one_room, "row": _row, "ell": _ell}


def _room_of(layout, xy):
    return [r.index for r in layout.rooms if np.all(xy >= r.lo - 1e-9) and np.all(xy <= r.hi + 1e-9)]


def _check(layout, objs, tr):
    start, poses = tr
    fs = tr.free
    assert tr.unseen == [] and tr.notes == []
    assert unseen_objects(layout, objs, poses) == []
    area = float(np.prod(np.asarray(layout.outer_hi) - np.asarray(layout.outer_lo)))
    assert 1 <= len(poses) <= 4 * area + 20  # a sweep of every room: poses grow with the floor's area
    xy = np.array([start[4:6]] + [p[4:6] for p in poses])
    assert fs.is_free(xy).all()
    for a, b in zip(xy[:-1], xy[1:]):
        assert fs.segment_free(a, b)
        assert np.hypot(*(b - a)) <= MAX_STEP_M + 1e-6
    # the swept disc clears every obstacle (less the grid's documented tolerance)
    t = np.linspace(0, 1, 21)[:, None]
    pts = np.concatenate([a + t * (b - a) for a, b in zip(xy[:-1], xy[1:])])
    assert fs.clearance(pts).min() >= fs.robot_radius_m - 0.83 * fs.cell_m
    visited = {r for p in xy for r in _room_of(layout, p)}
    assert visited == {r.index for r in layout.rooms}
    for p in [start] + poses:
        assert all(round(v, 6) == v for v in p) and len(p) == 7
        assert abs(np.hypot(p[0], p[3]) - 1) < 1e-5 and p[1] == p[2] == 0


@pytest.mark.parametrize("name", sorted(LAYOUTS))
def test_trajectory_visits_every_room_and_sees_every_object(name):
    layout, objs = LAYOUTS[name]()
    assert connected(free_space(layout, objs))
    for seed in (0, 1, 2):
        _check(layout, objs, passive_trajectory(layout, objs, seed))


def test_same_seed_same_trajectory_other_seeds_differ():
    layout, objs = _ell()
    a, b = passive_trajectory(layout, objs, 7), passive_trajectory(layout, objs, 7)
    assert a == b and a.notes == b.notes
    assert len({json.dumps(passive_trajectory(layout, objs, s)) for s in range(6)}) > 1


def test_moves_are_turns_or_straight_drives_the_controller_follows():
    """Each move is a turn on the spot or a drive along the current heading; the pose controller
    (benchbot.core.motion), run move by move from the start pose, stays in free space."""
    layout, objs = _row()
    tr = passive_trajectory(layout, objs, 3)
    start, poses = tr
    se2 = poses_to_se2([start] + poses)
    for a, b in zip(se2[:-1], se2[1:]):
        moved = np.hypot(*(b[:2] - a[:2]))
        turned = abs((b[2] - a[2] + math.pi) % (2 * math.pi) - math.pi)
        heading = math.atan2(b[1] - a[1], b[0] - a[0])
        assert moved < 1e-6 or (turned < 1e-4 and abs(math.sin(heading - a[2])) < 1e-4 and math.cos(heading - a[2]) > 0)
    gains = ControllerGains()
    pose = se2[:1].copy()
    for goal in se2[1:]:
        ctl = PoseControllers(goal[None], gains)
        for _ in range(4000):
            if not ctl.command(pose)[0]:
                break
            pose = integrate_unicycles(pose, ctl.v, ctl.w, 1.0 / gains.rate_hz)
            assert tr.free.clearance(pose[:, :2])[0] >= tr.free.robot_radius_m - 0.05
        assert np.hypot(*(pose[0, :2] - goal[:2])) < 0.1


def test_an_object_behind_a_wall_is_not_seen_from_the_next_room():
    layout, _ = _row()
    hidden = [_obj("box", (2.0, 2.0, 1.0), (0.3, 0.3, 0.3))]
    through_wall = [pose7(6.0, 3.5, math.pi)]  # in room 1, facing room 0 across the wall x = 4 (no door at y 3.5)
    assert unseen_objects(layout, hidden, through_wall) == [0]
    assert unseen_objects(layout, [_obj("box", (2.0, 3.5, 1.0), (0.3, 0.3, 0.3))], through_wall) == [0]
    # the same line of sight through the doorway (y 1.5..2.4) sees it; so does a pose in its own room
    assert unseen_objects(layout, hidden, [pose7(6.0, 2.0, math.pi)]) == []
    assert unseen_objects(layout, hidden, [pose7(3.5, 2.0, math.pi)]) == []
    # outside the field of view, too close below the camera, or beyond range: not seen
    assert unseen_objects(layout, hidden, [pose7(3.5, 2.0, 0.0)]) == [0]
    assert unseen_objects(layout, [_obj("mat", (2.0, 2.0, 0.01), (0.2, 0.2, 0.02))], [pose7(1.5, 2.0, 0.0)]) == [0]
    far = Layout(A(0, 0), A(20, 4), [], [RoomBox(0, "hall", A(0, 0), A(20, 4))], [], 0.12)
    assert unseen_objects(far, hidden, [pose7(11.0, 2.0, math.pi)]) == [0]
    assert seen_matrix(far, hidden, [pose7(9.0, 2.0, math.pi)]).tolist() == [[True]]


def test_a_blocked_doorway_disconnects_and_is_reported():
    layout, objs = _row()
    cabinet = _obj("cabinet", (8.0, 2.45, 0.9), (0.6, 1.2, 1.8))
    fs = free_space(layout, objs + [cabinet])
    assert not connected(fs)
    tr = passive_trajectory(layout, objs + [cabinet], 0)
    assert any("not reachable" in n for n in tr.notes)
    # a shelf high on the wall (bottom above the robot) does not block the door
    assert connected(free_space(layout, objs + [_obj("shelf", (8.0, 2.45, 2.0), (0.3, 1.2, 0.4))]))
    # a doorway narrower than the robot does not connect
    narrow = Layout(layout.outer_lo, layout.outer_hi, layout.cuts, layout.rooms,
                    [layout.doors[0], Door((1, 2), 0, 8.0, 2.0, 2.6)], 0.12)
    assert not connected(free_space(narrow, objs))


def test_wall_rects_cut_the_doorways():
    layout, _ = _row()
    lo, hi = wall_rects(layout)
    door = layout.doors[0]
    inside = (lo[:, 0] < 4.0) & (hi[:, 0] > 4.0) & (lo[:, 1] < 2.0) & (hi[:, 1] > 2.0)
    assert not inside.any() and door.centre.tolist() == [4.0, 1.95]
    assert ((lo[:, 0] < 4.0) & (hi[:, 0] > 4.0) & (lo[:, 1] < 3.0) & (hi[:, 1] > 3.0)).any()


def _grid_home(seed=0, nx=4, ny=3, w=4.0, h=3.5):
    """A 12-room home of nx × ny rooms with a door to each neighbour on a spanning tree plus a few, and about 80
    objects (furniture along the walls, small objects on tables)."""
    rng = np.random.default_rng(seed)
    rooms, doors, objs = [], [], []
    for j in range(ny):
        for i in range(nx):
            rooms.append(RoomBox(len(rooms), "office", A(i * w, j * h), A((i + 1) * w, (j + 1) * h)))
    for j in range(ny):
        for i in range(nx):
            k = j * nx + i
            if i + 1 < nx:
                doors.append(Door((k, k + 1), 0, (i + 1) * w, j * h + 1.0, j * h + 1.95))
            if j + 1 < ny and (i == 0 or rng.random() < 0.5):
                doors.append(Door((k, k + nx), 1, (j + 1) * h, i * w + 2.2, i * w + 3.1))
    for r in rooms:
        c = (r.lo + r.hi) / 2
        objs += [_obj("table", (c[0], c[1], 0.375), (1.0, 0.7, 0.75), r.index),
                 _obj("cup", (c[0] + 0.2, c[1], 0.8), (0.1, 0.1, 0.1), r.index),
                 _obj("book", (c[0] - 0.2, c[1] + 0.1, 0.77), (0.2, 0.15, 0.04), r.index),
                 _obj("cabinet", (r.lo[0] + 0.35, r.hi[1] - 0.6, 0.5), (0.5, 0.8, 1.0), r.index),
                 _obj("vase", (r.lo[0] + 0.35, r.hi[1] - 0.6, 1.1), (0.15, 0.15, 0.2), r.index),
                 _obj("plant", (r.hi[0] - 0.35, r.lo[1] + 0.35, 0.5), (0.4, 0.4, 1.0), r.index),
                 _obj("picture", (r.hi[0] - 0.08, (r.lo[1] + r.hi[1]) / 2 + 0.5, 1.6), (0.04, 0.6, 0.4), r.index)]
    layout = Layout(A(0, 0), A(nx * w, ny * h), [], rooms, doors, 0.12)
    return layout, objs


def test_twelve_room_home_is_planned_fast():
    layout, objs = _grid_home()
    assert len(layout.rooms) == 12 and len(objs) == 84
    passive_trajectory(layout, objs, 0)  # warm up (imports, caches)
    t = time.perf_counter()
    tr = passive_trajectory(layout, objs, 1)
    seconds = time.perf_counter() - t
    print(f"12 rooms, {len(objs)} objects: {len(tr[1])} poses in {seconds:.3f} s")
    _check(layout, objs, tr)
    assert seconds < 1.5


def _layout_from_plan(plan):
    """A Layout of a BEAR home's derived floor plan: room boxes grown to the wall centre lines, its doorways."""
    t = plan.wall_thickness
    rooms = []
    for r in plan.rooms:
        lo, hi = r.lo.copy(), r.hi.copy()
        lo[lo > plan.outer_lo + 1e-6] -= t / 2
        hi[hi < plan.outer_hi - 1e-6] += t / 2
        rooms.append(RoomBox(r.index, "hall", lo, hi))
    doors = []
    for o in plan.openings:
        if o.kind == "door" and min(o.rooms) >= 0:
            ax = int(np.argmax(np.abs(o.outward)))
            doors.append(Door(tuple(o.rooms), ax, float(o.lo[ax] + o.hi[ax]) / 2, float(o.lo[1 - ax]),
                              float(o.hi[1 - ax])))
    return Layout(plan.outer_lo, plan.outer_hi, [], rooms, doors, t)


@pytest.mark.parametrize("name", ["miniroom_1", "house_1"])
def test_bear_trajectories_seen_objects(name):
    """BEAR's own hand-made trajectory, judged by unseen_objects with the derived plan's real walls (and with the
    Layout's walls), and a procedural trajectory for the same home."""
    data = json.loads((DATA / f"{name}.json").read_text())
    plan = fp.plan_for_home([data])
    objs, poses = data["ground_truth"]["objects"], data["environment"]["trajectory_poses"]
    layout = _layout_from_plan(plan)
    walls = (np.array([w.lo[:2] for w in plan.walls]), np.array([w.hi[:2] for w in plan.walls]))
    own = unseen_objects(layout, objs, poses, walls=walls)
    print(f"{name}: BEAR's trajectory ({len(poses)} poses) leaves {len(own)}/{len(objs)} objects unseen "
          f"({', '.join(objs[i]['class'] for i in own)}); with the Layout's walls "
          f"{len(unseen_objects(layout, objs, poses))}")
    assert len(own) <= max(1, len(objs) // 10)
    tr = passive_trajectory(layout, objs, 0)
    print(f"{name}: procedural trajectory {len(tr[1])} poses, unseen {tr.unseen}, notes {tr.notes}")
    assert tr.unseen == [] or all("not reachable" in n or "seen" in n for n in tr.notes)


def test_an_empty_room_gets_a_look_all_around_and_an_invisible_object_a_note():
    layout, _ = _one_room()
    start, poses = passive_trajectory(layout, [], 5)
    se2 = poses_to_se2([start] + poses)
    k = int(np.argmin(np.all(np.abs(se2[:, :2] - se2[0, :2]) < 1e-9, axis=1)))  # the first pose elsewhere
    yaws = np.sort(se2[:5, 2] % (2 * math.pi))  # the start and four turns: a look all around; then the way on
    assert k >= 5 and np.diff(np.append(yaws, yaws[0] + 2 * math.pi)).max() <= math.pi / 2 + 1e-4
    assert len(poses) > 4  # then a sweep of the room's floor
    layout, objs = _row()
    in_the_wall = _obj("speck", (4.0, 3.5, 1.0), (0.05, 0.05, 0.05))  # inside the wall x = 4, beside no door
    tr = passive_trajectory(layout, objs + [in_the_wall], 0)
    assert tr.unseen == [len(objs)] and any("speck" in n for n in tr.notes)
    assert unseen_objects(layout, objs + [in_the_wall], tr[1]) == [len(objs)]
