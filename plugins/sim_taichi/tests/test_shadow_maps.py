"""Shadow maps (``Renderer(shadow_maps=...)``): the lamps' cube maps hold the true distances to the first occluder
and the sun's map the true heights of the first primitive the sun's rays meet, renders lit through them agree with
renders lit through shadow rays, and furnished scenes use them by default while primitive scenes keep exact shadow
rays."""

import dataclasses

import numpy as np
import pytest

pytest.importorskip("taichi")


def _lamp_scene(synthetic_env):
    """A room with a table-top box (centre (3, 0, 0.75), 0.8 × 0.8 × 0.1 m) 1.5 m under a lamp at (3, 0, 2.3),
    and a chair; ambient off, so everything lit is lit by the lamp."""
    from benchbot_worlds.scene.build import build_scene
    from benchbot_worlds.scene.model import LIGHT_POINT

    env = synthetic_env([("table", (3.0, 0.0, 0.75), (0.8, 0.8, 0.1)), ("chair", (0.5, 3.0, 0.3), (0.4, 0.4, 0.6))])
    scene = build_scene({**env, "procedural": False})
    scene.ambient = np.zeros(3, np.float32)
    scene.light_kind = np.array([LIGHT_POINT], np.int32)
    scene.light_vec = np.array([[3.0, 0.0, 2.3]], np.float32)
    scene.light_colour = np.array([[1.5, 1.5, 1.5]], np.float32)
    scene.light_range = np.array([6.0], np.float32)
    return scene


def _pixel(K, T, p):
    """(row, column) of map point p in the view of camera pose T (optical frame) with intrinsics K."""
    q = T[:3, :3].T @ (np.asarray(p, float) - T[:3, 3])
    return int(round(K[1, 1] * q[1] / q[2] + K[1, 2])), int(round(K[0, 0] * q[0] / q[2] + K[0, 2]))


def _render_with_and_without_maps(scene, K, views, W, H):
    """RGB (int) of each view of ``views``, rendered with shadow maps (key True) and with shadow rays (False), and
    whether each renderer's sun took its shadows from the sun map."""
    from benchbot_sim_taichi.render.renderer import Renderer

    images, sun_map = {}, {}
    for maps in (True, False):
        r = Renderer("cpu", shadow_maps=maps)
        r.set_scene(scene)
        sun_map[maps] = r.sun_map
        images[maps] = [r.render(K, T, W, H)["rgb"].astype(int) for T in views]
    return images, sun_map


def _sun_scene(synthetic_env, direction=(0.45, 0.30, 0.84)):
    """The same room lit by the sun alone (``direction``, towards the sun), ambient off."""
    from benchbot_worlds.scene.model import LIGHT_DIRECTIONAL

    scene = _lamp_scene(synthetic_env)
    d = np.asarray(direction, np.float32)
    scene.light_kind = np.array([LIGHT_DIRECTIONAL], np.int32)
    scene.light_vec = (d / np.linalg.norm(d))[None]
    scene.light_colour = np.array([[1.2, 1.2, 1.2]], np.float32)
    scene.light_range = np.zeros(1, np.float32)
    return scene


def _sun_texel(row, p):
    """(column, row) of the sun-map texel that holds point p, from the light's packed row."""
    x = np.dot(p, row[9:12]) - row[15]
    y = np.dot(p, row[12:15]) - row[16]
    return int(np.floor(x)), int(np.floor(y))


