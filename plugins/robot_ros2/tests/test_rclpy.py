"""A real rclpy (ROS 2 Jazzy from the ``ros-jazzy-*`` PyPI wheels, Fast DDS): the type hashes we announce are the
ones in Jazzy's own type descriptions; rclpy and our Cyclone DDS transport talk both ways on loopback (Fast DDS
through ``fastdds_loopback.xml``); ``serve-sim`` is a node to rclpy's graph API as ``ros2 node list`` and ``ros2
node info`` show it; and the robot ``carter_ros2`` is driven through rclpy against ``serve-sim``.

Marked ``rclpy``: skipped where rclpy cannot be imported (the workspace's own environment); CI runs them in a
Python 3.12 environment of their own with the wheels (``.ci/run``: ``pytest plugins/robot_ros2/tests -m rclpy``).
"""

from __future__ import annotations

import json
import os
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from benchbot_robot_ros2 import convert
from benchbot_robot_ros2.msgs import TYPE_HASHES
from benchbot_robot_ros2.transport import CycloneTransport, rclpy_available

pytestmark = [pytest.mark.rclpy, pytest.mark.skipif(not rclpy_available(),
                                                     reason="rclpy is not importable (no ROS 2 Jazzy here)")]

#: What serve-sim publishes and subscribes to, with their types (its module docstring's table).
SERVE_SIM_PUBLISHES = {
    "/clock": "rosgraph_msgs/msg/Clock", "/camera/color/image_raw": "sensor_msgs/msg/Image",
    "/camera/color/camera_info": "sensor_msgs/msg/CameraInfo", "/camera/depth/image_raw": "sensor_msgs/msg/Image",
    "/camera/depth/camera_info": "sensor_msgs/msg/CameraInfo", "/scan": "sensor_msgs/msg/LaserScan",
    "/odom": "nav_msgs/msg/Odometry", "/tf": "tf2_msgs/msg/TFMessage", "/tf_static": "tf2_msgs/msg/TFMessage",
    "/benchbot/reset_done": "std_msgs/msg/String",
}
SERVE_SIM_SUBSCRIBES = {"/cmd_vel": "geometry_msgs/msg/Twist", "/benchbot/reset": "std_msgs/msg/String"}


def _share() -> Path:
    """The ``share`` folder of the installed ROS 2 packages: the wheels put it in the environment's data folder
    (its prefix); a sourced ROS 2 install has it beside its ``lib``."""
    import sysconfig

    import rclpy

    for base in (Path(sysconfig.get_paths()["data"]), Path(rclpy.__file__).parents[4]):
        if (base / "share" / "rmw_dds_common").is_dir():
            return base / "share"
    pytest.skip("no share/rmw_dds_common here to read Jazzy's type descriptions from")


def test_type_hashes_are_jazzy_s_own():
    """Every hash we announce equals the one in Jazzy's type description (``share/<pkg>/msg/<Name>.json``), the
    three rmw_dds_common ones included; only tf2_msgs, which has no wheel, cannot be checked here."""
    missing = []
    for ros_type, ours in TYPE_HASHES.items():
        pkg, _, name = ros_type.split("/")
        description = _share() / pkg / "msg" / f"{name}.json"
        if not description.is_file():
            missing.append(ros_type)
            continue
        hashes = {h["type_name"]: h["hash_string"] for h in json.loads(description.read_text())["type_hashes"]}
        assert hashes[ros_type] == ours, ros_type
    assert missing == ["tf2_msgs/msg/TFMessage"]


@pytest.mark.slow
def test_rclpy_and_cyclone_dds_talk_both_ways_on_loopback(domain_id):
    """Fast DDS (rclpy, configured by fastdds_loopback.xml) and Cyclone DDS (LOOPBACK_URI) find each other by
    unicast on 127.0.0.1 and exchange messages in both directions; a type rclpy lacks (tf2_msgs) goes through
    Cyclone DDS."""
    from benchbot_robot_ros2.transport import FASTDDS_LOOPBACK_PROFILE, RclpyTransport

    dom = domain_id + 11
    r = RclpyTransport(dom, "loopback", node_name="benchbot_probe_rclpy")
    c = CycloneTransport(dom, "loopback", node_name="benchbot_probe_cyclone")
    assert os.environ["FASTRTPS_DEFAULT_PROFILES_FILE"] == str(FASTDDS_LOOPBACK_PROFILE)
    got = {"to_cyclone": [], "to_rclpy": [], "tf": []}
    done = threading.Event()

    def note(key):
        def callback(msg):
            got[key].append(msg)
            if all(got.values()):
                done.set()
        return callback

    c.subscribe("/t/to_cyclone", "geometry_msgs/msg/Twist", note("to_cyclone"))
    r.subscribe("/t/to_rclpy", "geometry_msgs/msg/Twist", note("to_rclpy"))
    r.subscribe("/t/tf", "tf2_msgs/msg/TFMessage", note("tf"))
    to_cyclone = r.publisher("/t/to_cyclone", "geometry_msgs/msg/Twist")
    to_rclpy = c.publisher("/t/to_rclpy", "geometry_msgs/msg/Twist")
    tf = c.publisher("/t/tf", "tf2_msgs/msg/TFMessage")
    try:
        for _ in range(150):
            to_cyclone.publish(convert.fill_twist(r.message("geometry_msgs/msg/Twist"), 0.5, 0.1))
            to_rclpy.publish(convert.fill_twist(c.message("geometry_msgs/msg/Twist"), -0.25, 1.5))
            tf.publish(c.message("tf2_msgs/msg/TFMessage"))
            if done.wait(0.1):
                break
        assert got["to_cyclone"] and got["to_cyclone"][0].linear.x == 0.5
        assert got["to_rclpy"] and got["to_rclpy"][0].angular.z == 1.5
        assert type(got["to_rclpy"][0]).__module__.startswith("geometry_msgs.msg")  # a real rclpy message
        assert got["tf"] and r.via_cyclonedds == {"tf2_msgs/msg/TFMessage"}
    finally:
        r.close()
        c.close()


