"""ROS 2 conventions of ``benchbot ros2 serve-sim`` (the simulator in a subprocess, on loopback DDS), checked with
independent readers: raw CDR samples decoded by rosbags (ROS 2 Jazzy's definitions), DDS discovery through the
built-in topics, recordings read with rosbags' MCAP reader.

The bridge serves a copy of ``carter_ros2`` whose frames are renamed (as a real robot's would be), with its laser's
range shortened to 1.5 m and 20 % of the depth pixels dropped, so that "no return" and "no hit" occur in a closed
room."""

from __future__ import annotations

import copy
import json
import math
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from benchbot.core.registry import get_registry

sys.path.insert(0, str(Path(__file__).parent))
from ros2_independent import RawListener, discovered  # noqa: E402

#: These tests run in a fresh interpreter (``test_sim_conventions_process.py`` starts it with this variable set):
#: after the rest of the suite in one process, this process's DDS listeners heard nothing from the bridge in three
#: full runs out of three, while the module alone passes every time (cause not found).
CHILD_VARIABLE = "BENCHBOT_ROS2_CONVENTIONS_CHILD"
pytestmark = pytest.mark.skipif(os.environ.get(CHILD_VARIABLE) != "1",
                                reason="run in a fresh process by test_sim_conventions_process.py")

FRAMES = {"robot": "base_link", "camera": "front_camera_color_optical_frame", "lidar": "front_laser"}
RANGE_MAX = 1.5
TIME_SCALE = 4.0

_SCRIPT = """
import json, sys
from benchbot_robot_ros2.sim_bridge import SimBridge
bridge = SimBridge("miniroom:4", width=64, height=48, arch="cpu", time_scale=float(sys.argv[2]),
                   transport="cyclonedds", domain_id=int(sys.argv[1]), ros_robot=json.loads(sys.argv[3]))
bridge.sim.range_max = float(sys.argv[4])            # a short-range laser: beams beyond it have no return
bridge.sim.noise["depth_dropout"] = 0.2              # depth pixels without a measurement
bridge.run()
"""


def _spec() -> dict:
    spec = copy.deepcopy(get_registry().get("robots", "carter_ros2"))
    spec["name"] = "carter_ros2_renamed"
    spec["ros2"]["frames"] = dict(FRAMES)
    return spec


@pytest.fixture(scope="module")
def bridge(domain_id):
    """The bridge on its own domain; yields the domain id."""
    dom = domain_id + 5
    env = dict(os.environ, CYCLONEDDS_URI=os.environ["CYCLONEDDS_URI"])
    log_path = Path(os.environ.get("TMPDIR", "/tmp")) / f"benchbot_conventions_{dom}.log"
    log = open(log_path, "w")
    proc = subprocess.Popen([sys.executable, "-X", "faulthandler", "-c", _SCRIPT, str(dom), str(TIME_SCALE),
                             json.dumps(_spec()), str(RANGE_MAX)], env=env, stdout=log, stderr=subprocess.STDOUT)
    odom = RawListener(dom, "/odom", "nav_msgs/msg/Odometry")
    try:
        odom.wait(lambda ms: len(ms) > 0, timeout=180)  # Taichi compiles its kernels first
    except AssertionError as exc:
        state = f"exited with {proc.returncode}" if proc.poll() is not None else "still running"
        if proc.poll() is None:  # where it is stuck: faulthandler prints every thread's stack on SIGABRT
            import signal

            proc.send_signal(signal.SIGABRT)
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                pass
        proc.kill()
        raise AssertionError(f"{exc}; the bridge (domain {dom}) {state}; its log:\n"
                             f"{log_path.read_text(errors='replace')[-3000:]}") from None
    finally:
        odom.close()
    yield dom
    proc.terminate()
    try:
        proc.wait(10)
    except subprocess.TimeoutExpired:
        proc.kill()
    log.close()


