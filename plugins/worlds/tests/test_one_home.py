"""One house per home: the five variants of a BEAR home, built as episodes build them (each with its own world seed),
share their floor plan, walls, doors, windows, lamps, materials and furniture, and draw the objects they share alike,
so scene change detection between two variants finds only the objects that changed; and a home moved (translated,
or turned and translated) is the same world moved. Real scene builder, real asset packs; Taichi only in the slow
depth test."""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from benchbot.core.seeding import environment_world_seed, home_seed
from benchbot_worlds.bear import DATA_DIR, home_files_of
from benchbot_worlds.homes import floorplan as fp
from benchbot_worlds.homes.home_frame import turned_layout
from benchbot_worlds.scene.build import build_scene
from benchbot_worlds.scene.model import LIGHT_DIRECTIONAL, PRIM_TRIANGLE

sys.path.insert(0, str(Path(__file__).parent))
from test_floorplan import _check_plan  # noqa: E402

HOMES = ("miniroom", "house")
#: Moves of a whole home (all five variants): map → moved map ``p' = M @ p + t`` (metres).
MOVES = {"shifted": (np.eye(2), (7.3, -2.1)), "turned and shifted": (np.array([[0.0, -1.0], [1.0, 0.0]]), (-3.4, 12.9))}
#: carter's footprint radius (robots/carter.yaml) ...
CARTER_RADIUS_M = 0.25


def _variant(name: str, v: int) -> dict:
    return json.loads((DATA_DIR / f"{name}_{v}.json").read_text())


def _key(o: dict) -> tuple:
    """An object of a variant is the same object in another when its ID_name, class, centroid and extent are."""
    return o["ID_name"], o["class"], tuple(o["centroid"]), tuple(o["extent"])


@pytest.fixture(scope="module")
def variants(furnished_bear_scenes) -> dict:
    """{(home, variant): furnished Scene} of the ten BEAR environments, each built with the world seed an episode run
    with ``--seed 0`` gives it (benchbot.core.seeding.environment_world_seed; conftest.py)."""
    return furnished_bear_scenes


def _material_fingerprints(scene) -> list[str]:
    """Per material of ``scene``: a digest of its factors and its texture's texels (level 0)."""
    out = []
    for k in range(len(scene.mat_albedo)):
        h = hashlib.sha1()
        for a in (scene.mat_albedo[k], scene.mat_roughness[k], scene.mat_metallic[k], scene.mat_glass[k]):
            h.update(np.ascontiguousarray(a).tobytes())
        t = int(scene.mat_texture[k])
        if t >= 0:
            offset, w, hgt, _ = (int(x) for x in scene.tex_info[t])
            h.update(scene.tex_texels[offset:offset + w * hgt].tobytes())
        out.append(h.hexdigest())
    return out


