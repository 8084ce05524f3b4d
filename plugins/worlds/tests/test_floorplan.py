"""Floor plans derived from the BEAR ground truth and robot paths (benchbot_worlds.homes.floorplan): walls clear of
every cuboid and of the swept paths except through doorways, every room reachable, windows only outside, lamps in
every room, seeded determinism; synthetic homes for doorways, passages and windows."""

from __future__ import annotations

import json
import os
from collections import deque
from pathlib import Path

import numpy as np
import pytest

from benchbot.core.errors import BackendError
from benchbot_worlds.homes import floorplan as fp

DATA = Path(fp.__file__).parents[1] / "data" / "bear"
RADIUS = 0.35


def _home(name):
    dicts = [json.loads((DATA / f"{name}_{v}.json").read_text()) for v in range(1, 6)]
    objects, paths = fp.home_inputs(dicts)
    return objects, paths


@pytest.fixture(scope="module")
def homes():
    out = {}
    for name in ("house", "miniroom"):
        objects, paths = _home(name)
        out[name] = (objects, paths, fp.derive_floor_plan(objects, paths, seed=0, robot_radius_m=RADIUS))
    return out


def _cuboids(objects):
    c = np.array([o["centroid"] for o in objects], dtype=float)
    e = np.array([o["extent"] for o in objects], dtype=float)
    return c - e / 2, c + e / 2


def _reachable(plan, start_room):
    adj = {r.index: set() for r in plan.rooms}
    for op in plan.openings:
        if op.kind == "door":
            a, b = op.rooms
            adj[a].add(b)
            adj[b].add(a)
    seen, todo = {start_room}, deque([start_room])
    while todo:
        for n in adj[todo.popleft()]:
            if n not in seen:
                seen.add(n)
                todo.append(n)
    return seen