class _Driver:
    """Publishes a Twist at 20 Hz (wall) from a thread until stopped."""

    def __init__(self, dom: int, v: float, w: float) -> None:
        from benchbot_robot_ros2 import convert
        from benchbot_robot_ros2.transport import CycloneTransport

        self.tr = CycloneTransport(dom, "loopback", node_name="test_teleop")
        self.pub = self.tr.publisher("/cmd_vel", "geometry_msgs/msg/Twist")
        self.msg = convert.fill_twist(self.tr.message("geometry_msgs/msg/Twist"), v, w)
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        while not self.stop.is_set():
            self.pub.publish(self.msg)
            time.sleep(0.05)

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.thread.join(2)
        self.tr.close()


def _reset(dom: int) -> None:
    from benchbot_robot_ros2.transport import CycloneTransport

    tr = CycloneTransport(dom, "loopback", node_name="test_reset")
    done = threading.Event()
    tr.subscribe("/benchbot/reset_done", "std_msgs/msg/String",
                 lambda m: json.loads(m.data).get("id") == "t" and done.set(), reliable=True)
    pub = tr.publisher("/benchbot/reset", "std_msgs/msg/String")
    msg = tr.message("std_msgs/msg/String")
    msg.data = json.dumps({"id": "t"})
    deadline = time.monotonic() + 60
    while not done.is_set() and time.monotonic() < deadline:
        pub.publish(msg)
        done.wait(1.0)
    tr.close()
    assert done.is_set(), "the bridge did not answer the reset"


def _t(stamp) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def _pose(m) -> tuple:
    p, q = m.pose.pose.position, m.pose.pose.orientation
    return (p.x, p.y, q.z, q.w)


def _yaw(q) -> float:
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


def test_one_frame_name_everywhere(bridge):
    """Images, camera infos and the scan name the definition's frames; /tf_static links them to the base and /tf
    the base to map, so a viewer can project the camera."""
    names = {k: RawListener(bridge, *k) for k in [("/camera/color/image_raw", "sensor_msgs/msg/Image"),
                                                  ("/camera/depth/image_raw", "sensor_msgs/msg/Image"),
                                                  ("/camera/color/camera_info", "sensor_msgs/msg/CameraInfo"),
                                                  ("/camera/depth/camera_info", "sensor_msgs/msg/CameraInfo"),
                                                  ("/scan", "sensor_msgs/msg/LaserScan"),
                                                  ("/odom", "nav_msgs/msg/Odometry"),
                                                  ("/tf", "tf2_msgs/msg/TFMessage")]}
    static = RawListener(bridge, "/tf_static", "tf2_msgs/msg/TFMessage", latched=True)
    try:
        got = {k[0]: r.wait(lambda ms: len(ms) > 0)[-1] for k, r in names.items()}
        edges = {t.child_frame_id: t.header.frame_id for m in static.wait(lambda ms: len(ms) > 0)
                 for t in m.transforms}
        edges.update({t.child_frame_id: t.header.frame_id for t in got["/tf"].transforms})
    finally:
        for r in [*names.values(), static]:
            r.close()
    for topic in ("/camera/color/image_raw", "/camera/depth/image_raw", "/camera/color/camera_info",
                  "/camera/depth/camera_info"):
        assert got[topic].header.frame_id == FRAMES["camera"], topic
    assert got["/scan"].header.frame_id == FRAMES["lidar"]
    assert (got["/odom"].header.frame_id, got["/odom"].child_frame_id) == ("odom", FRAMES["robot"])
    assert edges == {FRAMES["camera"]: FRAMES["robot"], FRAMES["lidar"]: FRAMES["robot"], FRAMES["robot"]: "odom",
                     "odom": "map"}


def test_laser_follows_rep117_and_keeps_angles_in_range(bridge):
    scan = RawListener(bridge, "/scan", "sensor_msgs/msg/LaserScan")
    try:
        msg = scan.wait(lambda ms: len(ms) > 0)[-1]
    finally:
        scan.close()
    ranges = np.asarray(msg.ranges)
    assert ranges.dtype == np.float32 and ranges.size == 360
    assert np.float32(msg.angle_min) == np.float32(-math.pi)
    assert -math.pi - 1e-6 < msg.angle_max < math.pi and msg.angle_max == pytest.approx(math.pi - 2 * math.pi / 360)
    assert msg.range_max == np.float32(RANGE_MAX)
    no_return = np.isposinf(ranges)
    assert no_return.any() and (~no_return).any()  # the room has walls within 1.5 m and beyond it
    assert np.all(ranges[~no_return] < RANGE_MAX) and not np.isnan(ranges).any()


