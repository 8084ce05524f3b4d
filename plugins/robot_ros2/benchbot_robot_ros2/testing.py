"""Test helpers: a fake ROS 2 robot (odometry, TF and a laser seeing one wall; obeys /cmd_vel) and a robot spec for
it. Used by the plugin's tests; handy for testing a solution's ROS 2 path without a robot."""

from __future__ import annotations

import math
import threading
import time

import numpy as np


class FakeRobot:
    """A ROS 2 robot in a thread: integrates /cmd_vel (unicycle, 50 Hz), publishes /odom, /tf (map→odom→base_link),
    /tf_static (base_link→lidar at the base) and /scan seeing a wall x = ``wall_x`` (map frame, if given).
    ``silence`` holds topic names not to publish; ``cmds`` records every (wall time, v, w) received. Every message
    is stamped with the wall clock (``time.time()``). ``cmd_timeout_s``: stop when no /cmd_vel came for that long
    (s), as robot bases do (None: keep the last command for ever)."""

    def __init__(self, transport, wall_x: float | None = None, cmd_timeout_s: float | None = None) -> None:
        from benchbot_robot_ros2 import convert

        self.c, self.tr, self.wall_x = convert, transport, wall_x
        self.pose = np.zeros(3)
        self.cmd = (0.0, 0.0)
        self.cmd_timeout_s = cmd_timeout_s
        self.cmds: list[tuple[float, float, float]] = []
        self.silence: set[str] = set()
        self.stop_event = threading.Event()
        self.pub = {n: transport.publisher(t, ty) for n, t, ty in [
            ("odom", "/odom", "nav_msgs/msg/Odometry"), ("tf", "/tf", "tf2_msgs/msg/TFMessage"),
            ("scan", "/scan", "sensor_msgs/msg/LaserScan")]}
        self.pub["tf_static"] = transport.publisher("/tf_static", "tf2_msgs/msg/TFMessage", latched=True)
        transport.subscribe("/cmd_vel", "geometry_msgs/msg/Twist", self._on_cmd, reliable=True)
        self.thread = threading.Thread(target=self._run, daemon=True)

    def _on_cmd(self, msg) -> None:
        self.cmd = (float(msg.linear.x), float(msg.angular.z))
        self.cmds.append((time.monotonic(), *self.cmd))

    def _tf(self, parent, child, T):
        ts = self.tr.message("geometry_msgs/msg/TransformStamped")
        self.c.set_stamp(ts.header.stamp)
        ts.header.frame_id, ts.child_frame_id = parent, child
        self.c.fill_transform(ts.transform, T)
        return ts

    def _run(self) -> None:
        from benchbot.core.geometry import se2_to_matrix
        from benchbot.core.motion import integrate_unicycle

        static = self.tr.message("tf2_msgs/msg/TFMessage")
        static.transforms = [self._tf("base_link", "lidar", np.eye(4))]
        self.pub["tf_static"].publish(static)
        angles = np.linspace(-math.pi, math.pi, 360, endpoint=False)
        while not self.stop_event.is_set():
            timeout = self.cmd_timeout_s
            if timeout is not None and self.cmds and time.monotonic() - self.cmds[-1][0] > timeout:
                self.cmd = (0.0, 0.0)
            self.pose = integrate_unicycle(self.pose, *self.cmd, 0.02)
            T = se2_to_matrix(*self.pose)
            if "odom" not in self.silence:
                odom = self.tr.message("nav_msgs/msg/Odometry")
                self.c.set_stamp(odom.header.stamp)
                odom.header.frame_id, odom.child_frame_id = "odom", "base_link"
                self.c.fill_pose(odom.pose.pose, T)
                self.pub["odom"].publish(odom)
            if "tf" not in self.silence:
                tf = self.tr.message("tf2_msgs/msg/TFMessage")
                tf.transforms = [self._tf("map", "odom", np.eye(4)), self._tf("odom", "base_link", T)]
                self.pub["tf"].publish(tf)
            if "scan" not in self.silence:
                world = angles + self.pose[2]
                with np.errstate(divide="ignore", invalid="ignore"):
                    r = np.where(np.cos(world) > 1e-6, (self.wall_x - self.pose[0]) / np.cos(world), np.inf) \
                        if self.wall_x is not None else np.full(360, np.inf)
                r = np.where(np.isfinite(r) & (r > 0), r, 20.0)
                self.pub["scan"].publish(self.c.fill_laser(self.tr.message("sensor_msgs/msg/LaserScan"), r, -math.pi,
                                                           2 * math.pi / 360, 0.1, 20.0, "lidar", time.time()))
            time.sleep(0.02)

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.stop_event.set()
        self.thread.join(2)


FAKE_SPEC = {
    "name": "fake_ros2", "type": "ros2", "global_frame": "map", "robot_frame": "robot",
    "poses": ["lidar", "robot", "initial_pose"], "actions": ["move_distance", "move_angle"],
    "observations": ["laser", "poses"],
    "connections": {
        "move_distance": {"connection": "api_to_ros", "ros_topic": "/cmd_vel", "ros_type": "geometry_msgs/msg/Twist"},
        "move_angle": {"connection": "api_to_ros", "ros_topic": "/cmd_vel", "ros_type": "geometry_msgs/msg/Twist"},
        "laser": {"connection": "ros_to_api", "ros_topic": "/scan", "ros_type": "sensor_msgs/msg/LaserScan"},
        "poses": {"connection": "ros_to_api"},
    },
    "ros2": {"transport": "cyclonedds", "network": "loopback", "frames": {"lidar": "lidar"}, "reset": "drive",
             "sensor_timeout_s": 0.3, "startup_timeout_s": 10, "safety_distance_m": 0.1, "footprint_radius_m": 0.25},
}
