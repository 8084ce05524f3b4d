"""Lamp shadow maps (``Renderer(lamp_maps=...)``): the cube maps hold the true distances to the first occluder, a
render lit through them agrees with one lit through shadow rays, and furnished scenes use them by default while
primitive scenes keep exact shadow rays."""

import dataclasses

import numpy as np
import pytest

pytest.importorskip("taichi")


def _lamp_scene(synthetic_env):
    """A room with a table-top box (centre (3, 0, 0.75), 0.8 × 0.8 × 0.1 m) 1.5 m under a lamp at (3, 0, 2.3),
    and a chair; ambient off, so everything lit is lit by the lamp."""
    from benchbot_sim_taichi.scene import LIGHT_POINT, build_scene

    env = synthetic_env([("table", (3.0, 0.0, 0.75), (0.8, 0.8, 0.1)), ("chair", (0.5, 3.0, 0.3), (0.4, 0.4, 0.6))])
    scene = build_scene({**env, "procedural": False})
    scene.ambient = np.zeros(3, np.float32)
    scene.light_kind = np.array([LIGHT_POINT], np.int32)
    scene.light_vec = np.array([[3.0, 0.0, 2.3]], np.float32)
    scene.light_colour = np.array([[1.5, 1.5, 1.5]], np.float32)
    scene.light_range = np.array([6.0], np.float32)
    return scene


def test_a_lamp_map_holds_the_distance_to_the_first_occluder(synthetic_env):
    """Straight down from the lamp (face −z, centre texels) the map holds the distance to the top of the table box
    (2.3 − 0.8 = 1.5 m); straight up (face +z) nothing but the shell, which casts no shadow: no occluder."""
    from benchbot_sim_taichi.kernels import LAMP_MAP_RES
    from benchbot_sim_taichi.renderer import Renderer

    r = Renderer("cpu", lamp_maps=True)
    r.set_scene(_lamp_scene(synthetic_env))
    maps = np.asarray(r._packed["lamp_maps"])
    assert maps.shape == (6, LAMP_MAP_RES, LAMP_MAP_RES)
    c = LAMP_MAP_RES // 2
    down, up = maps[5], maps[4]  # faces 2·axis + (0: +, 1: −), axis z = 2
    assert down[c - 1:c + 1, c - 1:c + 1] == pytest.approx(1.5, abs=2e-3)
    assert np.all(up[c - 1:c + 1, c - 1:c + 1] >= 1e29)
    assert r._packed["lights"][0, 8] == 0  # the lamp's slot


def test_lit_through_lamp_maps_agrees_with_shadow_rays(synthetic_env):
    """The same views rendered with the lamp's shadows from its cube map and from shadow rays: the table top (a
    primitive in the map, so a receiver that could shadow itself) is lit in both, the floor under the table is dark
    in both, and all but a thin rim of pixels along shadow edges agree within 2 levels."""
    from benchbot_sim_taichi.renderer import Renderer, intrinsics

    scene = _lamp_scene(synthetic_env)
    W, H = 96, 72
    K = intrinsics(W, H, 90.0)
    above = np.diag([1.0, -1.0, -1.0, 1.0])  # looking straight down, from beside the lamp
    above[:3, 3] = (2.4, 0.0, 1.9)
    under = above.copy()  # looking down at the floor from under the table top
    under[:3, 3] = (3.0, 0.0, 0.65)

    def pixel(T, p):
        q = T[:3, :3].T @ (np.asarray(p, float) - T[:3, 3])
        return int(round(K[1, 1] * q[1] / q[2] + K[1, 2])), int(round(K[0, 0] * q[0] / q[2] + K[0, 2]))

    images = {}
    for maps in (True, False):
        r = Renderer("cpu", lamp_maps=maps)
        r.set_scene(scene)
        images[maps] = [r.render(K, T, W, H)["rgb"].astype(int) for T in (above, under)]
    for got in images.values():
        assert got[0][pixel(above, (3.1, 0.1, 0.8))].min() > 40  # the table top, lit by the lamp
        assert got[1][H // 2, W // 2].max() == 0  # the floor under the table
    for a, b in zip(images[True], images[False]):
        diff = np.abs(a - b).max(axis=2)
        assert (diff > 2).mean() < 0.03, f"{(diff > 2).mean():.3f} of pixels differ"


def test_furnished_scenes_use_lamp_maps_by_default_primitive_scenes_use_rays(synthetic_env):
    from benchbot_sim_taichi.renderer import Renderer

    scene = _lamp_scene(synthetic_env)
    assert scene.style != "furnished"
    r = Renderer("cpu")
    r.set_scene(scene)
    assert r.lamps_with_maps == 0
    r.set_scene(dataclasses.replace(scene, style="furnished"))
    assert r.lamps_with_maps == 1
    with_rays = Renderer("cpu", lamp_maps=False)
    with_rays.set_scene(dataclasses.replace(scene, style="furnished"))
    assert with_rays.lamps_with_maps == 0
