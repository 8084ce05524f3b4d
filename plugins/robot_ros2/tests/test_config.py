"""The ros2 robot's configuration: the schema of its ``connections`` and ``ros2`` block (package data
``benchbot_robot_ros2/schemas/robot.schema.json``) is a valid Draft 2020-12 schema that the shipped robots, the fake
robot and :data:`DEFAULTS` satisfy, and bad input, from the spec or from an override, is one clear line naming the
field or its source. No DDS: every error comes before a transport is made."""

from __future__ import annotations

import copy

import pytest

from benchbot.core.errors import BackendError
from benchbot.core.specs import first_error, load_spec_file, validator
from benchbot_robot_ros2 import plugin
from benchbot_robot_ros2.backend import DEFAULTS, ROBOT_SCHEMA, Ros2RobotBackend, ros2_config
from benchbot_robot_ros2.testing import FAKE_SPEC


@pytest.fixture(autouse=True)
def no_overrides(monkeypatch):
    monkeypatch.delenv("ROS_DOMAIN_ID", raising=False)
    monkeypatch.delenv("BENCHBOT_ROS2_TIME_SCALE", raising=False)


def spec(ros2=None, connections=None):
    out = copy.deepcopy(FAKE_SPEC)
    out["ros2"].update(ros2 or {})
    out["connections"].update(connections or {})
    return out


def test_schema_is_valid_and_the_shipped_robots_match_it():
    assert validator(ROBOT_SCHEMA).schema["$id"].endswith("/robot_ros2/robot.schema.json")  # check_schema passed
    assert set(validator(ROBOT_SCHEMA).schema["properties"]["ros2"]["properties"]) == set(DEFAULTS)
    assert first_error({"ros2": DEFAULTS}, ROBOT_SCHEMA) is None
    for path in sorted(plugin.ROBOTS_DIR.glob("*.yaml")):
        assert first_error(load_spec_file(path), ROBOT_SCHEMA) is None, path
    assert first_error(FAKE_SPEC, ROBOT_SCHEMA) is None


def test_config_over_defaults_and_overrides(monkeypatch):
    cfg = ros2_config(spec({"domain_id": 7.0}))
    assert cfg["domain_id"] == 7 and isinstance(cfg["domain_id"], int) and cfg["rate_hz"] == 20.0
    assert cfg["startup_timeout_s"] == 10.0 and isinstance(cfg["startup_timeout_s"], float)
    assert ros2_config({"name": "bare", "ros2": None})["transport"] == "auto"
    assert ros2_config(spec(), {"ros2_domain_id": 12})["domain_id"] == 12
    monkeypatch.setenv("ROS_DOMAIN_ID", "9")
    monkeypatch.setenv("BENCHBOT_ROS2_TIME_SCALE", "2.5")
    cfg = ros2_config(spec())
    assert (cfg["domain_id"], cfg["time_scale"]) == (9, 2.5)


