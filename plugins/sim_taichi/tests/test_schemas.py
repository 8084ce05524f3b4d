"""The sim_taichi backend's schemas (package data ``benchbot_sim_taichi/schemas/``): valid Draft 2020-12 schemas that
the shipped robot, the defaults and the BEAR environments satisfy, and one clear line naming the field for bad input
(``sensor_config``, the backend's options; the mesh objects are tested in test_geometry.py). Nothing here imports
Taichi."""

from __future__ import annotations

import math

import pytest

from benchbot.core.errors import BackendError
from benchbot.core.specs import first_error, load_spec_file, validator
from benchbot_worlds import bear
from benchbot_sim_taichi import plugin
from benchbot_sim_taichi.backend import (
    DEFAULT_SENSORS, OPTIONS_SCHEMA, ROBOT_SCHEMA, TaichiSimBackend, sensor_config,
)
from benchbot_worlds.scene.build import ENVIRONMENT_SCHEMA

CARTER = load_spec_file(plugin.ROBOTS_DIR / "carter.yaml")


def test_schemas_are_valid_and_the_shipped_content_matches_them():
    for path in (ROBOT_SCHEMA, OPTIONS_SCHEMA):
        assert validator(path).schema["$id"].endswith("/sim_taichi/" + path.name)  # check_schema passed
    assert validator(ENVIRONMENT_SCHEMA).schema["$id"].endswith("/worlds/" + ENVIRONMENT_SCHEMA.name)
    assert first_error(CARTER, ROBOT_SCHEMA) is None
    assert first_error({"sensors": DEFAULT_SENSORS}, ROBOT_SCHEMA) is None
    for env in bear.environment_specs():
        assert first_error(env, ENVIRONMENT_SCHEMA) is None
    assert first_error({"mode": "quality", "seed": 3, "arch": None, "anything": object()}, OPTIONS_SCHEMA) is None


def test_sensor_config_merges_defaults_and_options():
    cfg = sensor_config(CARTER, {"width": 32, "height": 24})
    assert (cfg["camera"]["width"], cfg["camera"]["height"]) == (32, 24)
    assert cfg["robot_frame_height_m"] == 0.244 and isinstance(cfg["footprint_radius_m"], float)
    assert sensor_config({"name": "bare"}) == sensor_config({"name": "bare", "sensors": {"camera": None}})
    assert sensor_config({"name": "bare"})["laser"] == DEFAULT_SENSORS["laser"]


@pytest.mark.parametrize("sensors, options, field, problem", [
    ([], None, "sensors", "is not of type 'object', 'null'"),
    ({"camera": 3}, None, "sensors.camera", "is not of type 'object', 'null'"),
    ({"camera": {"width": 0}}, None, "sensors.camera.width", "less than the minimum of 1"),
    ({}, {"width": -4}, "sensors.camera.width", "less than the minimum of 1"),
    ({"camera": {"width": "640"}}, None, "sensors.camera.width", "is not of type 'integer'"),
    ({"camera": {"horizontal_fov_deg": 180}}, None, "sensors.camera.horizontal_fov_deg", "maximum of 180"),
    ({"camera": {"mount_xyz": [1, 2]}}, None, "sensors.camera.mount_xyz", "is too short"),
    ({"camera": {"mount_xyz": [1, 2, math.nan]}}, None, "sensors.camera.mount_xyz[2]", "expected a finite number"),
    ({"laser": {"beams": 2.5}}, None, "sensors.laser.beams", "is not of type 'integer'"),
    ({"laser": {"range_min": -1}}, None, "sensors.laser.range_min", "less than the minimum of 0"),
    ({"laser": {"range_min": 5, "range_max": 4}}, None, "sensors.laser.range_max", "expected range_min < range_max"),
    ({"footprint_radius_m": 0}, None, "sensors.footprint_radius_m", "less than or equal to the minimum of 0"),
    ({"footprint_radius_m": math.nan}, None, "sensors.footprint_radius_m", "expected a finite number"),
    ({"max_height_m": True}, None, "sensors.max_height_m", "is not of type 'number'"),
    ({"robot_frame_height_m": math.inf}, None, "sensors.robot_frame_height_m", "expected a finite number"),
    ({"noise": {"foo": 1}}, None, "sensors.noise", "'foo' was unexpected"),
    ({"noise": {"rgb_sigma": -1}}, None, "sensors.noise.rgb_sigma", "less than the minimum of 0"),
    ({"noise": {"depth_dropout": 1.5}}, None, "sensors.noise.depth_dropout", "greater than the maximum of 1"),
])
def test_a_bad_sensors_block_is_one_line_naming_the_field(sensors, options, field, problem):
    with pytest.raises(BackendError) as e:
        sensor_config({"name": "bot", "sensors": sensors}, options)
    assert e.value.message.startswith(f"robot 'bot': {field}: ") and problem in e.value.message
    assert "\n" not in e.value.message and "robot.schema.json" in e.value.hint


def test_an_unknown_render_mode_names_the_option():
    with pytest.raises(BackendError) as e:
        TaichiSimBackend(CARTER, {"mode": "slow"})
    assert e.value.message == "options.mode: 'slow' is not one of ['fast', 'quality']" and "fast" in e.value.hint
