"""A turned or mirrored layout gives the same furnished world turned or mirrored (benchbot_worlds.homes.home_frame):
the BEAR homes are in their home frame already; every symmetry of the square applied to a home's five variants
(objects, start poses, trajectories) brings it to the same home-frame layout, and the scene built of it is the
original scene carried by that symmetry — floor plan, walls, windows, lamps, furniture, obstacles, the objects'
primitives and the sun's direction — and renders as the original's images turned (the same) or mirrored."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchbot_worlds.bear import DATA_DIR
from benchbot_worlds.homes.floorplan import home_inputs
from benchbot_worlds.homes.home_frame import SQUARE_SYMMETRIES, home_frame, turned_layout
from benchbot_worlds.scene.build import build_scene
from benchbot_worlds.scene.model import LIGHT_DIRECTIONAL

QUARTER_TURN = np.array([[0.0, -1.0], [1.0, 0.0]])
#: The symmetries tried on whole scenes: a quarter turn, a half turn, a mirror about x, a mirror about a diagonal.
TURNS = {"turn 90": QUARTER_TURN, "turn 180": -np.eye(2), "mirror y": np.diag([1.0, -1.0]),
         "mirror diagonal": np.array([[0.0, 1.0], [1.0, 0.0]])}


def _home(name: str) -> list[dict]:
    return [json.loads((DATA_DIR / f"{name}_{v}.json").read_text()) for v in range(1, 6)]


def _scene(folder, name: str, variant: int, dicts: list[dict], style: str = "furnished"):
    folder.mkdir(parents=True, exist_ok=True)
    for v, d in enumerate(dicts, 1):
        (folder / f"{name}_{v}.json").write_text(json.dumps(d))
    env = {"name": name, "variant": variant, "type": "sim_taichi", "style": style,
           "map_path": str(folder / f"{name}_{variant}.json"),
           "home_files": [str(folder / f"{name}_{v}.json") for v in range(1, 6)]}
    return build_scene(env)


def _box(M, lo, hi):
    """The axis-aligned box lo..hi ((..., 2 or 3)) carried by M in xy."""
    lo, hi = np.asarray(lo, float).copy(), np.asarray(hi, float).copy()
    a, b = lo.copy(), hi.copy()
    a[..., :2], b[..., :2] = lo[..., :2] @ M.T, hi[..., :2] @ M.T
    return np.minimum(a, b), np.maximum(a, b)


@pytest.mark.parametrize("name", ["miniroom", "house"])
def test_bear_homes_are_in_their_home_frame_and_every_symmetry_finds_it(name):
    objects, paths = home_inputs(_home(name))
    frame = home_frame(objects, paths)
    assert frame.is_identity  # the BEAR worlds are what they were
    for M in SQUARE_SYMMETRIES:
        moved_objects, moved_paths = home_inputs([turned_layout(d, M) for d in _home(name)])
        f = home_frame(moved_objects, moved_paths)
        np.testing.assert_array_equal(f.R @ M, np.eye(2))  # the turn is undone …
        assert f.objects_to_home(moved_objects) == objects  # … exactly: the same home-frame layout, bit for bit


@pytest.mark.parametrize("name, variant", [("miniroom", 1), pytest.param("house", 2, marks=pytest.mark.slow)])
def test_a_turned_or_mirrored_layout_gives_the_same_world_turned_or_mirrored(tmp_path, name, variant):
    base = _scene(tmp_path / "base", name, variant, _home(name))
    for label, M in TURNS.items():
        moved = _scene(tmp_path / label.replace(" ", "_"), name, variant, [turned_layout(d, M) for d in _home(name)])
        a, b = base.plan, moved.plan
        assert [r.kind for r in a.rooms] == [r.kind for r in b.rooms], label
        for key in ("rooms", "walls", "openings"):
            for x, y in zip(getattr(a, key), getattr(b, key), strict=True):
                np.testing.assert_array_equal(np.concatenate(_box(M, x.lo, x.hi)), np.concatenate([y.lo, y.hi]))
        np.testing.assert_array_equal(np.asarray(a.lights)[:, :2] @ M.T, np.asarray(b.lights)[:, :2])
        # every triangle (structure, windows, doors, furniture, fitted models), in the same order
        v = base.tri_v.astype(np.float64)
        v[..., :2] = v[..., :2] @ M.T
        np.testing.assert_allclose(v, moved.tri_v, atol=2e-6, err_msg=label)
        np.testing.assert_array_equal(base.tri_uv, moved.tri_uv)
        np.testing.assert_array_equal(base.tri_material, moved.tri_material)
        # the ground truth, the primitives of objects without a model, what the robot bumps into, the outdoors
        for lo, hi in (("box_min", "box_max"), ("prim_min", "prim_max"), ("obstacle_min", "obstacle_max"),
                       ("room_min", "room_max")):
            want = _box(M, getattr(base, lo), getattr(base, hi))
            np.testing.assert_allclose(want[0], getattr(moved, lo), atol=1e-6, err_msg=f"{label} {lo}")
            np.testing.assert_allclose(want[1], getattr(moved, hi), atol=1e-6, err_msg=f"{label} {hi}")
        assert base.obstacle_names == moved.obstacle_names
        np.testing.assert_array_equal(base.obstacle_bottom, moved.obstacle_bottom)
        # lamps where they were, the sun from the same side of the house
        np.testing.assert_array_equal(base.light_kind, moved.light_kind)
        lv = base.light_vec.astype(np.float64)
        lv[:, :2] = lv[:, :2] @ M.T
        np.testing.assert_allclose(lv, moved.light_vec, atol=1e-6, err_msg=label)
        sun = base.light_kind == LIGHT_DIRECTIONAL
        if name == "house" and variant == 2:
            assert sun.any()  # house:2 is lit by the sun ("day"): its direction turned with the house
        np.testing.assert_array_equal(base.light_colour, moved.light_colour)


@pytest.mark.slow
def test_the_turned_and_mirrored_worlds_render_as_turned_and_mirrored_images(tmp_path):
    """From the carried poses, a quarter turn of miniroom:1 renders the same images, a mirror the images mirrored
    left to right: depth, class and instance exactly; RGB to one level in a few pixels (float32 shading sums). The
    mirror mirrors the robot too: carter's camera sits 6 cm left of its centre line, so its mirror image carries it
    6 cm to the right."""
    from benchbot.core.geometry import se2_to_matrix
    from benchbot_sim_taichi.backend import DEFAULT_SENSORS, camera_mount
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics

    renderer = Renderer("cpu")
    K = intrinsics(96, 72, 90.0)

    def frames(scene, mirrored=False):
        x0, y0, z0 = DEFAULT_SENSORS["camera"]["mount_xyz"]
        mount = camera_mount({"mount_xyz": [x0, -y0 if mirrored else y0, z0]})
        renderer.set_scene(scene)
        return [{k: np.asarray(v) for k, v in renderer.render(K, se2_to_matrix(x, y, yaw) @ mount, 96, 72).items()}
                for x, y, yaw in scene.trajectory_se2[:3]]

    base = frames(_scene(tmp_path / "base", "miniroom", 1, _home("miniroom")))
    for label, M, flip in (("turn 90", QUARTER_TURN, False), ("mirror y", np.diag([1.0, -1.0]), True)):
        moved = frames(_scene(tmp_path / label.replace(" ", "_"), "miniroom", 1,
                              [turned_layout(d, M) for d in _home("miniroom")]), mirrored=flip)
        for a, b in zip(base, moved, strict=True):
            b = {k: v[:, ::-1] if flip else v for k, v in b.items()}
            for key in ("depth", "class", "instance"):
                np.testing.assert_array_equal(a[key], b[key], err_msg=f"{label} {key}")
            gap = np.abs(a["rgb"].astype(int) - b["rgb"].astype(int))
            assert gap.max() <= 1 and (gap > 0).mean() < 0.005, (label, gap.max(), (gap > 0).mean())


@pytest.mark.parametrize("name, variant", [("miniroom", 1), ("house", 2)])
def test_the_primitives_style_turns_with_its_layout_too(tmp_path, name, variant):
    """In the primitives style the objects' procedural models (a chair's back, a bed's headboard) and the sun are
    made in the home frame as well: the turned layout's primitives are the original's turned."""
    base = _scene(tmp_path / "base", name, variant, _home(name), style="primitives")
    for label, M in TURNS.items():
        moved = _scene(tmp_path / label.replace(" ", "_"), name, variant, [turned_layout(d, M) for d in _home(name)],
                       style="primitives")
        np.testing.assert_array_equal(base.prim_type, moved.prim_type)
        np.testing.assert_array_equal(base.prim_albedo, moved.prim_albedo)
        swap = M[0, 0] == 0  # x and y trade places: so do the cylinders' axes
        axes = np.where((base.prim_axis < 2) & swap, 1 - base.prim_axis, base.prim_axis)
        np.testing.assert_array_equal(axes, moved.prim_axis, err_msg=label)
        for lo, hi in (("prim_min", "prim_max"), ("box_min", "box_max"), ("room_min", "room_max")):
            want = _box(M, getattr(base, lo), getattr(base, hi))
            np.testing.assert_allclose(want[0], getattr(moved, lo), atol=1e-6, err_msg=f"{label} {lo}")
            np.testing.assert_allclose(want[1], getattr(moved, hi), atol=1e-6, err_msg=f"{label} {hi}")
        sun = base.light_kind == LIGHT_DIRECTIONAL
        lv = base.light_vec[sun].astype(np.float64)
        lv[:, :2] = lv[:, :2] @ M.T
        np.testing.assert_allclose(lv, moved.light_vec[moved.light_kind == LIGHT_DIRECTIONAL], atol=1e-6)