def test_depth_follows_rep118(bridge):
    depth = RawListener(bridge, "/camera/depth/image_raw", "sensor_msgs/msg/Image")
    try:
        msg = depth.wait(lambda ms: len(ms) > 0)[-1]
    finally:
        depth.close()
    assert msg.encoding == "32FC1" and msg.is_bigendian == 0
    d = np.frombuffer(bytes(msg.data), dtype="<f4").reshape(msg.height, msg.width)
    assert np.isnan(d).mean() > 0.1  # the dropped pixels: NaN, not 0.0
    assert np.all(d[~np.isnan(d)] > 0)


def test_clock_and_stamps_are_simulated_time(bridge):
    """/clock is published; every stamp is one of its times; odometry differentiated over its stamps gives the
    commanded yaw rate (wall-clock stamps made it time_scale times slower)."""
    clock = RawListener(bridge, "/clock", "rosgraph_msgs/msg/Clock")
    odom = RawListener(bridge, "/odom", "nav_msgs/msg/Odometry")
    try:
        with _Driver(bridge, 0.0, 0.5):
            time.sleep(0.5)
            odom.messages.clear()
            odoms = odom.wait(lambda ms: sum(m.twist.twist.angular.z == 0.5 for m in ms) >= 30)
        clocks = {_t(m.clock) for _, m in clock.messages}
    finally:
        clock.close()
        odom.close()
    turning = [m for m in odoms if m.twist.twist.angular.z == 0.5]
    assert all(_t(m.header.stamp) in clocks for m in turning)
    assert abs(_t(turning[0].header.stamp) - time.time_ns()) < 3600e9  # a real epoch, not 1970
    a, b = turning[0], turning[-1]
    dt = (_t(b.header.stamp) - _t(a.header.stamp)) * 1e-9
    dyaw = np.unwrap([_yaw(m.pose.pose.orientation) for m in turning])
    # the pose of a message is after its tick's motion: len - 1 ticks between the first and the last
    assert dt == pytest.approx(0.05 * (len(turning) - 1), abs=1e-6)
    assert (dyaw[-1] - dyaw[0]) / dt == pytest.approx(0.5, rel=1e-6)


def test_odom_twist_is_the_motion_made(bridge):
    """Driving into a wall: once the bridge refuses the steps, the pose stays and the twist says 0 while the
    command still says 0.5 m/s."""
    _reset(bridge)
    odom = RawListener(bridge, "/odom", "nav_msgs/msg/Odometry")
    try:
        with _Driver(bridge, 0.5, 0.0):
            def blocked(ms):  # eleven messages at one pose, after having moved
                tail = ms[-11:]
                return (any(m.twist.twist.linear.x for m in ms) and len(tail) == 11
                        and len({_pose(m) for m in tail}) == 1)
            msgs = odom.wait(blocked, timeout=90)
    finally:
        odom.close()
        _reset(bridge)
    trace = [(_pose(m), m.twist.twist.linear.x, m.twist.twist.angular.z) for m in msgs]
    moving = [m for m in msgs if m.twist.twist.linear.x != 0.0]
    assert all(m.twist.twist.linear.x == 0.5 for m in moving), trace
    # the first message at the final pose is the tick that moved there; in the ten after it the step was refused
    assert all(m.twist.twist.linear.x == 0.0 and m.twist.twist.angular.z == 0.0 for m in msgs[-10:]), trace[-12:]


