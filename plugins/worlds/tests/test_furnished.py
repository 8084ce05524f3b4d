"""Furnished homes end to end (benchbot_worlds.homes.furnished + scene.build_scene, style ``furnished``) on the ten BEAR
environments with the installed asset packs: the ground truth is unchanged, the models of every object bound exactly
its cuboid, the passive trajectories are collision-free with the added walls and furniture, the variants of a home
share their house, a seed gives one house, the furnished style is the default and the primitive style stays
available, and `benchbot sim plan` draws a home's plan. No Taichi."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchbot.packs.assets import asset_library
from benchbot.core.errors import BackendError
from benchbot.core.seeding import home_seed
from benchbot_worlds.homes.beds import CLEARED_MIN_FRACTION
from benchbot_worlds.homes.furnish import (CLOSED_BOOK_ID, KEYBOARD_ID, PROPORTIONAL_TAG, TOASTER_ID,
                                           UNSTRETCHED_CLASSES)
from benchbot_worlds.homes.furnished import furnish_environment
from benchbot_worlds.homes.furnish_supports import standing_box
from benchbot_sim_taichi.kinematics import Obstacles
from benchbot_worlds.scene.meshes import instance_bounds
from benchbot_worlds.bear import DATA_DIR, home_files_of
from benchbot_worlds.homes.floorplan import home_files
from benchbot_worlds.scene.build import STYLE_VARIABLE, build_scene

ENVS = [f"{home}_{v}" for home in ("miniroom", "house") for v in range(1, 6)]
#: carter's footprint radius and height (robots/carter.yaml).
CARTER_RADIUS_M, CARTER_HEIGHT_M = 0.25, 1.0


def _environment(name: str, **extra) -> dict:
    path = DATA_DIR / f"{name}.json"
    env = dict(json.loads(path.read_text())["environment"])
    env["map_path"] = str(path)
    env["home_files"] = home_files_of(env["name"])  # as the plugin declares them: the variants share one plan
    env.update(extra)
    return env


@pytest.fixture(scope="module")
def scenes(furnished_bear_scenes) -> dict:
    """{'miniroom_1': furnished Scene, …} of the ten BEAR environments, as an episode run with ``--seed 0`` builds
    them (conftest.py: the scenes test_one_home reads too)."""
    return {name: furnished_bear_scenes[name.rsplit("_", 1)[0], int(name.rsplit("_", 1)[1])] for name in ENVS}


@pytest.mark.slow
def test_furnished_homes_draw_textured_models(scenes):
    lib = asset_library()
    assert lib.all(), "no asset pack is installed (benchbot-assets-sh3d provides one)"
    for name, scene in scenes.items():
        assert scene.style == "furnished"
        textured = int((scene.mat_texture >= 0).sum())
        assert scene.tri_v.shape[0] > 5000 and textured > 5, (name, scene.tri_v.shape, textured)


@pytest.mark.parametrize("name", ENVS)
def test_ground_truth_is_unchanged_and_models_fill_their_cuboids(name, scenes):
    scene = scenes[name]
    objects = json.loads((DATA_DIR / f"{name}.json").read_text())["ground_truth"]["objects"]
    assert scene.n_boxes == len(objects)
    for i, o in enumerate(objects):
        c, e = np.asarray(o["centroid"]), np.asarray(o["extent"])
        np.testing.assert_allclose(scene.box_min[i], c - e / 2, atol=1e-5)
        np.testing.assert_allclose(scene.box_max[i], c + e / 2, atol=1e-5)
    env = _environment(name)
    home = furnish_environment(objects, home_files(env), [], seed=home_seed(env["name"]))  # as the scene was
    by_object: dict[int, list] = {}
    for inst in home.instances:
        if inst.object_index >= 0:
            by_object.setdefault(inst.object_index, []).append(instance_bounds(inst))
    modelled = set(by_object)
    library = asset_library()
    proportional = {p.object_index for p in home.furnishing.placements
                    if p.mesh is None and (PROPORTIONAL_TAG in library.get(p.asset_id).tags
                                           or objects[p.object_index]["class"] in UNSTRETCHED_CLASSES)}
    assert len(modelled) >= 0.9 * len(objects), f"{name}: only {len(modelled)} of {len(objects)} objects have models"
    # every object but a mouse (no model in Sweet Home 3D's libraries) is a real model; nothing floats
    assert {objects[i]["class"] for i in range(len(objects)) if i not in modelled} <= {"mouse"}
    assert home.furnishing.unsupported == [], [(objects[i]["class"], why) for i, why in home.furnishing.unsupported]
    # the scene names each object's model (benchmarks/realism.py counts per model); books and keyboards are made in code
    models = {p.object_index: p.asset_id for p in home.furnishing.placements if p.role == "object"}
    assert scene.box_models == [models.get(i, "") for i in range(len(objects))]
    for i, model in enumerate(scene.box_models):
        cls = objects[i]["class"]
        if cls == "book":
            assert model == CLOSED_BOOK_ID, (name, i, model)
        elif cls == "keyboard":
            assert model == KEYBOARD_ID, (name, i, model)
        elif cls == "toaster":
            assert model == TOASTER_ID, (name, i, model)
        elif i in modelled:
            assert library.get(model).cls == cls, (name, i, model)
        else:
            assert model == "", (name, i, model)
    for i, bounds in by_object.items():
        lo = np.min([b[0] for b in bounds], axis=0)
        hi = np.max([b[1] for b in bounds], axis=0)
        c, e = np.asarray(objects[i]["centroid"]), np.asarray(objects[i]["extent"])
        if i in proportional:  # a round clock dial, a bottle: inside its cuboid, on its bottom (proportional_box)
            assert np.all(lo >= c - e / 2 - 1e-4) and np.all(hi <= c + e / 2 + 1e-4), (name, i)
            assert abs(lo[2] - (c[2] - e[2] / 2)) < 1e-4, (name, i)
            size = np.sort(np.asarray(library.get(models[i]).size_m[:2])) / library.get(models[i]).size_m[2]
            np.testing.assert_allclose(np.sort(hi[:2] - lo[:2]) / (hi[2] - lo[2]), size, rtol=0.02,
                                       err_msg=f"{name} object {i}: not scaled uniformly")  # the model's proportions
            continue
        if objects[i]["class"] == "bed":  # its model does not reach into a lower neighbour's (beds.clear_of_neighbours)
            for j, other in by_object.items():
                olo = np.min([q[0] for q in other], axis=0)
                ohi = np.max([q[1] for q in other], axis=0)
                if j != i and olo[2] < c[2] and objects[j]["class"] != "person" \
                        and not np.all((olo >= c - e / 2 - 1e-4) & (ohi <= c + e / 2 + 1e-4)):
                    assert np.any(np.minimum(hi, ohi) - np.maximum(lo, olo) <= 1e-3), (name, i, j)
            assert np.all(lo >= c - e / 2 - 1e-4) and np.all(hi <= c + e / 2 + 1e-4), (name, i)  # inside its cuboid,
            assert np.allclose([lo[2], hi[2]], [c[2] - e[2] / 2, c[2] + e[2] / 2], atol=1e-4), (name, i)  # full height
            assert np.all(hi[:2] - lo[:2] >= CLEARED_MIN_FRACTION * e[:2] - 1e-4), (name, i)
            continue
        want_lo, want_hi = standing_box(objects[i], (c - e / 2, c + e / 2))  # a toilet's bowl: from the floor up
        np.testing.assert_allclose(lo, want_lo, atol=1e-4, err_msg=f"{name} object {i} {objects[i]['class']}")
        np.testing.assert_allclose(hi, want_hi, atol=1e-4, err_msg=f"{name} object {i} {objects[i]['class']}")


@pytest.mark.parametrize("name", ENVS)
def test_passive_trajectory_is_collision_free(name, scenes):
    """The house adds walls and furniture: none of them may block the passive trajectory (carter's footprint)."""
    scene = scenes[name]
    low = scene.obstacle_bottom < CARTER_HEIGHT_M
    assert low.sum() >= 4
    added = Obstacles(rect_min=scene.obstacle_min[low], rect_max=scene.obstacle_max[low],
                      names=[n for n, k in zip(scene.obstacle_names, low) if k],
                      room_min=scene.room_min[:2].astype(np.float64), room_max=scene.room_max[:2].astype(np.float64),
                      radius=CARTER_RADIUS_M)
    poses = np.concatenate([scene.start_se2[None], scene.trajectory_se2])
    for a, b in zip(poses[:-1], poses[1:]):  # the straight segments between poses, every 5 cm
        steps = max(2, int(np.hypot(*(b[:2] - a[:2])) / 0.05) + 1)
        for t in np.linspace(0.0, 1.0, steps):
            p = a[:2] + t * (b[:2] - a[:2])
            clearance, what = added.clearance(p)
            assert clearance > 0.0, f"{name}: the trajectory at {p.round(3)} touches {what} ({clearance:.3f} m)"
    # and the robot's own obstacles include them
    assert set(added.names) <= set(Obstacles.from_scene(scene, CARTER_RADIUS_M, CARTER_HEIGHT_M).names)


def test_variants_share_their_house(scenes):
    for home in ("miniroom", "house"):
        walls = [scenes[f"{home}_{v}"].obstacle_min[[n == "wall" for n in scenes[f"{home}_{v}"].obstacle_names]]
                 for v in range(1, 6)]
        for w in walls[1:]:
            np.testing.assert_array_equal(w, walls[0])


def test_same_seed_same_house_other_seed_may_differ():
    a = build_scene(_environment("miniroom_1", style="furnished"), seed=3)
    b = build_scene(_environment("miniroom_1", style="furnished"), seed=3)
    np.testing.assert_array_equal(a.tri_v, b.tri_v)
    np.testing.assert_array_equal(a.tex_texels, b.tex_texels)


def test_furnished_is_the_default_primitives_stay_available_and_unknown_style_is_one_line(monkeypatch):
    monkeypatch.delenv(STYLE_VARIABLE, raising=False)  # the test suite's conftest sets primitives
    default = build_scene(_environment("miniroom_1"), seed=0)
    assert default.style == "furnished" and default.plan is not None and default.obstacle_min.shape[0] > 0
    monkeypatch.setenv(STYLE_VARIABLE, "primitives")
    assert build_scene(_environment("miniroom_1"), seed=0).style == "primitives"
    assert build_scene(_environment("miniroom_1", style="furnished"), seed=0).style == "furnished"  # the spec wins
    monkeypatch.setenv(STYLE_VARIABLE, "photoreal")
    with pytest.raises(BackendError, match="BENCHBOT_SIM_STYLE='photoreal' names no style") as e:
        build_scene(_environment("miniroom_1"), seed=0)
    assert "furnished, primitives" in str(e.value.hint)
    monkeypatch.delenv(STYLE_VARIABLE)
    scene = build_scene(_environment("miniroom_1", style="primitives"), seed=0)
    assert scene.style == "primitives" and scene.obstacle_min.shape == (0, 2) and scene.plan is None
    assert scene.box_models == []
    with pytest.raises(BackendError, match="unknown style 'photo'") as e:
        build_scene(_environment("miniroom_1", style="photo"), seed=0)
    assert "furnished, primitives" in str(e.value.hint)


@pytest.mark.slow
def test_sim_plan_draws_the_plan_of_a_home(tmp_path):
    from typer.testing import CliRunner

    from benchbot_sim_taichi.cli import app

    out = tmp_path / "plans" / "house_3.png"
    result = CliRunner().invoke(app, ["plan", "house:3", "-o", str(out)])
    assert result.exit_code == 0, result.output
    import cv2

    image = cv2.imread(str(out))
    assert image is not None and min(image.shape[:2]) > 400, None if image is None else image.shape
    # a drawn plan, not a blank page: walls (near black), room tints, boxes and labels
    assert (image.max(axis=2) < 80).mean() > 0.02 and len(np.unique(image.reshape(-1, 3), axis=0)) > 50
    bad = CliRunner().invoke(app, ["plan", "house:3", "-o", str(tmp_path / "no_such_dir_file" / "x.unknownext")])
    assert bad.exit_code != 0 and "Traceback" not in bad.output


def test_windows_have_glass_panes_and_nothing_else_does():
    from benchbot_worlds.scene.meshes import GLASS_OPACITY, load_mesh, with_real_blacks

    env = _environment("miniroom_1")
    data = json.loads((DATA_DIR / "miniroom_1.json").read_text())
    home = furnish_environment(data["ground_truth"]["objects"], home_files(env), [np.zeros((1, 2))], seed=0)
    lib = asset_library()
    placed = list(zip(home.furnishing.placements, home.instances[1:]))  # instances[0]: floors, walls, ceilings
    windows = [(p, inst) for p, inst in placed if p.role == "window"]
    assert len(windows) >= 2
    for p, inst in windows:
        model = load_mesh(lib.get(p.asset_id).path)
        assert any(m.opacity < GLASS_OPACITY for m in model.materials)  # the packaged window has panes…
        assert inst.mesh.f is model.f  # …all of its faces are drawn…
        panes = {m.name for m in inst.mesh.materials if m.glass}
        assert panes == {m.name for m in model.materials if m.opacity < GLASS_OPACITY}, panes  # …its glass as panes
    others = [(p, inst) for p, inst in placed if p.role not in ("window", "door")]
    assert others and all(inst.mesh is (p.mesh if p.mesh is not None
                                        else with_real_blacks(load_mesh(lib.get(p.asset_id).path)))
                          for p, inst in others), "only windows and doors have panes"
    assert not any(m.glass for _, inst in others for m in inst.mesh.materials)
