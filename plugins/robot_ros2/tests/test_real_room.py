"""The same solution file, scored in simulation and on a real robot: the example room pack that ships with
the plugin (``benchbot ros2 example-room``: ``example_room:1``, type ``real``, and its simulated twin
``example_room_sim:1``) is installed; one solution follows the room's trajectory and reports a chair-sized cuboid
1.5 m ahead of every pose it saw; ``benchbot batch`` scores it on ``carter`` in the twin and on the unchanged
``turtlebot4`` in the real room, driving a stand-in TurtleBot 4 written with real rclpy (Fast DDS on loopback):
its OAK-D topics, RPLIDAR scan of the room's walls, odometry, and TF (through a Cyclone DDS participant: the PyPI
wheels have no tf2_msgs). Both runs score alike; the real robot's manifest and recording say ``clock: wall``.

Marked ``rclpy`` (``.ci/ros2`` runs it in its Python 3.12 environment with the ros-jazzy wheels) and ``slow``.
"""

from __future__ import annotations

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

from benchbot_robot_ros2.transport import rclpy_available

pytestmark = [pytest.mark.rclpy, pytest.mark.slow,
              pytest.mark.skipif(not rclpy_available(), reason="rclpy is not importable (no ROS 2 Jazzy here)")]

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]

#: Follows the passive trajectory; checks the observations' structure; reports a chair 1.5 m ahead of each pose.
SOLUTION = '''
import json
import math
import numpy as np
from benchbot_api import ActionResult, Agent, BenchBot

class Ahead(Agent):
    def __init__(self):
        self.poses = []
    def is_done(self, action_result):
        return action_result != ActionResult.SUCCESS
    def pick_action(self, observations, action_list):
        rgb, depth, laser = observations["image_rgb"], observations["image_depth"], observations["laser"]
        assert rgb.dtype == np.uint8 and rgb.ndim == 3 and rgb.shape[2] == 3, rgb.shape
        assert depth.dtype == np.float32 and depth.shape == rgb.shape[:2], (depth.dtype, depth.shape)
        assert laser["scans"].shape[1] == 2 and np.isfinite(laser["scans"]).all()
        assert observations["image_rgb_info"]["matrix_intrinsics"].shape == (3, 3)
        robot = observations["poses"]["robot"]
        self.poses.append([float(robot["translation_xyz"][0]), float(robot["translation_xyz"][1]),
                           float(robot["rotation_rpy"][2])])
        return "move_next", {}
    def save_result(self, filename, empty_results, results_format_fns):
        results = empty_results["results"]
        chair = results["class_list"].index("chair")
        for x, y, yaw in self.poses:
            obj = results_format_fns["create_object"]()
            probs = [0.0] * len(results["class_list"])
            probs[chair] = 1.0
            obj.update(label_probs=probs, centroid=[x + 1.5 * math.cos(yaw), y + 1.5 * math.sin(yaw), 0.45],
                       extent=[0.45, 0.45, 0.9])
            results["objects"].append(obj)
        with open(filename, "w") as f:
            json.dump(empty_results, f)
        print("poses", json.dumps(self.poses), flush=True)

BenchBot(agent=Ahead()).run()
'''

#: The example room's walls (map frame, m): the stand-in's laser sees them.
ROOM = (-1.0, 3.0, -1.5, 1.5)


def wall_ranges(x: float, y: float, yaw: float, angles: np.ndarray) -> np.ndarray:
    """Distances (m) from ``(x, y)`` along ``yaw + angles`` to the walls of :data:`ROOM`."""
    x0, x1, y0, y1 = ROOM
    c, s = np.cos(yaw + angles), np.sin(yaw + angles)
    with np.errstate(divide="ignore", invalid="ignore"):
        tx = np.where(c > 1e-9, (x1 - x) / c, np.where(c < -1e-9, (x0 - x) / c, np.inf))
        ty = np.where(s > 1e-9, (y1 - y) / s, np.where(s < -1e-9, (y0 - y) / s, np.inf))
    return np.minimum(tx, ty)