def _check_plan(plan, objects, paths, radius=RADIUS):
    """Every guarantee of a plan, checked independently of how it was built."""
    lo, hi = _cuboids(objects) if objects else (np.zeros((0, 3)), np.zeros((0, 3)))
    # no wall box intersects a ground-truth cuboid (xy with a small margin, and z)
    for w in plan.walls:
        assert np.all(w.hi > w.lo), w
        inter = np.all(lo[:, :2] < w.hi[:2] + 0.02, axis=1) & np.all(hi[:, :2] > w.lo[:2] - 0.02, axis=1)
        inter &= (lo[:, 2] < w.hi[2]) & (hi[:, 2] > w.lo[2])
        assert not inter.any(), (w, [objects[i]["class"] for i in np.nonzero(inter)[0]])
    # no wall box the robot could touch (it reaches the floor) is within the robot radius of a path segment
    p0 = np.concatenate([p[:-1] if len(p) > 1 else p for p in paths])
    p1 = np.concatenate([p[1:] if len(p) > 1 else p for p in paths])
    for w in plan.walls:
        if w.lo[2] > 1e-9:
            assert w.lo[2] >= min(fp.DOOR_HEAD_M, plan.wall_height) - 1e-9  # lintels and window heads only
            continue
        d = fp.segment_box_distance(p0, p1, w.lo[:2], w.hi[:2]).min()
        assert d >= radius, (w, d)
    # every room reachable from the start rooms through doorways
    for p in paths:
        start = plan.room_at(p[0])
        assert start >= 0
        assert _reachable(plan, start) == {r.index for r in plan.rooms}
    # every path point and every cuboid centre inside a room; rooms do not overlap
    for p in paths:
        assert all(plan.room_at(q) >= 0 for q in p)
    for o in objects:
        assert plan.room_at(o["centroid"][:2]) >= 0
    for i, a in enumerate(plan.rooms):
        assert np.all(a.hi - a.lo >= fp.MIN_ROOM_SIDE_M - plan.wall_thickness - 1e-9)
        for b in plan.rooms[i + 1:]:
            assert np.any(a.hi <= b.lo + 1e-9) or np.any(b.hi <= a.lo + 1e-9)
    # lamps: at least one per room, under the ceiling
    for r in plan.rooms:
        inside = [q for q in plan.lights if np.all(q[:2] >= r.lo) and np.all(q[:2] <= r.hi)]
        assert inside, r
        assert all(0 < q[2] < plan.wall_height for q in inside)
    # windows only in exterior walls, doors only inside; no window behind a cuboid taller than the sill
    for op in plan.openings:
        wall = plan.walls[op.wall]
        assert np.all(op.hi > op.lo)
        assert abs(np.linalg.norm(op.outward) - 1) < 1e-9
        if op.kind == "window":
            assert wall.exterior and op.rooms[1] == -1
            assert op.lo[2] == pytest.approx(fp.WINDOW_SILL_M) and op.hi[2] == pytest.approx(fp.WINDOW_HEAD_M)
            ax = int(np.argmax(np.abs(op.outward)))
            o = 1 - ax
            face = op.lo[ax] if op.outward[ax] > 0 else op.hi[ax]  # the inner face
            tall = hi[:, 2] > fp.WINDOW_SILL_M
            gap = np.where(op.outward[ax] > 0, face - hi[:, ax], lo[:, ax] - face)
            near = tall & (gap <= fp.WINDOW_CLEAR_DEPTH_M) & (lo[:, o] < op.hi[o]) & (hi[:, o] > op.lo[o])
            assert not near.any(), [objects[i]["class"] for i in np.nonzero(near)[0]]
        else:
            assert op.kind == "door" and not wall.exterior and min(op.rooms) >= 0
            assert op.lo[2] == 0.0
    assert plan.wall_height >= max(fp.WALL_HEIGHT_MIN_M, float(hi[:, 2].max(initial=0)) + 0.3 - 1e-9)
    # wall spans: on a room's face, inside the room's extent, clear of doorways
    for s in plan.wall_spans:
        r = plan.rooms[s.room]
        assert s.max_height <= plan.wall_height
        for q in (s.a, s.b):
            assert np.all(q >= r.lo - 1e-9) and np.all(q <= r.hi + 1e-9)
        mid = (s.a + s.b) / 2 + 0.05 * s.inward
        assert np.all(mid > r.lo) and np.all(mid < r.hi)  # the normal points into the room
        for op in plan.openings:
            if op.kind != "door":
                continue
            ax = int(np.argmax(np.abs(op.outward)))
            o = 1 - ax
            on_face = op.lo[ax] - 1e-6 <= s.a[ax] <= op.hi[ax] + 1e-6
            assert not (on_face and min(s.a[o], s.b[o]) < op.hi[o] and max(s.a[o], s.b[o]) > op.lo[o])


@pytest.mark.parametrize("name", ["house", "miniroom"])
def test_bear_homes_keep_every_guarantee(homes, name):
    objects, paths, plan = homes[name]
    _check_plan(plan, objects, paths)


def test_house_has_several_rooms_of_plausible_kinds(homes):
    objects, _, plan = homes["house"]
    assert len(plan.rooms) >= 8
    kinds = [r.kind for r in plan.rooms]
    for k in ("kitchen", "bathroom", "bedroom", "living_room", "office"):
        assert k in kinds, kinds
    for o in objects:
        room = plan.rooms[plan.room_at(o["centroid"][:2])]
        if o["class"] == "bed":
            assert room.kind == "bedroom"
        if o["class"] == "toilet":
            assert room.kind == "bathroom"
    assert sum(op.kind == "window" for op in plan.openings) >= len(plan.rooms)
    assert sum(op.kind == "door" and op.leaf for op in plan.openings) >= 5


def test_miniroom_is_one_bedroom_studio(homes):
    _, _, plan = homes["miniroom"]
    assert [r.kind for r in plan.rooms] == ["bedroom"]
    assert not [op for op in plan.openings if op.kind == "door"]
    assert sum(op.kind == "window" for op in plan.openings) >= 2


