"""Things on the GT tables' tops (benchbot_worlds.homes.furnish_tables): the top surface of a model, where an item
may stand, and the dressing of tables in a furnished home — on a hand-made table mesh (no Taichi), then on the
shipped pack's tables in BEAR homes."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from benchbot.packs.assets import AssetLibrary
from benchbot_worlds.homes import furnish as F
from benchbot_worlds.homes import furnish_tables as T

sys.path.insert(0, str(Path(__file__).parent))
from test_furnish import FULL_LIB, asset, box_of, gt, inter, obj_asset, one_room_plan, placed_box  # noqa: E402


@dataclass
class Mesh:
    v: np.ndarray
    f: np.ndarray


def _quad(v, f, corners):
    i = len(v)
    v.extend(corners)
    f.extend([[i, i + 1, i + 2], [i, i + 2, i + 3]])


def rimmed_table_mesh(w=1.2, d=0.8, h=0.75, rim=0.05, inset=0.02, shelf_z=0.2) -> Mesh:
    """A table model (origin at the bottom centre, z up): a top at ``h − inset`` set into a rim ``rim`` wide at
    ``h``, a shelf at ``shelf_z`` and four vertical legs."""
    v, f = [], []
    x, y = w / 2, d / 2
    xi, yi = x - rim, y - rim
    _quad(v, f, [[-xi, -yi, h - inset], [xi, -yi, h - inset], [xi, yi, h - inset], [-xi, yi, h - inset]])
    rims = (((-x, -y), (x, -y + rim)), ((-x, y - rim), (x, y)), ((-x, -y), (-x + rim, y)), ((x - rim, -y), (x, y)))
    for a, b in rims:
        _quad(v, f, [[a[0], a[1], h], [b[0], a[1], h], [b[0], b[1], h], [a[0], b[1], h]])
    _quad(v, f, [[-xi, -yi, shelf_z], [xi, -yi, shelf_z], [xi, yi, shelf_z], [-xi, yi, shelf_z]])
    for sx in (-1, 1):
        for sy in (-1, 1):
            _quad(v, f, [[sx * xi, sy * yi, 0], [sx * x, sy * yi, 0], [sx * x, sy * yi, h], [sx * xi, sy * yi, h]])
    return Mesh(np.asarray(v, float), np.asarray(f, np.int64))


def test_the_top_surface_is_the_up_facing_triangles_near_the_top():
    mesh = rimmed_table_mesh()
    tris = T.top_surface(mesh.v, mesh.f, np.eye(4))
    assert len(tris) == 2 + 8  # the inset top and the rim; neither the shelf nor the legs
    z = T.surface_heights(tris, np.array([[0.0, 0.0], [0.58, 0.0], [0.0, 0.38], [0.7, 0.0], [0.0, 0.5]]))
    assert z[0] == pytest.approx(0.73) and z[1] == pytest.approx(0.75) and z[2] == pytest.approx(0.75)
    assert np.isneginf(z[3]) and np.isneginf(z[4])  # beside the table: no top
    # placed: turned a quarter and moved
    c, s = 0.0, 1.0
    M = np.array([[c, -s, 0, 2.0], [s, c, 0, 1.0], [0, 0, 1, 0.1], [0, 0, 0, 1]])
    z = T.surface_heights(T.top_surface(mesh.v, mesh.f, M), np.array([[2.0, 1.0], [2.0, 1.58]]))
    assert z == pytest.approx([0.83, 0.85])


def test_footprint_points_cover_the_footprint_edges_included():
    p = T.footprint_points(np.array([0.0, 1.0]), np.array([0.4, 1.2]))
    assert p.shape == (T.FOOTPRINT_GRID ** 2, 2)
    assert p.min(axis=0) == pytest.approx([0.0, 1.0]) and p.max(axis=0) == pytest.approx([0.4, 1.2])


ITEMS = [asset("newspaper_a", T.TABLETOP_KIND, (0.27, 0.24, 0.02), mount="surface"),
         asset("plate_a", T.TABLETOP_KIND, (0.2, 0.2, 0.02), mount="surface"),
         asset("candle_a", T.TABLETOP_KIND, (0.13, 0.13, 0.15), mount="surface")]


def _dressed(objs, lib, seed=0, context=None):
    plan = one_room_plan()
    meshes = {"table_a": rimmed_table_mesh()}
    res = F.furnish_home(objs, plan, lib, seed=seed, context_objects=context,
                         mesh_of=lambda a: meshes.get(a.id) or rimmed_table_mesh(*a.size_m))
    return res, [p for p in res.placements if p.role == "distractor" and lib.get(p.asset_id).kind == T.TABLETOP_KIND]


def test_tables_get_things_on_their_top_clear_of_what_stands_there():
    lib = AssetLibrary(FULL_LIB + ITEMS)
    table = gt("table", [2.0, 2.0, 0.0], [3.2, 2.8, 0.75])
    cup = gt("cup", [2.4, 2.3, 0.73], [2.5, 2.4, 0.83])
    items = []
    for seed in range(8):
        res, mine = _dressed([table, cup], lib, seed=seed)
        assert len(mine) <= T.MAX_ITEMS_PER_TABLE
        assert len({p.asset_id for p in mine}) == len(mine)  # never the same thing twice on one table
        tlo, thi = box_of(table)
        mesh = rimmed_table_mesh()
        top = T.top_surface(mesh.v, mesh.f, [p for p in res.placements if p.object_index == 0][0].transform)
        for p in mine:
            lo, hi = placed_box(lib, p)
            z = T.surface_heights(top, T.footprint_points(lo[:2], hi[:2]))
            assert np.all(np.isfinite(z)) and lo[2] == pytest.approx(z.max())  # on the top, nowhere beside it
            assert z.min() >= lo[2] - T.MAX_GAP_M - 1e-9
            assert np.all(lo[:2] >= tlo[:2]) and np.all(hi[:2] <= thi[:2])
            cl, ch = box_of(cup)
            assert not inter((lo - T.ITEM_CLEARANCE_M, hi + T.ITEM_CLEARANCE_M), (cl, ch))
        items.append([(p.asset_id, np.round(p.transform, 9).tolist()) for p in mine])
    assert sum(map(len, items)) >= 8  # tables do get things
    again = [[(p.asset_id, np.round(p.transform, 9).tolist()) for p in _dressed([table, cup], lib, seed=s)[1]]
             for s in range(8)]
    assert again == items  # deterministic per seed


def test_the_variants_of_a_home_dress_a_shared_table_alike_and_avoid_each_others_objects():
    lib = AssetLibrary(FULL_LIB + ITEMS)
    table = gt("table", [2.0, 2.0, 0.0], [3.2, 2.8, 0.75], name="table_1")
    book = gt("book", [2.9, 2.5, 0.73], [3.1, 2.7, 0.78])  # on the table in the second variant only
    union = [table, book]
    a = _dressed([table], lib, context=union)[1]
    b = _dressed([table, book], lib, context=union)[1]
    assert [(p.asset_id, p.transform.tolist()) for p in a] == [(p.asset_id, p.transform.tolist()) for p in b]
    for p in a:
        lo, hi = placed_box(lib, p)
        assert not inter((lo - T.ITEM_CLEARANCE_M, hi + T.ITEM_CLEARANCE_M), box_of(book))


def pads_table_mesh(w=1.2, d=0.8, h=0.75, pad=0.1) -> Mesh:
    """A table model whose top is four small pads at its corners (``pad`` a side) with nothing between them."""
    v, f = [], []
    x, y = w / 2, d / 2
    for sx in (-1, 1):
        for sy in (-1, 1):
            a, b = (sx * x, sy * y), (sx * (x - pad), sy * (y - pad))
            lo, hi = np.minimum(a, b), np.maximum(a, b)
            _quad(v, f, [[lo[0], lo[1], h], [hi[0], lo[1], h], [hi[0], hi[1], h], [lo[0], hi[1], h]])
    return Mesh(np.asarray(v, float), np.asarray(f, np.int64))


def test_nothing_stands_where_no_top_is_under_it():
    """Positions whose footprint has no top under it at all (the top's highest point there is -inf) are no place for
    an item: a table of four corner pads too small for any item stays bare (it used to take an item at z = -inf,
    which the fit refused with a ValueError)."""
    lib = AssetLibrary(FULL_LIB + ITEMS)
    table = gt("table", [2.0, 2.0, 0.0], [3.2, 2.8, 0.75])
    for seed in range(8):
        res = F.furnish_home([table], one_room_plan(), lib, seed=seed, mesh_of=lambda a: pads_table_mesh())
        assert not [p for p in res.placements if p.asset_id in {a.id for a in ITEMS}], seed


def test_no_things_without_tabletop_models_a_mesh_or_on_a_plant_stand():
    table = gt("table", [2.0, 2.0, 0.0], [3.2, 2.8, 0.75])
    assert _dressed([table], AssetLibrary(FULL_LIB))[1] == []
    res = F.furnish_home([table], one_room_plan(), AssetLibrary(FULL_LIB + ITEMS), seed=0)  # no mesh_of
    assert not [p for p in res.placements if p.asset_id in {a.id for a in ITEMS}]
    lib = AssetLibrary([a for a in FULL_LIB if a.cls != "table"] + [obj_asset("stand", "table", (0.45, 0.45, 0.9))]
                       + ITEMS)
    stand = gt("table", [2.0, 2.0, 0.0], [2.45, 2.45, 0.9])
    assert _dressed([stand], lib)[1] == []


@pytest.mark.parametrize("name", ["miniroom_1", "house_1"])
def test_things_stand_on_the_shipped_tables_of_bear_homes(name):
    """With the shipped pack, in a furnished BEAR home (map frame, placed meshes): some tables are dressed; every
    tabletop item stands on the top surface of a table model (within MAX_GAP_M everywhere under it) and meets no GT
    cuboid of any variant of the home but a table's top, which it may sink into by at most MAX_GAP_M."""
    import json

    from benchbot.packs.assets import asset_library
    from benchbot_worlds.bear import DATA_DIR
    from benchbot_worlds.homes.floorplan import home_files
    from benchbot_worlds.homes.furnished import furnish_environment
    from benchbot_worlds.scene.meshes import instance_bounds
    from test_furnished import _environment  # noqa: E402

    lib = asset_library()
    assert lib.by_kind(T.TABLETOP_KIND), "the shipped pack (benchbot-assets-sh3d) has no tabletop models"
    objects = json.loads((DATA_DIR / f"{name}.json").read_text())["ground_truth"]["objects"]
    files = home_files(_environment(name))
    home = furnish_environment(objects, files, [], seed=0)
    placed = list(zip(home.furnishing.placements, home.instances[1:]))  # instances[0]: floors, walls, ceilings
    tops = np.concatenate([T.top_surface(inst.mesh.v, inst.mesh.f, inst.transform) for p, inst in placed
                           if p.role == "object" and objects[p.object_index]["class"] == "table"])
    items = [inst for p, inst in placed if p.role == "distractor" and lib.get(p.asset_id).kind == T.TABLETOP_KIND]
    assert items, f"{name}: no table got anything"
    union = [o for f in files for o in json.loads(Path(f).read_text())["ground_truth"]["objects"]]
    assert len(union) > len(objects)
    for inst in items:
        lo, hi = instance_bounds(inst)
        z = T.surface_heights(tops, T.footprint_points(lo[:2], hi[:2]))
        assert np.all(np.isfinite(z)), (name, "off the top")
        assert abs(lo[2] - z.max()) < 1e-6 and z.min() >= lo[2] - T.MAX_GAP_M - 1e-6, (name, lo, z)
        for o in union:
            c = box_of(o)
            if inter((lo, hi), c, eps=1e-4):  # only the top of the table it stands on
                assert o["class"] == "table" and c[1][2] <= lo[2] + T.MAX_GAP_M + 1e-6, (name, o["class"], lo, c)