def test_the_bridge_is_a_ros_node(bridge):
    info = RawListener(bridge, "ros_discovery_info", "rmw_dds_common/msg/ParticipantEntitiesInfo", latched=True,
                       dds_name=True)
    try:
        msgs = info.wait(lambda ms: any(n.node_name == "benchbot_sim" for m in ms for n in m.node_entities_info_seq))
        graph = discovered(bridge)
    finally:
        info.close()
    (entry,) = [m for m in msgs if any(n.node_name == "benchbot_sim" for n in m.node_entities_info_seq)][-1:]
    participant = bytes(entry.gid.data)
    assert graph["participants"][participant] == b"enclave=/;"
    topics = {p["topic"]: p for p in graph["publications"] if p["participant"] == participant}
    assert {"rt/clock", "rt/scan", "rt/odom", "rt/tf", "rt/tf_static", "rt/camera/color/image_raw"} <= set(topics)
    writers = {bytes(g.data) for g in entry.node_entities_info_seq[0].writer_gid_seq}
    assert {p["gid"] for t, p in topics.items() if t != "ros_discovery_info"} == writers
    assert all(p["user_data"].startswith(b"typehash=RIHS01_") for p in topics.values())


def test_recording_from_a_ros2_robot_names_its_frames(bridge, monkeypatch, tmp_path):
    """An episode of the renamed robot recorded through ROS 2: the images, camera infos and scans carry the robot's
    TF frames, which /tf (map → base) and /tf_static (base → sensors) name; the scan starts at -π; the recording
    replays with the robot's own camera frame id."""
    import dataclasses

    from rosbags.rosbag2 import Reader

    from benchbot.api.benchbot import BenchBot
    from benchbot.core.session import resolve_run, start_service
    from benchbot.plugins.recorder import attach_recorder, detach_recorder
    from benchbot.plugins.replay import start_replay_service
    from ros2_independent import TYPESTORE

    monkeypatch.setenv("BENCHBOT_ROS2_TIME_SCALE", str(TIME_SCALE))
    reg = get_registry()
    run = dataclasses.replace(resolve_run(reg, "semantic_slam:passive:ground_truth", "carter_ros2", "miniroom:4"),
                              robot=_spec())
    options = {"ros2_domain_id": bridge}
    path = tmp_path / "ros2.mcap"
    service = start_service(reg, run, seed=0, options=options)
    try:
        recorder = attach_recorder(reg, service, run, path, seed=0, options=options)
        bot = BenchBot(backend=service)
        observations = [bot.reset()[0]] + [bot.step("move_next")[0] for _ in range(2)]
        detach_recorder(reg, service, recorder)
    finally:
        service.close()
    assert observations[-1]["image_rgb_info"]["frame_id"] == FRAMES["camera"]  # the robot's, passed through
    messages: dict = {}
    with Reader(path) as reader:
        for conn, _, raw in reader.messages():
            messages.setdefault(conn.topic, []).append(TYPESTORE.deserialize_cdr(raw, conn.msgtype))
    for topic in ("/camera/color/image_raw", "/camera/depth/image_raw", "/camera/color/camera_info",
                  "/camera/depth/camera_info"):
        assert {m.header.frame_id for m in messages[topic]} == {FRAMES["camera"]}, topic
    assert {m.header.frame_id for m in messages["/scan"]} == {FRAMES["lidar"]}
    assert all(np.float32(m.angle_min) == np.float32(-math.pi) and m.angle_max < math.pi for m in messages["/scan"])
    assert {(t.header.frame_id, t.child_frame_id) for m in messages["/tf"] for t in m.transforms} == \
        {("map", FRAMES["robot"])}
    assert {(t.header.frame_id, t.child_frame_id) for m in messages["/tf_static"] for t in m.transforms} == \
        {(FRAMES["robot"], FRAMES["camera"]), (FRAMES["robot"], FRAMES["lidar"])}
    replay, _ = start_replay_service(path, reg)
    try:
        bot = BenchBot(backend=replay)
        first, _ = bot.reset()
        assert first["image_rgb_info"]["frame_id"] == FRAMES["camera"]
        np.testing.assert_allclose(first["poses"]["camera"]["translation_xyz"],
                                   observations[0]["poses"]["camera"]["translation_xyz"], atol=1e-9)
    finally:
        replay.close()