def test_same_seed_same_plan_and_the_seed_matters():
    objects, paths = _home("house")
    a = fp.derive_floor_plan(objects, paths, seed=0).to_dict()
    b = fp.derive_floor_plan(list(objects), [p.copy() for p in paths], seed=0).to_dict()
    assert a == b
    others = [fp.derive_floor_plan(objects, paths, seed=s).to_dict() for s in (1, 2, 3)]
    assert any(o != a for o in others)
    for s, plan in zip((1, 2, 3), others):
        assert plan["outer_lo"] == a["outer_lo"] and plan["wall_height"] == a["wall_height"], s


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_other_seeds_keep_every_guarantee(seed):
    objects, paths = _home("house")
    _check_plan(fp.derive_floor_plan(objects, paths, seed=seed), objects, paths)


def _obj(cls, c, e):
    return {"class": cls, "ID_name": cls, "centroid": list(c), "extent": list(e), "isgroup": False}


def test_two_clusters_with_a_path_between_become_two_rooms_with_a_door_on_the_path():
    objects = [_obj("bed", (0.0, 0.0, 0.3), (2.0, 1.6, 0.6)), _obj("couch", (8.0, -0.8, 0.4), (2.0, 0.9, 0.8)),
               _obj("tv", (8.0, 1.2, 0.8), (0.6, 0.2, 0.5))]
    path = np.array([[1.6, 0.3], [4.0, 0.6], [6.6, 0.2]])
    plan = fp.derive_floor_plan(objects, [path])
    _check_plan(plan, objects, [path])
    assert sorted(r.kind for r in plan.rooms) == ["bedroom", "living_room"]
    doors = [op for op in plan.openings if op.kind == "door"]
    assert len(doors) == 1 and doors[0].leaf
    d = doors[0]
    assert abs(d.outward[0]) == 1.0  # in a wall across x
    x = (d.lo[0] + d.hi[0]) / 2
    y_on_path = np.interp(x, path[:, 0], path[:, 1])
    assert d.lo[1] + RADIUS <= y_on_path <= d.hi[1] - RADIUS  # the robot passes through the opening
    assert fp.DOOR_MIN_WIDTH_M - 1e-9 <= d.hi[1] - d.lo[1] <= fp.DOOR_MAX_WIDTH_M
    assert d.hi[2] == pytest.approx(fp.DOOR_HEAD_M)


def test_a_path_stretch_as_wide_as_a_doorway_gets_a_door_whatever_the_last_bit():
    """A stretch of wall the paths need, 0.91 m wide (between the doorway's least and largest widths), gets a doorway
    of exactly its width: (a + b) / 2 - (b - a) / 2 is a bit more than a here, which made it an open passage."""
    a, b = 0.3, 1.21
    assert (a + b) / 2 - (b - a) / 2 > a
    planner = fp._Planner([], [np.array([[0.0, 0.0], [1.0, 1.0]])], 0, RADIUS)
    ((d0, d1, kind),) = planner._openings([], [(a, b)], (0.0, 5.0))
    assert kind == "door" and d0 == pytest.approx(a) and d1 == pytest.approx(b)


def test_a_wall_no_path_crosses_still_gets_a_doorway():
    objects = [_obj("bed", (0.0, 0.0, 0.3), (2.0, 1.6, 0.6)), _obj("toilet", (7.0, 0.0, 0.3), (0.5, 0.6, 0.6))]
    path = np.array([[-0.5, 1.8], [0.5, 1.8]])  # the robot stays in the bedroom
    plan = fp.derive_floor_plan(objects, [path])
    _check_plan(plan, objects, [path])
    assert sorted(r.kind for r in plan.rooms) == ["bathroom", "bedroom"]
    assert [op.leaf for op in plan.openings if op.kind == "door"] == [True]