class StandInTurtleBot4:
    """A TurtleBot 4 stand-in: an rclpy node publishing what ``turtlebot4.yaml`` subscribes to, under its topic and
    frame names, with wall-clock stamps, and obeying ``/cmd_vel`` (stopping when no command came for 0.5 s), at
    ``time_scale`` times real time (the backend runs at ``BENCHBOT_ROS2_TIME_SCALE``, so the test is short). Its
    camera sees a grey room 1.5 m deep; its laser the room's walls. ``/tf`` and ``/tf_static`` go through a Cyclone
    DDS participant (the PyPI wheels have no tf2_msgs)."""

    def __init__(self, domain_id: int, time_scale: float) -> None:
        import rclpy
        from geometry_msgs.msg import Twist
        from nav_msgs.msg import Odometry
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import qos_profile_sensor_data
        from sensor_msgs.msg import CameraInfo, Image, LaserScan

        from benchbot_robot_ros2.transport import CycloneTransport

        self.rclpy, self.time_scale = rclpy, time_scale
        self.Image, self.CameraInfo, self.LaserScan, self.Odometry = Image, CameraInfo, LaserScan, Odometry
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        self.node = rclpy.create_node("turtlebot4_stand_in", context=self.context)
        sensor = qos_profile_sensor_data
        self.pub = {
            "rgb": self.node.create_publisher(Image, "/oakd/rgb/preview/image_raw", sensor),
            "rgb_info": self.node.create_publisher(CameraInfo, "/oakd/rgb/preview/camera_info", sensor),
            "depth": self.node.create_publisher(Image, "/oakd/stereo/image_raw", sensor),
            "depth_info": self.node.create_publisher(CameraInfo, "/oakd/stereo/camera_info", sensor),
            "scan": self.node.create_publisher(LaserScan, "/scan", sensor),
            "odom": self.node.create_publisher(Odometry, "/odom", 10),
        }
        self.node.create_subscription(Twist, "/cmd_vel", self._on_cmd, 10)
        self.tf_side = CycloneTransport(domain_id, "loopback", node_name="turtlebot4_stand_in_tf")
        self.tf_pub = self.tf_side.publisher("/tf", "tf2_msgs/msg/TFMessage")
        self.tf_static = self.tf_side.publisher("/tf_static", "tf2_msgs/msg/TFMessage", latched=True)
        self.pose = np.zeros(3)  # example_room:1's start pose: the origin of map, facing +x
        self.cmd, self.cmd_at, self.ticks, self.last = (0.0, 0.0), -math.inf, 0, time.monotonic()
        self.lock = threading.Lock()
        self._publish_static()
        self.node.create_timer(1.0 / 30.0, self._tick)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.stopping = threading.Event()
        self.thread.start()

    def _spin(self) -> None:
        while not self.stopping.is_set():
            self.executor.spin_once(timeout_sec=0.05)

    def _on_cmd(self, msg) -> None:
        with self.lock:
            self.cmd, self.cmd_at = (float(msg.linear.x), float(msg.angular.z)), time.monotonic()

    def _stamp(self, header, frame: str) -> None:
        t = time.time_ns()
        header.stamp.sec, header.stamp.nanosec = t // 1_000_000_000, t % 1_000_000_000
        header.frame_id = frame

    def _transform(self, parent: str, child: str, T: np.ndarray):
        from benchbot_robot_ros2 import convert

        ts = self.tf_side.message("geometry_msgs/msg/TransformStamped")
        self._stamp(ts.header, parent)
        ts.child_frame_id = child
        convert.fill_transform(ts.transform, T)
        return ts

    def _publish_static(self) -> None:
        camera = np.eye(4)  # the OAK-D's optical frame: z forward, x right, y down
        camera[:3, :3] = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]]
        camera[:3, 3] = [0.06, 0.0, 0.25]
        lidar = np.eye(4)
        lidar[2, 3] = 0.2
        msg = self.tf_side.message("tf2_msgs/msg/TFMessage")
        msg.transforms = [self._transform("base_link", "oakd_rgb_camera_optical_frame", camera),
                          self._transform("base_link", "rplidar_link", lidar)]
        self.tf_static.publish(msg)

    def _camera_info(self):
        info = self.CameraInfo()
        self._stamp(info.header, "oakd_rgb_camera_optical_frame")
        info.height, info.width, info.distortion_model = 48, 64, "plumb_bob"
        info.k = [50.0, 0.0, 32.0, 0.0, 50.0, 24.0, 0.0, 0.0, 1.0]
        info.p = [50.0, 0.0, 32.0, 0.0, 0.0, 50.0, 24.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        return info

    def _tick(self) -> None:
        from benchbot.core.geometry import se2_to_matrix
        from benchbot.core.motion import integrate_unicycle
        from benchbot_robot_ros2 import convert

        now = time.monotonic()
        dt, self.last = min(now - self.last, 0.2) * self.time_scale, now
        with self.lock:
            v, w = self.cmd if now - self.cmd_at < 0.5 / self.time_scale else (0.0, 0.0)
        self.pose = integrate_unicycle(self.pose, v, w, dt)
        T = se2_to_matrix(*self.pose)
        odom = self.Odometry()
        self._stamp(odom.header, "odom")
        odom.child_frame_id = "base_link"
        convert.fill_pose(odom.pose.pose, T)
        odom.twist.twist.linear.x, odom.twist.twist.angular.z = v, w
        self.pub["odom"].publish(odom)
        tf = self.tf_side.message("tf2_msgs/msg/TFMessage")
        tf.transforms = [self._transform("map", "odom", np.eye(4)), self._transform("odom", "base_link", T)]
        self.tf_pub.publish(tf)
        scan = self.LaserScan()
        self._stamp(scan.header, "rplidar_link")
        angles = -math.pi + np.arange(360) * (2 * math.pi / 360)
        scan.angle_min, scan.angle_increment = -math.pi, 2 * math.pi / 360
        scan.angle_max = scan.angle_min + 359 * scan.angle_increment
        scan.range_min, scan.range_max = 0.15, 12.0
        scan.ranges = wall_ranges(*self.pose, angles).astype(np.float32).tolist()
        self.pub["scan"].publish(scan)
        self.ticks += 1
        if self.ticks % 3 == 0:  # the camera at 10 Hz
            rgb = self.Image()
            self._stamp(rgb.header, "oakd_rgb_camera_optical_frame")
            rgb.height, rgb.width, rgb.encoding, rgb.step = 48, 64, "rgb8", 64 * 3
            rgb.data = np.full((48, 64, 3), 128, np.uint8).tobytes()
            depth = self.Image()
            self._stamp(depth.header, "oakd_rgb_camera_optical_frame")
            depth.height, depth.width, depth.encoding, depth.step = 48, 64, "16UC1", 64 * 2
            depth.data = np.full((48, 64), 1500, np.uint16).tobytes()
            self.pub["rgb"].publish(rgb)
            self.pub["depth"].publish(depth)
            self.pub["rgb_info"].publish(self._camera_info())
            self.pub["depth_info"].publish(self._camera_info())

    def close(self) -> None:
        self.stopping.set()
        self.thread.join(5)
        self.executor.shutdown()
        self.node.destroy_node()
        self.rclpy.shutdown(context=self.context)
        self.tf_side.close()


def _batch(tmp_path: Path, env: dict, robot: str, envs: str, *extra: str) -> tuple[dict, Path, str]:
    """``benchbot batch`` of the solution; its JSON outcome, run directory and the episode's log."""
    proc = subprocess.run([*BENCHBOT, "batch", "--native", "python solution.py", "--envs", envs, "--robot", robot,
                           "--task", "semantic_slam:passive:ground_truth", "--no-tui", "--json", "--output-dir",
                           str(tmp_path / "runs"), "--prefix", robot, *extra],
                          cwd=tmp_path / "solution", env=env, capture_output=True, text=True, timeout=600)
    assert proc.stdout.strip(), proc.stderr[-3000:]
    result = json.loads(proc.stdout)
    run_dir = Path(result["run_dir"])
    episode = result["episodes"][0]
    log = (run_dir / episode["log"]).read_text()
    assert episode["status"] == "ok", (f"{episode['status']}: {episode.get('error')}\n--- episode log:\n{log[-3000:]}"
                                       f"\n--- stderr:\n{proc.stderr[-3000:]}")
    return result, run_dir, log


def _poses(log: str) -> list[list[float]]:
    return json.loads(next(line for line in log.splitlines() if line.startswith("poses "))[6:])


def test_one_solution_scored_in_the_simulated_twin_and_on_a_stand_in_turtlebot4(tmp_path, domain_id):
    from benchbot.packs.content_packs import install_pack
    from benchbot.core.registry import Registry
    from benchbot_robot_ros2.plugin import EXAMPLE_ROOM
    from benchbot_robot_ros2.transport import FASTDDS_LOOPBACK_PROFILE, LOOPBACK_URI

    dom = domain_id + 15
    time_scale = 4.0
    data = tmp_path / "data"
    env = dict(os.environ, BENCHBOT_DATA_DIR=str(data), ROS_DOMAIN_ID=str(dom), COLUMNS="200",
               BENCHBOT_ROS2_TIME_SCALE=str(time_scale), CYCLONEDDS_URI=LOOPBACK_URI,
               FASTRTPS_DEFAULT_PROFILES_FILE=str(FASTDDS_LOOPBACK_PROFILE))
    proc = subprocess.run([*BENCHBOT, "ros2", "example-room", str(tmp_path / "my_room")], env=env,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    saved = os.environ.get("BENCHBOT_DATA_DIR")
    os.environ["BENCHBOT_DATA_DIR"] = str(data)
    try:
        install_pack(tmp_path / "my_room", registry=Registry())
    finally:
        if saved is None:
            os.environ.pop("BENCHBOT_DATA_DIR")
        else:
            os.environ["BENCHBOT_DATA_DIR"] = saved
    assert sorted(p.name for p in (tmp_path / "my_room").rglob("*.*")) == sorted(
        p.name for p in EXAMPLE_ROOM.rglob("*.*") if "__pycache__" not in p.parts)
    (tmp_path / "solution").mkdir()
    (tmp_path / "solution" / "solution.py").write_text(SOLUTION)

    t0 = time.monotonic()
    sim, sim_dir, sim_log = _batch(tmp_path, env, "carter", "example_room_sim:1", "--camera-size", "64x48")
    sim_s = time.monotonic() - t0
    stand_in = StandInTurtleBot4(dom, time_scale)
    try:
        t0 = time.monotonic()
        real, real_dir, real_log = _batch(tmp_path, env, "turtlebot4", "example_room:1", "--record")
        real_s = time.monotonic() - t0
    finally:
        stand_in.close()

    # the same trajectory was followed: start, then the room's first two poses (the third ends the episode)
    expected = [[0.0, 0.0, 0.0], [0.6, 0.0, 0.0], [0.6, 0.0, math.pi / 2]]
    for log in (sim_log, real_log):
        np.testing.assert_allclose(_poses(log), expected, atol=0.03)
    assert abs(stand_in.pose[0] - 0.6) < 0.03 and abs(stand_in.pose[1] - 0.3) < 0.03  # and the last one
    # scored alike: the chair 1.5 m ahead of the second pose overlaps the room's chair
    scores = [json.loads((d / "scores.json").read_text()) for d in (sim_dir, real_dir)]
    omq = [s["scores"]["OMQ"] for s in scores]
    print(f"carter in example_room_sim:1: {sim_s:.1f} s, OMQ {omq[0]}; turtlebot4 (stand-in) in example_room:1: "
          f"{real_s:.1f} s, OMQ {omq[1]}")
    assert all(isinstance(x, float) for x in omq), scores
    assert omq[0] > 0 and omq[1] == pytest.approx(omq[0], abs=0.02)
    # a real robot's clock is the wall clock: in the manifest and in the recording
    clocks = [json.loads((d / "manifest.json").read_text())["episodes"][0]["backend"]["clock"]
              for d in (sim_dir, real_dir)]
    assert clocks == ["simulated", "wall"]
    from mcap.reader import make_reader

    recordings = sorted(real_dir.rglob("*.mcap"))
    assert len(recordings) == 1
    with open(recordings[0], "rb") as f:
        meta = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    assert json.loads(meta["benchbot.clock"]["json"])["clock"] == "wall"
