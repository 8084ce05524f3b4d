"""Furnished homes lit by day alone (``day``) are lit by the sky through their windows: one point light just inside
each window, the sky's colour at a ceiling lamp's luminance, and part of the ambient it stood in for
(benchbot_worlds.scene.build, docs/realism.md *What paid*)."""

from __future__ import annotations

import numpy as np
import pytest

from benchbot.core.registry import Registry
from benchbot_worlds.scene import build
from benchbot_worlds.scene.build import (BASE_LAMP_INTENSITY, DAY_WINDOW_AMBIENT_SHARE, INDOOR_AMBIENT_GAIN,
                                         LAMP_GAIN, LAMP_RANGE_M, LIGHT_POINT, WINDOW_LIGHT_INSET_M, build_scene)
from benchbot_worlds.scene.model import LUMA_709

LUMA = np.asarray(LUMA_709)


def _furnished(name: str, lighting: str | None = None) -> dict:
    env = {**Registry().get("environments", name), "style": "furnished"}
    return env if lighting is None else {**env, "lighting": lighting}


@pytest.fixture(scope="module")
def miniroom_2():
    """miniroom:2 (lit ``day`` by BEAR's map), its furnished home and its scene."""
    env = _furnished("miniroom:2")
    data = build.load_ground_truth_json(env["map_path"])
    home = build.furnished_home(env, data["environment"], data["ground_truth"]["objects"], env["map_path"])
    return env, home, build_scene(env)


def test_a_day_home_has_one_light_inside_each_window(miniroom_2):
    env, home, scene = miniroom_2
    assert scene.lighting == "day" and len(home.windows) > 0
    points = scene.light_kind == LIGHT_POINT
    assert int(points.sum()) == len(home.windows)  # and no ceiling lamp: it is day
    where = scene.light_vec[points].astype(np.float64)
    centres, inward = home.windows[:, 0], home.windows[:, 1]
    assert np.allclose(where, centres + WINDOW_LIGHT_INSET_M * inward, atol=1e-5)
    assert np.allclose(np.linalg.norm(inward, axis=1), 1.0) and np.all(inward[:, 2] == 0)
    # inside the outer walls, at a window's height
    assert np.all(where[:, :2] > home.outer_lo) and np.all(where[:, :2] < home.outer_hi)
    assert np.all((where[:, 2] > 0.3) & (where[:, 2] < home.wall_height))
    colour = scene.light_colour[points].astype(np.float64)
    lamp = np.array([1.0, 0.82, 0.60]) * BASE_LAMP_INTENSITY * LAMP_GAIN
    assert np.allclose(colour @ LUMA, lamp @ LUMA, rtol=1e-5)
    assert np.all(colour[:, 2] > colour[:, 0])  # the sky's blue, not the lamps' warm white
    assert np.all(scene.light_range[points] == LAMP_RANGE_M)


def test_a_day_homes_ambient_keeps_its_share(miniroom_2):
    _, _, scene = miniroom_2
    day_ambient = np.array([0.30, 0.31, 0.33])
    assert np.allclose(scene.ambient, day_ambient * DAY_WINDOW_AMBIENT_SHARE * INDOOR_AMBIENT_GAIN, rtol=1e-5)


@pytest.mark.parametrize("lighting", ["base", "day_extra", "night", "night_extra"])
def test_other_lightings_get_no_window_lights(miniroom_2, lighting):
    _, home, _ = miniroom_2
    room_min, room_max = np.array([-5.0, -5.0, 0.0]), np.array([5.0, 5.0, 3.0])
    with_windows = build.scene_lights(lighting, room_min, room_max, lamps=home.lamps, windows=home.windows)
    without = build.scene_lights(lighting, room_min, room_max, lamps=home.lamps)
    for a, b in zip(with_windows, without):
        assert np.array_equal(a, b)


def test_a_primitives_room_lit_by_day_has_no_window_lights():
    scene = build_scene({**Registry().get("environments", "miniroom:2"), "style": "primitives"})
    assert scene.lighting == "day" and not np.any(scene.light_kind == LIGHT_POINT)
    assert np.allclose(scene.ambient, [0.30, 0.31, 0.33], rtol=1e-5)
