"""Messages over real DDS (two participants on loopback), the codec against cyclonedds', and the rclpy transport."""

from __future__ import annotations

import math
import threading
import time

import numpy as np
import pytest

from benchbot.core.geometry import quaternion_xyzw_to_matrix
from benchbot_robot_ros2 import convert
from benchbot_robot_ros2.transport import CycloneTransport, rclpy_available


def _roundtrip(domain_id, topic, ros_type, fill):
    a, b = CycloneTransport(domain_id, "loopback"), CycloneTransport(domain_id, "loopback")
    got, ev = [], threading.Event()
    b.subscribe(topic, ros_type, lambda m: (got.append(m), ev.set()))
    pub = a.publisher(topic, ros_type)
    msg = fill(a.message(ros_type))
    deadline = time.monotonic() + 10
    while not ev.is_set() and time.monotonic() < deadline:
        pub.publish(msg)
        ev.wait(0.1)
    a.close(), b.close()
    assert got, f"nothing received on {topic}"
    return msg, got[0]


def test_type_names_and_topics_follow_ros2_conventions():
    from benchbot_robot_ros2.msgs import Image, TFMessage, dds_topic, message_class

    assert Image.__idl_typename__ == "sensor_msgs::msg::dds_::Image_"
    assert TFMessage.__idl_typename__ == "tf2_msgs::msg::dds_::TFMessage_"
    assert message_class("sensor_msgs/Image") is Image
    assert dds_topic("/camera/color/image_raw") == "rt/camera/color/image_raw"
    with pytest.raises(KeyError, match="unsupported ROS 2 message type"):
        message_class("foo_msgs/msg/Bar")


def test_rep117_and_rep118_writers():
    """BenchBot's no return (range_max) and no hit (depth 0.0) become REP 117's +Inf and REP 118's NaN (the writers
    of benchbot.core.ros_messages, which the recorder and the simulator bridge share)."""
    from benchbot.core.ros_messages import ros_depth, ros_ranges

    np.testing.assert_array_equal(ros_ranges(np.array([1.0, 20.0, 25.0, 2.0]), 20.0),
                                  np.array([1.0, np.inf, np.inf, 2.0], np.float32))
    d = ros_depth(np.array([[0.0, 1.5], [-1.0, np.inf]], np.float32))
    assert d.dtype == np.float32 and d[0, 1] == 1.5 and np.isnan(d[0, 0]) and np.isnan(d[1]).all()


def test_fast_codec_is_byte_identical_to_cyclonedds():
    from cyclonedds.idl import IdlStruct

    from benchbot_robot_ros2.msgs import Image, LaserScan

    rng = np.random.default_rng(0)
    img = convert.fill_image(Image(), rng.integers(0, 255, (5, 7, 3), dtype=np.uint8), "rgb8", "camera", 12.5)
    assert img.serialize() == IdlStruct.serialize(img)
    back = Image.deserialize(IdlStruct.serialize(img))
    assert np.array_equal(convert.image_rgb(back), convert.image_rgb(img))
    scan = LaserScan(ranges=[1.0, 2.5, 3.0], intensities=[0.5], range_max=5.0)
    assert scan.serialize() == IdlStruct.serialize(scan)
    assert np.allclose(LaserScan.deserialize(IdlStruct.serialize(scan)).ranges, [1.0, 2.5, 3.0])


