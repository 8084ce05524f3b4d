"""Procedural surface textures: seamless, deterministic, distinct per kind."""

import numpy as np
import pytest

from benchbot_worlds.scene.surfaces import SURFACE_KINDS, TEXTURE_PX, room_materials, surface_texture


@pytest.mark.parametrize("kind", SURFACE_KINDS)
def test_texture_tiles_seamlessly(kind):
    img = surface_texture(kind, 5).astype(np.int32)
    assert img.shape == (TEXTURE_PX, TEXTURE_PX, 3) and img.dtype == np.int32
    # The step across the wrap (last column → first, last row → first) is no larger than the largest step between
    # neighbouring columns (rows) inside the image: plank joints and grout lines are steps too.
    for axis in (1, 0):
        steps = np.abs(np.diff(img, axis=axis)).mean(axis=(0, 2) if axis == 1 else (1, 2))
        wrap = np.abs(np.take(img, 0, axis=axis) - np.take(img, -1, axis=axis)).mean()
        assert wrap <= steps.max() + 1


def test_textures_are_deterministic_and_seeded():
    assert np.array_equal(surface_texture("wood", 1), surface_texture.__wrapped__("wood", 1))
    assert not np.array_equal(surface_texture("carpet", 1), surface_texture("carpet", 2))
    assert not surface_texture("tile", 0).flags.writeable


def test_unknown_kind_is_refused():
    with pytest.raises(ValueError, match="unknown surface kind 'marble'"):
        surface_texture("marble")


def test_room_materials_follow_room_kind():
    for seed in range(10):
        assert room_materials("bathroom", seed)["floor"][0] == "tile"
        assert room_materials("kitchen", seed)["floor"][0] == "tile"
        assert room_materials("bedroom", seed)["floor"][0] in ("carpet", "wood")
    assert room_materials("office", 3) == room_materials("office", 3)
    assert room_materials("unknown", 3)["floor"][0] in ("wood", "tile")