def test_no_wall_where_its_rooms_could_not_be_connected():
    # bedroom and bathroom fixtures 1.2 m apart along their whole length: no doorway has clear floor on both sides,
    # and the robot never leaves the bedroom; a wall between them would leave the bathroom unreachable
    objects = [_obj("bed", (0.0, 0.0, 0.3), (2.0, 5.0, 0.6)), _obj("toilet", (3.6, 0.0, 0.3), (2.8, 5.0, 0.6))]
    path = np.array([[-0.5, 3.0], [0.5, 3.0]])
    plan = fp.derive_floor_plan(objects, [path])
    _check_plan(plan, objects, [path])
    assert len(plan.rooms) == 1


def test_a_path_along_the_only_gap_rules_the_wall_out():
    # the robot drives up and down the only gap between the clusters: a wall there would need a 6 m opening
    objects = [_obj("bed", (0.0, 0.0, 0.3), (2.0, 6.0, 0.6)), _obj("toilet", (3.0, 0.0, 0.3), (2.0, 6.0, 0.6))]
    path = np.array([[1.5, -3.0], [1.5, 3.0]])
    plan = fp.derive_floor_plan(objects, [path])
    _check_plan(plan, objects, [path])
    assert len(plan.rooms) == 1


def test_no_window_behind_tall_furniture():
    # a row of tall cupboards (people, 1.8 m) along the whole south wall of a long room; low tables along the north
    tall = [_obj("person", (x, 0.25, 0.9), (0.8, 0.4, 1.8)) for x in np.arange(0.5, 9.0, 1.0)]
    low = [_obj("table", (x, 3.6, 0.3), (0.8, 0.5, 0.6)) for x in np.arange(0.5, 9.0, 2.0)]
    path = np.array([[0.5, 1.8], [8.5, 1.8]])
    plan = fp.derive_floor_plan(tall + low, [path])
    _check_plan(plan, tall + low, [path])
    south = [op for op in plan.openings if op.kind == "window" and op.outward[1] < 0]
    north = [op for op in plan.openings if op.kind == "window" and op.outward[1] > 0]
    assert not south and len(north) >= 2
    spans = [s for s in plan.wall_spans if s.inward[1] < 0]  # along the north wall
    assert any(s.max_height == pytest.approx(fp.WINDOW_SILL_M) for s in spans)
    assert any(s.max_height == pytest.approx(plan.wall_height) for s in spans)


def test_segment_box_distance_is_exact():
    rng = np.random.default_rng(7)
    p0 = rng.uniform(-3, 3, (300, 2))
    p1 = p0 + rng.uniform(-2, 2, (300, 2))
    p1[:20] = p0[:20]  # points
    p1[20:40, 0] = p0[20:40, 0]  # vertical segments
    lo, hi = np.array([-0.7, -0.4]), np.array([0.9, 0.5])
    got = fp.segment_box_distance(p0, p1, lo, hi)
    t = np.linspace(0, 1, 4001)
    pts = p0[:, None, :] + t[None, :, None] * (p1 - p0)[:, None, :]
    d = np.maximum(np.maximum(lo - pts, pts - hi), 0.0)
    brute = np.hypot(d[..., 0], d[..., 1]).min(axis=1)
    step = np.linalg.norm(p1 - p0, axis=1) / 4000
    assert np.all(got <= brute + 1e-12)
    assert np.all(brute - got <= step + 1e-9)
    assert np.any(got == 0) and np.any(got > 0.5)