def _triangles(scene, objects: bool) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(vertices (T, 3, 3) float64, uvs (T, 3, 2), material fingerprints) of the scene's triangles of ground-truth
    objects (``objects``) or of everything else (structure, doors, windows, lamps, furniture), in scene order."""
    is_tri = scene.prim_type == PRIM_TRIANGLE
    pick = is_tri & ((scene.prim_object >= 0) if objects else (scene.prim_object < 0))
    idx = scene.prim_axis[pick]
    fingerprints = _material_fingerprints(scene)
    mats = [fingerprints[m] if m >= 0 else "" for m in scene.tri_material[idx]]
    return scene.tri_v[idx].astype(np.float64), scene.tri_uv[idx].astype(np.float64), mats


#: Material fingerprints (:func:`_material_fingerprints`) numbered in the order first met, for the rows of a bag.
_FINGERPRINT_NUMBERS: dict[str, int] = {}


class _Bag:
    """The triangles as a multiset (vertices and UVs to 10 µm, materials): a Counter of the triangles' tuples, kept
    as their rows sorted (NumPy: a house's 100,000 triangles as Python tuples took seconds). Two bags are equal when
    they hold the same triangles, each as many times; ``len`` is the number of distinct triangles."""

    def __init__(self, v: np.ndarray, uv: np.ndarray, mats: list[str]):
        numbers = [_FINGERPRINT_NUMBERS.setdefault(m, len(_FINGERPRINT_NUMBERS)) for m in mats]
        rows = np.concatenate([np.round(v.reshape(len(v), 9), 5), np.round(uv.reshape(len(uv), 6), 5),
                               np.asarray(numbers, dtype=np.float64).reshape(-1, 1)], axis=1)
        rows += 0.0  # -0.0 → 0.0: equal as the tuples' floats are
        self.rows = rows[np.lexsort(rows.T[::-1])]

    def __len__(self) -> int:
        return int(len(self.rows) and 1 + np.any(self.rows[1:] != self.rows[:-1], axis=1).sum())

    def __eq__(self, other: object) -> bool:
        return isinstance(other, _Bag) and np.array_equal(self.rows, other.rows)

    __hash__ = None  # type: ignore[assignment]


def _bag(v: np.ndarray, uv: np.ndarray, mats: list[str]) -> _Bag:
    """The triangles as a multiset (vertices and UVs to 10 µm, materials)."""
    return _Bag(v, uv, mats)


@pytest.mark.parametrize("name", ["miniroom", pytest.param("house", marks=pytest.mark.slow)])
def test_the_variants_of_a_home_share_one_plan_materials_and_furniture(variants, name):
    """The plan (rooms, walls, doors, windows, lamps: its digest), and every triangle that is not a ground-truth
    object — floors, walls and ceilings with their materials, doors, windows, lamps, supports, distractor furniture —
    are the same in the five variants, although each is built with its own world seed."""
    scenes = [variants[name, v] for v in range(1, 6)]
    assert len({environment_world_seed(0, {"name": name, "variant": v}) for v in range(1, 6)}) == 5
    digests = {s.plan.digest() for s in scenes}
    assert len(digests) == 1, [s.plan.summary() for s in scenes]
    base = _bag(*_triangles(scenes[0], objects=False))
    assert len(base) > 10_000
    for v, s in enumerate(scenes[1:], 2):
        assert _bag(*_triangles(s, objects=False)) == base, f"{name}:{v}"
        walls = [n == "wall" for n in s.obstacle_names]
        np.testing.assert_array_equal(s.obstacle_min[walls], scenes[0].obstacle_min[[n == "wall" for n in
                                                                                      scenes[0].obstacle_names]])


@pytest.mark.parametrize("name", HOMES)
def test_an_object_the_variants_share_is_drawn_alike_in_all_of_them(variants, name):
    """Its model, turn, size and materials: a home's variants draw a shared object from the home's seed (an object of
    a class no asset pack has, drawn with primitives, alike in shape; their colour varies with the world seed)."""
    drawn = {}
    for v in range(1, 6):
        scene, objects = variants[name, v], _variant(name, v)["ground_truth"]["objects"]
        assert scene.box_names == [o["ID_name"] for o in objects]
        is_tri = scene.prim_type == PRIM_TRIANGLE
        fingerprints = _material_fingerprints(scene)
        for k, o in enumerate(objects):
            idx = scene.prim_axis[is_tri & (scene.prim_object == k)]
            prims = ~is_tri & (scene.prim_object == k)
            shape = sorted(zip(scene.prim_type[prims].tolist(), map(tuple, scene.prim_min[prims].tolist()),
                               map(tuple, scene.prim_max[prims].tolist())))
            drawn.setdefault(_key(o), {})[v] = (scene.box_models[k], shape,
                                                _bag(scene.tri_v[idx].astype(np.float64),
                                                     scene.tri_uv[idx].astype(np.float64),
                                                     [fingerprints[m] for m in scene.tri_material[idx]]))
    shared = {k: d for k, d in drawn.items() if len(d) > 1}
    assert len(shared) >= (10 if name == "miniroom" else 45)
    for key, by_variant in shared.items():
        first = next(iter(by_variant.values()))
        assert all(d == first for d in by_variant.values()), (name, key[0], sorted(by_variant))


@pytest.mark.parametrize("name", HOMES)
def test_the_home_plan_keeps_every_guarantee_for_every_variant(variants, name):
    """No wall cuts a cuboid of any variant, no wall stands in any variant's robot path (the plan's corridor radius),
    every room is reachable, and so on (test_floorplan's checks, on the plan the scenes were built with)."""
    dicts = [_variant(name, v) for v in range(1, 6)]
    objects, paths = fp.home_inputs(dicts)
    _check_plan(variants[name, 1].plan, objects, paths, radius=variants[name, 1].plan.corridor.radius)
    assert variants[name, 1].plan.corridor.radius >= CARTER_RADIUS_M


@pytest.mark.slow
def test_sim_plan_prints_one_plan_for_every_house_variant(tmp_path):
    """``benchbot sim plan house:2`` and ``house:5`` print the same rooms, doors, windows, lamps and plan digest
    (on stderr; the figure's path on stdout)."""
    from typer.testing import CliRunner

    from benchbot_sim_taichi.cli import app

    printed = {}
    for v in (2, 5):
        result = CliRunner().invoke(app, ["plan", f"house:{v}", "-o", str(tmp_path / f"house_{v}.png")])
        assert result.exit_code == 0, result.output
        (line,) = [x for x in result.stderr.splitlines() if x.startswith(f"house:{v}: ")]
        printed[v] = line.split(": ", 1)[1]
    plan = fp.plan_for_files(home_files_of("house"), seed=home_seed("house"))
    assert printed[2] == printed[5] == f"{plan.summary()}; plan {plan.digest()[:12]}", printed


# ------------------------------------------------------------------------------------------------- a moved home
def _moved_scene(folder: Path, name: str, variant: int, M, t):
    """The furnished scene of ``name:variant`` with all five variants of the home moved by ``p' = M @ p + t``,
    named as the original (so the same home seed and world seed)."""
    folder.mkdir(parents=True, exist_ok=True)
    for v in range(1, 6):
        (folder / f"{name}_{v}.json").write_text(json.dumps(turned_layout(_variant(name, v), M, t)))
    env = {"name": name, "variant": variant, "type": "sim_taichi", "style": "furnished",
           "map_path": str(folder / f"{name}_{variant}.json"),
           "home_files": [str(folder / f"{name}_{v}.json") for v in range(1, 6)]}
    return build_scene(env, seed=environment_world_seed(0, env))


def _carry(M, t, lo, hi):
    """The box lo..hi ((..., 2 or 3)) moved by ``p' = M @ p + t`` in xy."""
    lo, hi = np.asarray(lo, float).copy(), np.asarray(hi, float).copy()
    a, b = lo.copy(), hi.copy()
    a[..., :2], b[..., :2] = lo[..., :2] @ M.T + t, hi[..., :2] @ M.T + t
    return np.minimum(a, b), np.maximum(a, b)


@pytest.mark.parametrize("name, variant", [("miniroom", 1), pytest.param("house", 2, marks=pytest.mark.slow)])
def test_a_moved_home_is_the_same_world_moved(tmp_path, variants, name, variant):
    """Translated by (7.3, -2.1) m, or turned a quarter and translated: the same rooms, walls, doors, windows, lamps
    (to 1e-9 m), every triangle in the same order within 1e-5 m (float32) with the same texture coordinates and
    materials, the same ground truth, obstacles and lights, carried."""
    base = variants[name, variant]
    base_v, base_uv, base_mats = _triangles(base, objects=False)
    obj_v, obj_uv, obj_mats = _triangles(base, objects=True)
    for label, (M, t) in MOVES.items():
        t = np.asarray(t, dtype=np.float64)
        moved = _moved_scene(tmp_path / label.replace(" ", "_"), name, variant, M, t)
        a, b = base.plan, moved.plan
        assert [r.kind for r in a.rooms] == [r.kind for r in b.rooms], label
        assert a.summary() == b.summary(), label
        for key in ("rooms", "walls", "openings"):
            for x, y in zip(getattr(a, key), getattr(b, key), strict=True):
                want = np.concatenate(_carry(M, t, x.lo, x.hi))
                np.testing.assert_allclose(np.concatenate([y.lo, y.hi]), want, atol=1e-9, err_msg=f"{label} {key}")
        np.testing.assert_allclose(np.asarray(b.lights)[:, :2], np.asarray(a.lights)[:, :2] @ M.T + t, atol=1e-9)
        for (v0, uv0, m0), (v1, uv1, m1) in (((base_v, base_uv, base_mats), _triangles(moved, objects=False)),
                                             ((obj_v, obj_uv, obj_mats), _triangles(moved, objects=True))):
            want = v0.copy()
            want[..., :2] = v0[..., :2] @ M.T + t
            assert v1.shape == want.shape, label
            assert np.abs(v1 - want).max() < 1e-5, (label, np.abs(v1 - want).max())
            np.testing.assert_array_equal(uv1, uv0, err_msg=label)  # floors and walls textured from the home's origin
            assert m1 == m0, label
        for lo, hi in (("box_min", "box_max"), ("prim_min", "prim_max"), ("room_min", "room_max")):
            want = _carry(M, t, getattr(base, lo), getattr(base, hi))
            np.testing.assert_allclose(getattr(moved, lo), want[0], atol=1e-5, err_msg=f"{label} {lo}")
            np.testing.assert_allclose(getattr(moved, hi), want[1], atol=1e-5, err_msg=f"{label} {hi}")
        want = _carry(M, t, base.obstacle_min, base.obstacle_max)
        np.testing.assert_allclose(moved.obstacle_min, want[0], atol=1e-5, err_msg=label)
        np.testing.assert_allclose(moved.obstacle_max, want[1], atol=1e-5, err_msg=label)
        assert moved.obstacle_names == base.obstacle_names and moved.box_models == base.box_models, label
        np.testing.assert_array_equal(moved.light_kind, base.light_kind)
        sun = base.light_kind == LIGHT_DIRECTIONAL
        lv = base.light_vec.astype(np.float64)
        lv[:, :2] = lv[:, :2] @ M.T + np.where(sun[:, None], 0.0, t)  # the sun's direction turns, lamps move
        np.testing.assert_allclose(moved.light_vec, lv, atol=1e-5, err_msg=label)
        np.testing.assert_array_equal(moved.light_colour, base.light_colour)


# ----------------------------------------------------------------------------------- what change detection sees
@pytest.mark.slow
def test_two_variants_seen_from_the_same_poses_differ_only_at_changed_objects(variants):
    """miniroom:1 and miniroom:2 rendered from the same camera poses (along both trajectories): wherever neither
    image sees an object that changed between them (one not in the other with the same ID_name, class, centroid and
    extent), the depth and the class are the same — the walls, doors, windows, lamps, furniture and unchanged objects
    a change detector sees are one house."""
    from benchbot.core.geometry import se2_to_matrix
    from benchbot_sim_taichi.backend import camera_mount
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics

    a, b = variants["miniroom", 1], variants["miniroom", 2]
    keys = [{_key(o) for o in _variant("miniroom", v)["ground_truth"]["objects"]} for v in (1, 2)]
    changed = keys[0] ^ keys[1]
    assert changed  # 9 objects: 4 gone, 5 new
    poses = np.concatenate([a.trajectory_se2[::6], b.trajectory_se2[::6]])
    renderer, K = Renderer("cpu"), intrinsics(96, 72, 90.0)

    def views(scene, v):
        objects = _variant("miniroom", v)["ground_truth"]["objects"]
        is_changed = {int(i): _key(o) in changed for i, o in zip(scene.box_instance, objects)}
        renderer.set_scene(scene)
        out = []
        for x, y, yaw in poses:
            f = renderer.render(K, se2_to_matrix(x, y, yaw) @ camera_mount(), 96, 72)
            inst = np.asarray(f["instance"])
            out.append((np.asarray(f["depth"]), np.asarray(f["class"]),
                        np.vectorize(lambda i: is_changed.get(int(i), False))(inst)))
        return out

    seen_change = 0
    for (da, ca, xa), (db, cb, xb) in zip(views(a, 1), views(b, 2), strict=True):
        same = ~(xa | xb)
        seen_change += int((~same).sum())
        np.testing.assert_allclose(da[same], db[same], atol=1e-6)
        np.testing.assert_array_equal(ca[same], cb[same])
    assert seen_change > 0  # the views do see what changed
