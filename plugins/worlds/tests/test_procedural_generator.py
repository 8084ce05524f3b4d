"""The procedural home generator (benchbot_worlds.procedural: rooms, objects, variants, generator) and the floor plan
that follows a generated layout."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from benchbot_worlds.bear import lighting_of_map_path
from benchbot_worlds.homes.floorplan import (
    DOOR_JAMB_M, MIN_ROOM_SIDE_M, derive_floor_plan, home_inputs, plan_for_home)
from benchbot_worlds.homes.home_frame import SQUARE_SYMMETRIES, HomeFrame
from benchbot_worlds.procedural.free_space import free_space, main_component
from benchbot_worlds.procedural.generator import GENERATOR_VERSION, generate_home
from benchbot_worlds.procedural.layout import layout_from_dict, layout_to_dict
from benchbot_worlds.procedural.objects import FRIDGE_FRONT_M, MAX_OBJECTS, WALL_GAP_M, quota
from benchbot_worlds.procedural.rooms import generate_layout
from benchbot_worlds.procedural.variants import LIGHTINGS
from benchbot_worlds.procedural.visibility import poses_to_se2, unseen_objects

#: Seeds whose homes take < 0.3 s each on a 2-core CPU.
FAST_SEEDS = (1, 3, 5, 8, 9)


def _bytes(home) -> bytes:
    return json.dumps(home.variants, sort_keys=True).encode()


def _boxes(objects):
    c = np.array([o["centroid"] for o in objects])
    e = np.array([o["extent"] for o in objects])
    return c - e / 2, c + e / 2


def test_same_seed_same_bytes_in_process():
    assert GENERATOR_VERSION == 5
    assert _bytes(generate_home(5, "procedural_test_0005")) == _bytes(generate_home(5, "procedural_test_0005"))
    assert _bytes(generate_home(5, "procedural_test_0005")) != _bytes(generate_home(9, "procedural_test_0005"))


@pytest.mark.slow
def test_same_seed_same_bytes_in_a_subprocess():
    code = ("import json,sys;from benchbot_worlds.procedural.generator import generate_home;"
            "sys.stdout.write(json.dumps(generate_home(5,'procedural_test_0005').variants,sort_keys=True))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, check=True).stdout
    assert out == _bytes(generate_home(5, "procedural_test_0005"))


def test_bad_seed_is_refused():
    for bad in (-1, 2 ** 64, 1.5, True):
        with pytest.raises(ValueError):
            generate_home(bad, "x")


def test_layouts_rooms_tile_the_outer_rectangle_and_doors_connect_them():
    for seed in range(60):
        lay = generate_layout(np.random.default_rng(seed))
        area = sum(float(np.prod(r.hi - r.lo)) for r in lay.rooms)
        assert area == pytest.approx(float(np.prod(lay.outer_hi - lay.outer_lo)), abs=1e-6)
        assert all(np.all(r.hi - r.lo >= MIN_ROOM_SIDE_M - 1e-9) for r in lay.rooms)
        assert sum(r.kind == "kitchen" for r in lay.rooms) <= 1
        if len(lay.rooms) >= 2:
            assert any(r.kind == "bedroom" for r in lay.rooms)
        parent = list(range(len(lay.rooms)))

        def find(i):
            while parent[i] != i:
                i = parent[i]
            return i

        for d in lay.doors:
            assert 0.9 - 1e-9 <= d.width <= 1.0 + 1e-9
            a, b = (lay.rooms[i] for i in d.rooms)
            o = 1 - d.axis
            shared = max(a.lo[o], b.lo[o]), min(a.hi[o], b.hi[o])
            assert d.lo >= shared[0] + 0.06 + DOOR_JAMB_M - 1e-9 and d.hi <= shared[1] - 0.06 - DOOR_JAMB_M + 1e-9
            parent[find(d.rooms[0])] = find(d.rooms[1])
        assert len({find(i) for i in range(len(lay.rooms))}) == 1, seed
        for r in lay.rooms:
            if r.kind == "bathroom":
                assert sum(r.index in d.rooms for d in lay.doors) == 1
        assert layout_to_dict(layout_from_dict(layout_to_dict(lay))) == layout_to_dict(lay)


@pytest.mark.parametrize("seed", FAST_SEEDS + (121, 223))  # 121, 223: a desk's monitor once stood past its top
def test_generated_homes_are_valid(seed):
    home = generate_home(seed, f"procedural_test_{seed:04d}")
    lay = home.layout
    assert [v["environment"]["variant"] for v in home.variants] == [1, 2, 3, 4, 5]
    assert [lighting_of_map_path(v["environment"]["map_path"]) for v in home.variants] == list(LIGHTINGS)
    union = {}
    for v in home.variants:
        env = v["environment"]
        assert env["type"] == "world" and env["layout"] == layout_to_dict(lay) and len(env["object_labels"]) == 30
        for o in v["ground_truth"]["objects"]:
            union[(o["ID_name"], tuple(o["centroid"]))] = o
    objects = list(union.values())
    lo, hi = _boxes(objects)
    n = len(objects)
    # no two objects overlap (1 mm tolerance: contact is allowed)
    ov = np.all(lo[:, None] < hi[None] - 1e-3, axis=2) & np.all(hi[:, None] > lo[None] + 1e-3, axis=2)
    ov[np.arange(n), np.arange(n)] = False
    assert not ov.any(), [(objects[i]["ID_name"], objects[j]["ID_name"]) for i, j in zip(*np.nonzero(ov))][:5]
    # each inside one room's clear floor (no wall cut)
    t = lay.wall_thickness
    for k in range(n):
        assert any(np.all(lo[k, :2] >= r.lo + t / 2 * (r.lo > lay.outer_lo) - 1e-6)
                   and np.all(hi[k, :2] <= r.hi - t / 2 * (r.hi < lay.outer_hi) + 1e-6) for r in lay.rooms), k
    # nothing floats or overhangs: on the floor or within 1 mm of another object's top, inside its footprint
    for k in range(n):
        if abs(lo[k, 2]) <= 1e-3:
            continue
        under = (np.abs(hi[:, 2] - lo[k, 2]) <= 1e-3) & np.all(lo[:, :2] <= lo[k, :2] + 1e-3, axis=1) & \
            np.all(hi[:, :2] >= hi[k, :2] - 1e-3, axis=1)
        assert under.any(), objects[k]
    # door approaches clear of floor objects
    for d in lay.doors:
        a, b = np.zeros(2), np.zeros(2)
        a[d.axis], b[d.axis] = d.pos - t / 2 - 0.7, d.pos + t / 2 + 0.7
        a[1 - d.axis], b[1 - d.axis] = d.lo, d.hi
        assert not np.any(np.all(lo[:, :2] < b, axis=1) & np.all(hi[:, :2] > a, axis=1))


def _blocked_fridge_fronts(home) -> list[tuple[str, str]]:
    """(refrigerator, floor object) pairs of ``home`` where the floor object stands in the FRIDGE_FRONT_M strip in
    front of the refrigerator (its back: the side nearest its room's wall)."""
    lay, objects = home.layout, _union(home)
    lo, hi = _boxes(objects)
    t, out = lay.wall_thickness, []
    for k, o in enumerate(objects):
        if o["class"] != "refrigerator":
            continue
        room = next(r for r in lay.rooms if np.all(lo[k, :2] >= r.lo - 1e-6) and np.all(hi[k, :2] <= r.hi + 1e-6))
        rlo = np.asarray(room.lo) + t / 2 * (np.asarray(room.lo) > lay.outer_lo)
        rhi = np.asarray(room.hi) - t / 2 * (np.asarray(room.hi) < lay.outer_hi)
        gaps = {(0, -1): lo[k, 0] - rlo[0], (0, 1): rhi[0] - hi[k, 0], (1, -1): lo[k, 1] - rlo[1],
                (1, 1): rhi[1] - hi[k, 1]}
        ax, sg = min(gaps, key=gaps.get)
        assert gaps[(ax, sg)] <= WALL_GAP_M + 1e-6, "a refrigerator stands against a wall"
        a, b = lo[k, :2].copy(), hi[k, :2].copy()
        a[ax], b[ax] = (hi[k, ax], hi[k, ax] + FRIDGE_FRONT_M) if sg < 0 else (lo[k, ax] - FRIDGE_FRONT_M, lo[k, ax])
        on_floor = np.abs(lo[:, 2]) <= 1e-3
        inside = on_floor & np.all(lo[:, :2] < b - 1e-6, axis=1) & np.all(hi[:, :2] > a + 1e-6, axis=1)
        out += [(o["ID_name"], objects[j]["ID_name"]) for j in np.nonzero(inside)[0]]
    return out


def test_the_floor_in_front_of_every_refrigerator_is_clear():
    """Its doors open and someone stands at them: no floor object (a table, a chair, a sink) within FRIDGE_FRONT_M of
    its front. Without the rule (``front = 0.0`` in ``objects._wall_object``) 7 of these seeds' 8 fridges have one
    there."""
    fridges = 0
    for seed in range(12):
        home = generate_home(seed, f"procedural_test_{seed:04d}")
        fridges += sum(o["class"] == "refrigerator" for o in _union(home))
        assert _blocked_fridge_fronts(home) == [], seed
    assert fridges >= 8


def _union(home) -> list[dict]:
    union = {}
    for v in home.variants:
        for o in v["ground_truth"]["objects"]:
            union[(o["ID_name"], tuple(o["centroid"]))] = o
    return list(union.values())


def _sees_all_and_reaches_all(seed: int) -> None:
    home = generate_home(seed, f"procedural_test_{seed:04d}")
    objs, env = _union(home), home.variants[0]["environment"]
    assert unseen_objects(home.layout, objs, [env["start_pose"]] + env["trajectory_poses"]) == [], seed
    fs = free_space(home.layout, objs)
    assert all(main_component(fs)[1]), seed
    se2 = poses_to_se2([env["start_pose"]] + env["trajectory_poses"])
    assert fs.is_free(se2[:, :2]).all(), seed
    for a, b in zip(se2[:-1], se2[1:]):  # a turn on the spot or a straight drive of at most 1 m along the heading
        moved = float(np.hypot(*(b[:2] - a[:2])))
        turned = abs((b[2] - a[2] + math.pi) % (2 * math.pi) - math.pi)
        heading = math.atan2(b[1] - a[1], b[0] - a[0])
        assert moved < 1e-6 or (turned < 1e-4 and moved <= 1.0 + 1e-6 and math.cos(heading - a[2]) > 1 - 1e-5
                                and fs.segment_free(a[:2], b[:2])), (seed, a, b)
    assert not any("not reachable" in n or "not seen" in n or "no pose sees" in n for n in home.notes), seed


@pytest.mark.parametrize("seed", (7, 30))  # before: rooms the trajectory could not reach (objects.py's own grid)
def test_every_object_is_seen_and_every_room_reached(seed):
    _sees_all_and_reaches_all(seed)


@pytest.mark.slow
def test_every_object_is_seen_and_every_room_reached_over_50_seeds():
    for seed in range(50):
        _sees_all_and_reaches_all(seed)


def test_quota_is_capped_and_keeps_a_bed_per_bedroom_and_a_toilet_per_bathroom():
    for seed in range(40):
        lay = generate_layout(np.random.default_rng(seed))
        q = quota(np.random.default_rng(seed), lay)
        kinds = [r.kind for r in lay.rooms]
        assert sum(q.values()) <= MAX_OBJECTS
        assert q["bed"] >= kinds.count("bedroom") and q["toilet"] >= kinds.count("bathroom")


@pytest.mark.parametrize("seed", FAST_SEEDS[:3])
def test_the_plan_of_a_generated_home_follows_its_layout(seed):
    home = generate_home(seed, f"procedural_test_{seed:04d}")
    lay = home.layout
    plan = plan_for_home(home.variants)
    t = lay.wall_thickness
    got = sorted((round(float(r.lo[0] - t / 2 * (r.lo[0] > lay.outer_lo[0] + 1e-9)), 6),
                  round(float(r.lo[1] - t / 2 * (r.lo[1] > lay.outer_lo[1] + 1e-9)), 6),
                  round(float(r.hi[0] + t / 2 * (r.hi[0] < lay.outer_hi[0] - 1e-9)), 6),
                  round(float(r.hi[1] + t / 2 * (r.hi[1] < lay.outer_hi[1] - 1e-9)), 6), r.kind) for r in plan.rooms)
    want = sorted((*(round(float(v), 6) for v in (*r.lo, *r.hi)), r.kind) for r in lay.rooms)
    assert len(got) == len(want)
    for g, w in zip(got, want):
        assert g[4] == w[4] and np.allclose(g[:4], w[:4], atol=2e-6), (g, w)
    # a doorway where the trajectory passes each layout door
    doors = [o for o in plan.openings if o.kind == "door"]
    for d in lay.doors:
        c = d.centre
        assert any(np.all(o.lo[:2] - 1e-6 <= c) and np.all(c <= o.hi[:2] + 1e-6) for o in doors), d


def test_given_cuts_are_carried_into_a_turned_home_frame():
    home = generate_home(5, "procedural_test_0005")
    objects, paths = home_inputs(home.variants)
    lay = home.variants[0]["environment"]["layout"]
    direct = derive_floor_plan(objects, paths, layout=lay)
    for R in SQUARE_SYMMETRIES[1:]:
        frame = HomeFrame(R, np.array([0.37, -1.2]))
        turned = derive_floor_plan(frame.objects_to_home(objects), [frame.points_to_home(p) for p in paths],
                                   layout=frame.layout_to_home(lay))
        back = frame.plan_to_map(turned)
        a = sorted((tuple(np.round(r.lo, 5)), tuple(np.round(r.hi, 5)), r.kind) for r in direct.rooms)
        b = sorted((tuple(np.round(r.lo, 5)), tuple(np.round(r.hi, 5)), r.kind) for r in back.rooms)
        assert a == b


def test_ground_truth_schema_accepts_the_layout_field():
    """schemas/ground_truth.schema.json leaves ``environment``'s other properties open: no schema change needed."""
    jsonschema = pytest.importorskip("jsonschema")
    from pathlib import Path

    schema = json.loads((Path(__file__).resolve().parents[3] / "schemas" / "ground_truth.schema.json").read_text())
    data = generate_home(5, "procedural_test_0005").variants[0]
    assert "layout" in data["environment"]
    jsonschema.validate(data, schema)


def _at_a_workstation(objects: list[dict]) -> tuple[int, int]:
    """(keyboards, keyboards at a workstation) of a home's ground truth: a monitor (``tv``) on the same table top
    behind the keyboard (its centre within the keyboard's width), its wide side along the keyboard's long side."""
    lo, hi = _boxes(objects)
    keyboards = workstations = 0
    for k, o in enumerate(objects):
        if o["class"] != "keyboard":
            continue
        keyboards += 1
        long_ax = int(np.argmax(hi[k, :2] - lo[k, :2]))
        for j, m in enumerate(objects):
            same_top = abs(lo[j, 2] - lo[k, 2]) < 1e-6
            if m["class"] != "tv" or not same_top:
                continue
            beside = lo[k, long_ax] <= (lo[j, long_ax] + hi[j, long_ax]) / 2 <= hi[k, long_ax]
            if beside and int(np.argmax(hi[j, :2] - lo[j, :2])) == long_ax:
                workstations += 1
                break
    return keyboards, workstations


def test_keyboards_stand_at_a_workstation_with_a_monitor_behind_them():
    """Since generator version 5 a keyboard stands at the front of a desk (one is made in a bedroom or living room
    of a home with no office) with a monitor behind it, as BEAR's one desk has it. Generator version 4's rule (desk
    objects anywhere on a desk's or any table's top) put none of these seeds' 19 keyboards before a monitor; version 5
    puts 16."""
    keyboards = workstations = 0
    for seed in range(16):
        home = generate_home(seed, f"procedural_test_{seed:04d}")
        k, w = _at_a_workstation(home.variants[0]["ground_truth"]["objects"])
        keyboards, workstations = keyboards + k, workstations + w
    assert keyboards >= 8
    assert workstations >= 0.6 * keyboards, (workstations, keyboards)