def test_the_sun_map_holds_the_height_of_the_first_primitive_the_sun_meets(synthetic_env):
    """With the sun straight overhead, the texel over the table holds the height of its top (0.8 m), the texel over
    the bare floor between the table and the chair holds no primitive, and the map spans the primitives' extent."""
    from benchbot_sim_taichi.render.kernels import SUN_MAP_RES
    from benchbot_sim_taichi.render.renderer import Renderer

    r = Renderer("cpu", shadow_maps=True, device_buffers=False)  # the maps traced into the packed NumPy arrays
    r.set_scene(_sun_scene(synthetic_env, direction=(0.0, 0.0, 1.0)))
    assert r.sun_map and r.lamps_with_maps == 0
    sun_map, row = np.asarray(r._packed["sun_map"]), r._packed["lights"][0]
    assert sun_map.shape == (SUN_MAP_RES, SUN_MAP_RES) and row[8] == 0
    x, y = _sun_texel(row, (3.0, 0.0, 0.0))
    assert sun_map[y, x] == pytest.approx(0.8, abs=1e-3)
    x, y = _sun_texel(row, (1.8, 1.5, 0.0))
    assert sun_map[y, x] < -1e29
    texel = 1.0 / np.linalg.norm(row[9:12])
    extent = 3.2 - (-0.4)  # y, from the table's near side to the chair's far side (x spans 0.3 .. 3.4)
    assert texel == pytest.approx(extent / (SUN_MAP_RES - 4), rel=1e-3)  # and a margin of 2 texels each side


def test_lit_through_the_sun_map_agrees_with_shadow_rays(synthetic_env):
    """The floor around the table seen from above, lit by an oblique sun through its map and through shadow rays:
    the table's shadow on the floor is dark in both, the table top and the open floor lit in both, and all but a
    thin rim of pixels along the shadow's edges agree within 2 levels."""
    from benchbot_sim_taichi.render.renderer import intrinsics

    scene = _sun_scene(synthetic_env)
    W, H = 96, 72
    K = intrinsics(W, H, 90.0)
    T = np.diag([1.0, -1.0, -1.0, 1.0])  # looking straight down from 2.4 m over the table and its shadow
    T[:3, 3] = (2.6, -0.25, 2.4)

    def pixel(p):
        return _pixel(K, T, p)

    renders, sun_map = _render_with_and_without_maps(scene, K, [T], W, H)
    assert sun_map == {True: True, False: False}
    images = {maps: views[0] for maps, views in renders.items()}
    # the shadow of the table top's centre (0.8 m high) falls 0.8 / 0.84 · (0.45, 0.30) away from under it
    d = np.array([0.45, 0.30, 0.84]) / np.linalg.norm([0.45, 0.30, 0.84])
    shadow = np.array([3.0, 0.0, 0.8]) - 0.8 / d[2] * d
    for got in images.values():
        assert got[pixel(shadow)].max() == 0
        assert got[pixel((3.1, 0.1, 0.8))].min() > 40  # the table top
        assert got[pixel((3.0, -1.2, 0.0))].min() > 40  # the open floor
    diff = np.abs(images[True] - images[False]).max(axis=2)
    assert (diff > 2).mean() < 0.03, f"{(diff > 2).mean():.3f} of pixels differ"