@pytest.mark.parametrize("kind", ["image", "depth", "info", "scan", "scan_rep117", "odom", "tf", "twist"])
def test_messages_roundtrip_through_dds(domain_id, kind):
    rng = np.random.default_rng(1)
    rgb = rng.integers(0, 255, (6, 8, 3), dtype=np.uint8)
    depth = rng.random((6, 8)).astype(np.float32)
    K = np.array([[4.0, 0, 3.5], [0, 4.0, 2.5], [0, 0, 1]])
    T = np.eye(4)
    T[:3, :3] = quaternion_xyzw_to_matrix([0, 0, math.sin(0.3), math.cos(0.3)])
    T[:3, 3] = [1.0, -2.0, 0.5]
    cases = {
        "image": ("/t/img", "sensor_msgs/msg/Image", lambda m: convert.fill_image(m, rgb, "rgb8", "camera", 1.0),
                  lambda m: np.testing.assert_array_equal(convert.image_rgb(m), rgb)),
        "depth": ("/t/depth", "sensor_msgs/msg/Image", lambda m: convert.fill_image(m, depth, "32FC1", "camera", 1.0),
                  lambda m: np.testing.assert_array_equal(convert.image_depth(m), depth)),
        "info": ("/t/info", "sensor_msgs/msg/CameraInfo", lambda m: convert.fill_camera_info(m, K, 8, 6, "camera", 1),
                 lambda m: np.testing.assert_array_equal(convert.camera_info(m)["matrix_intrinsics"], K)),
        "scan": ("/t/scan", "sensor_msgs/msg/LaserScan",
                 lambda m: convert.fill_laser(m, np.array([1.0, 2.0, 3.0]), -math.pi, 0.1, 0.1, 20.0, "lidar", 1.0),
                 lambda m: np.testing.assert_allclose(convert.laser(m)["scans"][:, 0], [1, 2, 3])),
        # REP 117 on the wire (+Inf no return, NaN invalid, -Inf too close); angle_min -π arrives as float32(-π),
        # which is below -π: the observation's first angle is still -π, not +π
        "scan_rep117": ("/t/scan117", "sensor_msgs/msg/LaserScan",
                        lambda m: convert.fill_laser(m, np.array([1.0, np.inf, np.nan, -np.inf]), -math.pi,
                                                     2 * math.pi / 4, 0.1, 20.0, "lidar", 1.0),
                        lambda m: (_check_rep117(m), None)[1]),
        "odom": ("/t/odom", "nav_msgs/msg/Odometry", lambda m: (convert.fill_pose(m.pose.pose, T), m)[1],
                 lambda m: np.testing.assert_allclose(convert.odometry_se2(m), [1.0, -2.0, 0.6])),
        "tf": ("/t/tf", "tf2_msgs/msg/TFMessage", lambda m: _tf(m, T),
               lambda m: np.testing.assert_allclose(convert.transform_to_matrix(m.transforms[0].transform), T,
                                                    atol=1e-12)),
        "twist": ("/t/cmd", "geometry_msgs/msg/Twist", lambda m: convert.fill_twist(m, 0.5, -0.25),
                  lambda m: (m.linear.x, m.angular.z) == (0.5, -0.25) or pytest.fail("twist changed")),
    }
    topic, ros_type, fill, check = cases[kind]
    _, got = _roundtrip(domain_id, topic, ros_type, fill)
    check(got)


def _check_rep117(m):
    assert np.float32(m.angle_min) == np.float32(-math.pi)
    scans = convert.laser(m)["scans"]
    np.testing.assert_array_equal(scans[:, 0], [1.0, 20.0, 20.0, 0.0])  # the API's no return: range_max
    assert scans[0, 1] == -math.pi
    assert np.all(scans[:, 1] >= -math.pi) and np.all(scans[:, 1] < math.pi) and np.all(np.diff(scans[:, 1]) > 0)


def _tf(m, T):
    from benchbot_robot_ros2.msgs import TransformStamped

    ts = TransformStamped(child_frame_id="base_link")
    ts.header.frame_id = "map"
    convert.fill_transform(ts.transform, T)
    m.transforms = [ts]
    return m


@pytest.mark.ros
@pytest.mark.rclpy
@pytest.mark.skipif(not rclpy_available(), reason="rclpy is not importable (no ROS 2 Jazzy install here)")
def test_rclpy_transport_talks_to_cyclone_transport(domain_id):
    from benchbot_robot_ros2.transport import RclpyTransport

    r, c = RclpyTransport(domain_id, "loopback"), CycloneTransport(domain_id, "loopback")
    got, ev = [], threading.Event()
    c.subscribe("/t/rclpy", "geometry_msgs/msg/Twist", lambda m: (got.append(m), ev.set()))
    pub = r.publisher("/t/rclpy", "geometry_msgs/msg/Twist")
    for _ in range(100):
        pub.publish(convert.fill_twist(r.message("geometry_msgs/msg/Twist"), 0.5, 0.1))
        if ev.wait(0.1):
            break
    r.close(), c.close()
    assert got and got[0].linear.x == 0.5


@pytest.mark.slow
def test_plugin_contract_and_command(benchbot_contract):
    import subprocess
    import sys

    import benchbot_robot_ros2.plugin as plugin

    benchbot_contract.check_content_plugin(plugin)
    proc = subprocess.run([sys.executable, "-m", "benchbot.cli", "ros2", "serve-sim", "--help"], capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 0 and "--env" in proc.stdout, proc.stderr


@pytest.mark.slow
def test_close_while_a_callback_runs_returns(domain_id):
    """Closing a transport while a subscriber's callback is running returns once the callback is done. Before, the
    listener thread held the last reference to its reader and deleted it from inside its own callback, and
    closing hung for ever."""
    tr = CycloneTransport(domain_id + 7, "loopback")
    running, release = threading.Event(), threading.Event()

    def slow(_msg):
        running.set()
        release.wait(5.0)

    tr.subscribe("/close_test", "std_msgs/msg/String", slow, reliable=True)
    pub = tr.publisher("/close_test", "std_msgs/msg/String")
    msg = tr.message("std_msgs/msg/String")
    msg.data = "x"
    deadline = time.monotonic() + 20.0
    while not running.is_set() and time.monotonic() < deadline:
        pub.publish(msg)
        running.wait(0.05)
    assert running.is_set(), "the callback never ran"
    del pub
    closer = threading.Thread(target=tr.close, daemon=True)
    closer.start()
    time.sleep(0.3)  # close is now waiting for the callback in progress
    release.set()
    closer.join(20.0)
    assert not closer.is_alive(), "close() hung while a callback was running"
