"""Pixel integration (``sensors.camera.samples_per_pixel``): the camera's decode inverts its encode, sub-pixels
tile their pixel, blocks are averaged in linear radiance, and the backend records and applies the setting with
depth, segmentation and the laser left at the pixel centres (real Taichi on the CPU)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from benchbot.core.errors import BackendError
from benchbot_sim_taichi.render.camera_model import CameraModel
from benchbot_sim_taichi.render.pixel_integration import grid_side, integrate, subpixel_intrinsics

CAMERAS = [CameraModel(), CameraModel(-0.5, "filmic", 0.0, True), CameraModel(1.3, "clip", 0.4),
           CameraModel(2.0, "filmic", 0.2)]


@pytest.mark.parametrize("camera", CAMERAS)
def test_decode_inverts_encode_for_every_8_bit_value(camera):
    values = np.arange(256, dtype=np.uint8)
    radiance = camera.decode(values)
    assert np.all(np.diff(radiance) > 0) and radiance[0] == 0.0
    flat = dataclasses.replace(camera, vignetting=0.0)
    again = flat.encode(np.repeat(radiance[:, None, None], 3, axis=2), np.eye(3), gain=1.0)[:, 0, 0]
    assert np.array_equal(again, values)


def test_integrate_averages_linear_radiance_not_the_encoded_values():
    """A block half black and half white averages to half the light: 255 · 0.5^(1/2.2) = 186 through the plain
    camera, not the encoded mean 128; a block of one value keeps it; the filmic camera's own curve is inverted."""
    img = np.zeros((4, 6, 3), np.uint8)
    img[0, 1] = img[1, 0] = 255
    img[0:2, 2:4] = 77
    img[2:4, :] = (10, 200, 255)
    out = integrate(img, 2, CameraModel())
    assert out.shape == (2, 3, 3) and out.dtype == np.uint8
    assert out[0, 0].tolist() == [186, 186, 186]
    assert out[0, 1].tolist() == [77, 77, 77] and out[1, 2].tolist() == [10, 200, 255]
    filmic = CameraModel(-0.5, "filmic")
    half = filmic.encode(np.full((1, 1, 3), filmic.decode(np.uint8(255)) / 2.0), np.eye(3), gain=1.0)[0, 0, 0]
    assert integrate(img, 2, filmic)[0, 0, 0] == half != 186
    assert np.array_equal(integrate(img, 1, filmic), img)
    with pytest.raises(ValueError, match="does not split into 4 x 4 blocks"):
        integrate(img, 4, filmic)


@pytest.mark.parametrize("camera", CAMERAS)
def test_a_block_of_one_value_keeps_it_for_every_value(camera):
    values = np.arange(256, dtype=np.uint8).reshape(16, 16, 1).repeat(3, axis=2)
    blocks = values.repeat(4, axis=0).repeat(4, axis=1)
    assert np.array_equal(integrate(blocks, 4, camera), values)


def test_the_grid_sides_and_the_sub_pixel_intrinsics():
    assert [grid_side(s) for s in (1, 4, 9, 16)] == [1, 2, 3, 4]
    with pytest.raises(ValueError, match="samples_per_pixel must be one of"):
        grid_side(2)
    from benchbot_sim_taichi.render.renderer import intrinsics

    for n in (2, 3, 4):  # the n-times image of the same field of view, pixel centres on integers
        assert np.allclose(subpixel_intrinsics(intrinsics(64, 48, 90.0), n), intrinsics(64 * n, 48 * n, 90.0))


def test_the_backend_integrates_the_rgb_and_keeps_depth_segmentation_and_laser(bear_envs, make_backend, carter_spec):
    """samples_per_pixel 4 against 1 at one pose of miniroom:1: the same depth, segmentation and scan (pixel
    centres), an RGB that differs where the image has edges and detail, and lies closer to the plain image than to
    the plain image moved by one pixel (the sub-pixels tile each pixel's area, not a shifted one)."""
    names = ["image_rgb", "image_depth", "image_segment", "laser"]
    views = {}
    for spp in (1, 4):
        spec = {**carter_spec, "sensors": {**carter_spec["sensors"],
                                           "camera": {**carter_spec["sensors"]["camera"], "samples_per_pixel": spp}}}
        from benchbot_sim_taichi.backend import TaichiSimBackend

        b = TaichiSimBackend(spec, {"arch": "cpu", "width": 96, "height": 72})
        assert b.samples_per_pixel == spp and b.sensors["camera"]["samples_per_pixel"] == spp
        b.load_scene(bear_envs["miniroom:1"])
        views[spp] = b.observe(names)
        b.close()
    plain, ss = views[1], views[4]
    assert np.array_equal(plain["image_depth"], ss["image_depth"])
    assert np.array_equal(plain["image_segment"]["instance_segment_img"], ss["image_segment"]["instance_segment_img"])
    assert np.array_equal(plain["laser"]["scans"], ss["laser"]["scans"])
    a, p = ss["image_rgb"].astype(int), plain["image_rgb"].astype(int)
    err = np.abs(a - p)[2:-2, 2:-2].mean()
    for axis in (0, 1):
        for step in (1, -1):
            moved = np.abs(a - np.roll(p, step, axis=axis))[2:-2, 2:-2].mean()
            assert err < 0.8 * moved, (err, moved, axis, step)
    assert 0 < err and (np.abs(a - p).max(axis=2) > 8).any()


@pytest.mark.parametrize("sensors,field", [({"camera": {"samples_per_pixel": 2}}, "sensors.camera.samples_per_pixel"),
                                           ({"camera": {"samples_per_pixel": 16, "width": 4096}},
                                            "sensors.camera.samples_per_pixel")])
def test_a_bad_samples_per_pixel_is_one_line_naming_the_field(carter_spec, sensors, field):
    from benchbot_sim_taichi.backend import sensor_config

    with pytest.raises(BackendError) as exc:
        sensor_config({"name": "carter", "sensors": sensors})
    assert field in exc.value.message and "\n" not in exc.value.message


def test_batched_robots_refuse_sub_pixels(bear_envs, carter_spec):
    from benchbot_sim_taichi.backend import TaichiSimBackend

    spec = {**carter_spec, "sensors": {**carter_spec["sensors"],
                                       "camera": {**carter_spec["sensors"]["camera"], "samples_per_pixel": 4}}}
    b = TaichiSimBackend(spec, {"arch": "cpu", "width": 32, "height": 24})
    b.load_scene(bear_envs["miniroom:1"])
    with pytest.raises(BackendError, match="samples_per_pixel 4"):
        b.batched(2)
    b.close()