def _graph_node(dom: int):
    import rclpy

    context = rclpy.Context()
    rclpy.init(context=context, domain_id=dom)
    return rclpy, context, rclpy.create_node("benchbot_graph_probe", context=context)


@pytest.mark.slow
def test_serve_sim_is_a_node_to_rclpy_s_graph_api(sim_bridge):
    """What ``ros2 node list`` / ``ros2 node info /benchbot_sim`` / ``ros2 topic info -v /scan`` ask rmw: the node
    /benchbot_sim (on Cyclone DDS) with its publishers and subscribers, their types, and our type hashes."""
    dom, _ = sim_bridge
    rclpy, context, node = _graph_node(dom)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if ("benchbot_sim", "/") in node.get_node_names_and_namespaces():
                published = dict(node.get_publisher_names_and_types_by_node("benchbot_sim", "/"))
                if set(SERVE_SIM_PUBLISHES) <= set(published):
                    break
            time.sleep(0.2)
        assert ("benchbot_sim", "/") in node.get_node_names_and_namespaces()
        published = {t: types for t, types in node.get_publisher_names_and_types_by_node("benchbot_sim", "/")}
        assert {t: published.get(t) for t in SERVE_SIM_PUBLISHES} == {t: [v] for t, v in SERVE_SIM_PUBLISHES.items()}
        subscribed = dict(node.get_subscriber_names_and_types_by_node("benchbot_sim", "/"))
        assert {t: subscribed.get(t) for t in SERVE_SIM_SUBSCRIBES} == \
            {t: [v] for t, v in SERVE_SIM_SUBSCRIBES.items()}
        scan = [i for i in node.get_publishers_info_by_topic("/scan") if i.node_name == "benchbot_sim"]
        assert len(scan) == 1 and scan[0].topic_type == "sensor_msgs/msg/LaserScan"
        announced = scan[0].topic_type_hash
        assert f"RIHS{announced.version:02d}_{bytes(announced.value).hex()}" == TYPE_HASHES["sensor_msgs/msg/LaserScan"]
    finally:
        node.destroy_node()
        rclpy.shutdown(context=context)


@pytest.mark.slow
def test_carter_ros2_is_driven_through_rclpy_against_serve_sim(sim_bridge, monkeypatch):
    """The robot carter_ros2 (transport auto: rclpy here) follows miniroom:4's trajectory and turns on the spot
    against serve-sim (Cyclone DDS), its observations as the API gives them: images from Fast DDS, TF from Cyclone
    DDS (tf2_msgs has no wheel)."""
    from benchbot.core.episode import Episode
    from benchbot.core.registry import get_registry
    from benchbot_robot_ros2.backend import Ros2RobotBackend
    from benchbot_robot_ros2.transport import RclpyTransport

    dom, time_scale = sim_bridge
    monkeypatch.setenv("ROS_DOMAIN_ID", str(dom))
    monkeypatch.setenv("BENCHBOT_ROS2_TIME_SCALE", str(time_scale))
    reg = get_registry()
    robot = reg.get("robots", "carter_ros2")
    episode = Episode(reg.get("tasks", "semantic_slam:active:ground_truth"), robot, reg.scenes("miniroom:4"),
                      Ros2RobotBackend(robot, {"seed": 0}))
    try:
        transport = episode.backend.transport
        assert isinstance(transport, RclpyTransport) and transport.via_cyclonedds == {"tf2_msgs/msg/TFMessage"}
        start = episode.backend.base_pose()
        assert episode.act("move_angle", {"angle": 30}) == "SUCCESS"
        turned = episode.backend.base_pose()
        assert np.degrees(turned[2] - start[2]) == pytest.approx(30, abs=2.0)
        assert np.hypot(*(turned[:2] - start[:2])) < 0.05
        obs = episode.observe()
        assert obs["image_rgb"].shape == (48, 64, 3) and obs["image_depth"].shape == (48, 64)
        assert np.isfinite(obs["laser"]["scans"]).all() and obs["poses"]["camera"]["translation_xyz"][2] > 0.5
        assert transport.errors == 0, transport.last_error
    finally:
        episode.backend.close()