def test_a_lamp_map_holds_the_distance_to_the_first_occluder(synthetic_env):
    """Straight down from the lamp (face −z, centre texels) the map holds the distance to the top of the table box
    (2.3 − 0.8 = 1.5 m); straight up (face +z) nothing but the shell, which casts no shadow: no occluder."""
    from benchbot_sim_taichi.render.kernels import LAMP_MAP_RES
    from benchbot_sim_taichi.render.renderer import Renderer

    r = Renderer("cpu", shadow_maps=True, device_buffers=False)  # the maps traced into the packed NumPy arrays
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
    from benchbot_sim_taichi.render.renderer import intrinsics

    scene = _lamp_scene(synthetic_env)
    W, H = 96, 72
    K = intrinsics(W, H, 90.0)
    above = np.diag([1.0, -1.0, -1.0, 1.0])  # looking straight down, from beside the lamp
    above[:3, 3] = (2.4, 0.0, 1.9)
    under = above.copy()  # looking down at the floor from under the table top
    under[:3, 3] = (3.0, 0.0, 0.65)

    def pixel(T, p):
        return _pixel(K, T, p)

    images, _sun_map = _render_with_and_without_maps(scene, K, [above, under], W, H)
    for got in images.values():
        assert got[0][pixel(above, (3.1, 0.1, 0.8))].min() > 40  # the table top, lit by the lamp
        assert got[1][H // 2, W // 2].max() == 0  # the floor under the table
    for a, b in zip(images[True], images[False]):
        diff = np.abs(a - b).max(axis=2)
        assert (diff > 2).mean() < 0.03, f"{(diff > 2).mean():.3f} of pixels differ"


def test_furnished_scenes_use_shadow_maps_by_default_primitive_scenes_use_rays(synthetic_env):
    from benchbot_sim_taichi.render.renderer import Renderer

    scene = _lamp_scene(synthetic_env)
    assert scene.style != "furnished"
    sunny = _sun_scene(synthetic_env)
    r = Renderer("cpu")
    r.set_scene(scene)
    assert r.lamps_with_maps == 0
    r.set_scene(sunny)
    assert not r.sun_map
    r.set_scene(dataclasses.replace(scene, style="furnished"))
    assert r.lamps_with_maps == 1
    r.set_scene(dataclasses.replace(sunny, style="furnished"))
    assert r.sun_map
    with_rays = Renderer("cpu", shadow_maps=False)
    with_rays.set_scene(dataclasses.replace(scene, style="furnished"))
    assert with_rays.lamps_with_maps == 0
    with_rays.set_scene(dataclasses.replace(sunny, style="furnished"))
    assert not with_rays.sun_map


def test_a_scene_keeps_the_lights_asked_for(synthetic_env):
    """``Scene.with_lights`` keeps the sun, the lamps, all or none, and refuses another word."""
    from benchbot_worlds.scene.model import LIGHT_DIRECTIONAL, LIGHT_POINT

    scene = _lamp_scene(synthetic_env)
    sun = _sun_scene(synthetic_env)
    both = dataclasses.replace(scene, light_kind=np.concatenate([scene.light_kind, sun.light_kind]),
                               light_vec=np.concatenate([scene.light_vec, sun.light_vec]),
                               light_colour=np.concatenate([scene.light_colour, sun.light_colour]),
                               light_range=np.concatenate([scene.light_range, sun.light_range]))
    assert both.with_lights("sun").light_kind.tolist() == [LIGHT_DIRECTIONAL]
    assert both.with_lights("lamps").light_kind.tolist() == [LIGHT_POINT]
    assert both.with_lights("lamps").light_range.tolist() == [6.0]
    assert both.with_lights("all").light_kind.size == 2 and both.with_lights("none").light_kind.size == 0
    with pytest.raises(ValueError, match="all, sun, lamps or none"):
        both.with_lights("candles")


@pytest.mark.slow  # two renderers each build the scene's BVH and maps
def test_the_shadow_map_benchmark_compares_maps_with_rays_on_an_environment():
    """``benchmarks/shadow_maps.py`` (the maps-against-rays figures of the docs) on a BEAR environment in the tests'
    scene style, with its sun alone, tiny: the sun takes the map, and the images agree but for a few pixels."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[3]
    proc = subprocess.run([sys.executable, str(root / "benchmarks" / "shadow_maps.py"), "--env", "miniroom:1",
                           "--lights", "sun", "--width", "64", "--height", "48", "--every", "25", "--json"],
                          capture_output=True, text=True, timeout=600, cwd=root)
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads(proc.stdout)
    assert out["sun_map"] and out["lamps_with_maps"] == 0 and out["views"] >= 2
    assert out["differ_gt2_mean"] < 0.02 and out["setup_s_maps"] > 0 and out["fps_maps"] > 0 and out["fps_rays"] > 0


@pytest.mark.slow
def test_the_render_benchmark_times_a_scene_with_only_the_lights_asked_for():
    """``benchmarks/render.py --lights sun`` (the lights' share of a frame in the docs), tiny: one light kept, and
    with ``--shadow-maps on`` it takes the sun map."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[3]
    proc = subprocess.run([sys.executable, str(root / "benchmarks" / "render.py"), "--env", "miniroom:1", "--width",
                           "32", "--height", "24", "--frames", "2", "--lights", "sun", "--shadow-maps", "on",
                           "--no-embree", "--json"], capture_output=True, text=True, timeout=600, cwd=root)
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads(proc.stdout)
    assert out["lights"] == 1 and out["lights_kept"] == "sun" and out["sun_map"] and out["lamps_with_maps"] == 0
    assert out["fps"] > 0 and out["lights_on"]


def test_a_sun_without_a_direction_keeps_its_shadow_rays(synthetic_env):
    """A directional light of zero length has no plane to project onto: no sun map, and the scene still renders."""
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics

    scene = dataclasses.replace(_sun_scene(synthetic_env), style="furnished")
    scene.light_vec = np.zeros((1, 3), np.float32)
    r = Renderer("cpu")
    r.set_scene(scene)
    assert not r.sun_map
    assert np.isfinite(r._packed["lights"]).all()
    assert r.render(intrinsics(16, 12, 90.0), np.eye(4), 16, 12)["rgb"].shape == (12, 16, 3)


def test_frames_whose_every_light_has_a_map_are_shaded_without_shadow_rays_and_look_the_same(synthetic_env,
                                                                                            monkeypatch):
    """With one shadow sample and a shadow map for every light (a furnished scene's lamps and sun), the renderer
    shades with ``sensors.shade_maps_kernel``, which has no code of shadow rays (far fewer registers on a GPU): the
    frames equal those of ``shade_kernel``, bit for bit. More samples, a light without a map (a second sun) or maps
    turned off need the rays, and get ``shade_kernel``."""
    from contextlib import contextmanager

    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics

    lamp, sun = _lamp_scene(synthetic_env), _sun_scene(synthetic_env)
    both = dataclasses.replace(lamp, style="furnished",
                               light_kind=np.concatenate([lamp.light_kind, sun.light_kind]),
                               light_vec=np.concatenate([lamp.light_vec, sun.light_vec]),
                               light_colour=np.concatenate([lamp.light_colour, sun.light_colour]),
                               light_range=np.concatenate([lamp.light_range, sun.light_range]))
    W, H = 48, 36
    K = intrinsics(W, H, 90.0)
    views = np.stack([np.diag([1.0, -1.0, -1.0, 1.0])] * 3)  # looking down on the table, its shadows, the chair
    views[:, :3, 3] = [(2.6, -0.25, 2.4), (3.0, 0.0, 0.65), (1.0, 2.5, 1.6)]
    shaded_by = []

    @contextmanager
    def timer(name):
        shaded_by.append(name)
        yield

    r = Renderer("cpu")
    r.set_scene(both)
    assert r.sun_map and r.lamps_with_maps == 1 and not r.shadow_rays
    r.kernel_timer = timer
    fast = r.render_sensors(K, views, W, H)
    assert shaded_by[-1] == "shade_maps_kernel" and fast["rgb"].any()
    r.kernel_timer = None
    assert all(np.array_equal(fast[k], v) for k, v in r.render_sensors(K, views, W, H).items())  # the graph too
    monkeypatch.setattr(Renderer, "shadow_rays", property(lambda self: True))
    r.kernel_timer = timer
    general = r.render_sensors(K, views, W, H)
    assert shaded_by[-1] == "shade_kernel"
    for key in fast:
        np.testing.assert_array_equal(fast[key], general[key], err_msg=key)
    monkeypatch.undo()
    soft = Renderer("cpu", shadow_samples=4)
    soft.set_scene(both)
    rays = Renderer("cpu", shadow_maps=False)
    rays.set_scene(both)
    two_suns = Renderer("cpu")
    two_suns.set_scene(dataclasses.replace(both, light_kind=np.concatenate([both.light_kind, sun.light_kind]),
                                           light_vec=np.concatenate([both.light_vec, sun.light_vec[:, [1, 0, 2]]]),
                                           light_colour=np.concatenate([both.light_colour, sun.light_colour]),
                                           light_range=np.concatenate([both.light_range, sun.light_range])))
    assert soft.shadow_rays and rays.shadow_rays and two_suns.shadow_rays
    # shade_maps_kernel truly has no shadow rays: forced onto lights without maps, those lights add nothing
    rays.kernel_timer = timer
    with_rays = rays.render_sensors(K, views, W, H)["rgb"].astype(int)
    monkeypatch.setattr(Renderer, "shadow_rays", property(lambda self: False))
    without = rays.render_sensors(K, views, W, H)["rgb"].astype(int)
    assert shaded_by[-1] == "shade_maps_kernel"
    assert (without <= with_rays).all() and (without < with_rays - 20).mean() > 0.2