@pytest.mark.parametrize("ros2, connections, field, problem", [
    ({"domain_id": 233}, None, "ros2.domain_id", "greater than the maximum of 232"),
    ({"domain_id": "0"}, None, "ros2.domain_id", "is not of type 'integer'"),
    ({"rate_hz": 0}, None, "ros2.rate_hz", "less than or equal to the minimum of 0"),
    ({"time_scale": -1}, None, "ros2.time_scale", "less than or equal to the minimum of 0"),
    ({"sensor_timeout_s": "fast"}, None, "ros2.sensor_timeout_s", "is not of type 'number'"),
    ({"reset": "teleport"}, None, "ros2.reset", "'teleport' is not one of ['drive', 'topic']"),
    ({"ground_truth": "gps"}, None, "ros2.ground_truth", "is not one of ['tf', 'odometry']"),
    ({"transport": "zenoh"}, None, "ros2.transport", "is not one of ['auto', 'rclpy', 'cyclonedds']"),
    ({"network": "lan"}, None, "ros2.network", "is not one of ['loopback', 'system']"),
    ({"odom_topic": ""}, None, "ros2.odom_topic", "should be non-empty"),
    ({"frames": {"lidar": 3}}, None, "ros2.frames.lidar", "is not of type 'string'"),
    (None, {"move_angle": {"connection": "api_to_ros", "ros_topic": "/cmd_vel", "ros_type": "sensor_msgs/msg/Image"}},
     "connections.move_angle.ros_type", "is not one of ['geometry_msgs/msg/Twist', 'geometry_msgs/Twist']"),
    (None, {"laser": {"connection": "ros_to_api", "ros_topic": "/scan"}},
     "connections.laser", "'ros_type' is a dependency of 'ros_topic'"),
])
def test_a_bad_spec_is_one_line_naming_the_field(ros2, connections, field, problem):
    bad = spec(ros2, connections)
    with pytest.raises(BackendError) as e:
        ros2_config(bad)
    assert e.value.message.startswith(f"robot 'fake_ros2': {field}: ") and problem in e.value.message
    assert "\n" not in e.value.message and "robot.schema.json" in e.value.hint
    with pytest.raises(BackendError) as again:  # the backend refuses it before it makes or touches a transport
        Ros2RobotBackend(bad, {"transport": object()})
    assert again.value.message == e.value.message


def test_twist_actions_in_either_spelling_and_topics_without_type_for_actions_pass():
    ok = {"move_angle": {"connection": "api_to_ros", "ros_topic": "/cmd_vel", "ros_type": "geometry_msgs/Twist"},
          "move_next": {"connection": "api_to_ros", "ros_topic": "/cmd_vel"}, "poses": {"connection": "ros_to_api"}}
    assert ros2_config(spec(connections=ok))["domain_id"] == 0


@pytest.mark.parametrize("variable, value, options, problem", [
    ("ROS_DOMAIN_ID", "300", None, "ROS_DOMAIN_ID = '300': 300 is greater than the maximum of 232"),
    ("ROS_DOMAIN_ID", "abc", None, "ROS_DOMAIN_ID = 'abc': expected an integer"),
    (None, None, {"ros2_domain_id": -1}, "options.ros2_domain_id = -1: -1 is less than the minimum of 0"),
    ("BENCHBOT_ROS2_TIME_SCALE", "0", None, "BENCHBOT_ROS2_TIME_SCALE = '0': 0.0 is less than or equal to the minimum"),
    ("BENCHBOT_ROS2_TIME_SCALE", "x", None, "BENCHBOT_ROS2_TIME_SCALE = 'x': expected a number"),
])
def test_a_bad_override_names_its_source(monkeypatch, variable, value, options, problem):
    if variable:
        monkeypatch.setenv(variable, value)
    with pytest.raises(BackendError) as e:
        ros2_config(spec(), options)
    assert e.value.message.startswith(problem) and "\n" not in e.value.message and e.value.hint


def test_serve_sim_reads_the_domain_through_the_plugin_s_declared_setting(monkeypatch):
    """``ROS_DOMAIN_ID`` is the plugin's setting (``benchbot_robot_ros2.settings``, an external variable): `benchbot
    ros2 serve-sim` and the bridge read it through its reader, a bad value is one line naming it (before: the
    bridge's ``int()`` raised a traceback on ``abc``, and nothing bounded it to 0..232)."""
    from benchbot.core import settings
    from benchbot.core.errors import UsageError
    from benchbot_robot_ros2.plugin import benchbot_settings
    from benchbot_robot_ros2.settings import ROS_DOMAIN_ID

    assert ROS_DOMAIN_ID in benchbot_settings() and ROS_DOMAIN_ID.external
    monkeypatch.setenv("ROS_DOMAIN_ID", "17")
    assert settings.value(ROS_DOMAIN_ID) == 17
    for bad in ("300", "abc"):
        monkeypatch.setenv("ROS_DOMAIN_ID", bad)
        with pytest.raises(UsageError, match=rf"^ROS_DOMAIN_ID='{bad}' is not a whole number from 0 to 232$"):
            settings.value(ROS_DOMAIN_ID)