def test_corridor_blocked():
    paths = [np.array([[0.0, 0.0], [4.0, 0.0]])]
    c = fp.Corridor.from_paths(paths, 0.35)
    assert c.blocked([1.0, 0.3], [1.5, 0.8])  # 0.30 from the path
    assert not c.blocked([1.0, 0.4], [1.5, 0.8])
    assert c.blocked([4.2, -0.1], [4.5, 0.1])  # beyond the end, 0.2 away
    assert not c.blocked([4.4, -0.1], [4.6, 0.1])
    assert c.blocked([1.0, 0.4], [1.5, 0.8], margin=0.1)
    assert fp.blocked(paths, [1.0, 0.3], [1.5, 0.8]) and not fp.blocked(paths, [1.0, 0.3], [1.5, 0.8],
                                                                         robot_radius_m=0.2)
    plan = fp.derive_floor_plan([_obj("chair", (2.0, 2.0, 0.4), (0.5, 0.5, 0.8))], paths)
    assert plan.blocked([1.0, 0.3], [1.5, 0.8]) and fp.blocked(plan, [1.0, 0.3], [1.5, 0.8])
    assert not plan.blocked([1.75, 1.75], [2.25, 2.25])


def test_bad_input_is_one_clear_error():
    with pytest.raises(BackendError, match="object 0 .* lacks"):
        fp.derive_floor_plan([{"class": "chair", "centroid": [0, 0]}], [])
    with pytest.raises(BackendError, match="path 0 has shape"):
        fp.derive_floor_plan([], [np.zeros((3, 3))])
    with pytest.raises(BackendError, match="no objects and no path"):
        fp.derive_floor_plan([], [])
    with pytest.raises(BackendError, match="non-finite"):
        fp.derive_floor_plan([_obj("chair", (np.nan, 0, 0), (1, 1, 1))], [])
    with pytest.raises(BackendError, match="bad pose"):
        fp.home_inputs([{"environment": {"start_pose": [0, 0, 0, 0, 1, 2, 0]}, "ground_truth": {"objects": []}}])


def test_home_files_are_declared_and_plans_cached(tmp_path):
    """An environment's plan comes from the files its ``home_files`` declares (relative to its file, its own map
    first when not listed), never from files that merely sit beside its map; plans are cached by file and seed."""
    for v in (1, 2):
        (tmp_path / f"house_{v}.json").write_text((DATA / f"house_{v}.json").read_text())
    env = {"name": "h", "variant": 2, "map_path": str(tmp_path / "house_2.json"),
           "_file_path": str(tmp_path / "env.yaml")}
    assert fp.home_files(env) == [tmp_path / "house_2.json"]  # a sibling beside it is not its home
    assert fp.home_files({**env, "home_files": ["house_1.json", "house_2.json"]}) == [
        tmp_path / "house_1.json", tmp_path / "house_2.json"]
    assert fp.home_files({**env, "home_files": ["house_1.json"]}) == [tmp_path / "house_2.json",
                                                                      tmp_path / "house_1.json"]
    with pytest.raises(BackendError, match=r"^environment h:2: home_files\[1\] .*house_9.json does not exist$"):
        fp.home_files({**env, "home_files": ["house_1.json", "house_9.json"]})
    with pytest.raises(BackendError, match="home_files is not a non-empty list"):
        fp.home_files({**env, "home_files": "house_1.json"})
    mine = fp.home_files({**env, "home_files": ["house_1.json", "house_2.json"]})
    a = fp.plan_for_files(mine, seed=0)
    assert fp.plan_for_files(mine, seed=0) is a
    assert fp.plan_for_files(mine, seed=1) is not a
    st = os.stat(mine[0])
    os.utime(mine[0], ns=(st.st_atime_ns, st.st_mtime_ns + 1_000_000_000))
    b = fp.plan_for_files(mine, seed=0)
    assert b is not a and b.to_dict() == a.to_dict()
    with pytest.raises(BackendError, match="cannot read the ground-truth file"):
        fp.plan_for_files([tmp_path / "missing_1.json"])


def test_plan_figure(tmp_path, homes):
    pytest.importorskip("matplotlib")
    from benchbot_worlds.homes.floorplan_plot import save_plan_figure

    objects, paths, plan = homes["miniroom"]
    out = save_plan_figure(plan, objects, paths, tmp_path / "plan.png", dpi=40)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
