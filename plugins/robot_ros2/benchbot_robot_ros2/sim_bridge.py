"""The Taichi simulator served as a ROS 2 robot (``benchbot ros2 serve-sim --env ENV``).

Runs the ``carter`` robot of ``benchbot_sim_taichi`` in one environment and, over ROS 2 (rclpy or Cyclone DDS):

=============================  ==============================  ==============================================
topic                          type                            content
=============================  ==============================  ==============================================
``/camera/color/image_raw``    ``sensor_msgs/msg/Image``       ``rgb8``, frame ``camera`` (optical)
``/camera/color/camera_info``  ``sensor_msgs/msg/CameraInfo``  K, P = [K|0], no distortion
``/camera/depth/image_raw``    ``sensor_msgs/msg/Image``       ``32FC1`` metres along the optical axis, 0 = none
``/camera/depth/camera_info``  ``sensor_msgs/msg/CameraInfo``  as the colour camera's
``/scan``                      ``sensor_msgs/msg/LaserScan``   frame ``lidar``, 360 beams from -π
``/odom``                      ``nav_msgs/msg/Odometry``       ``odom`` → ``base_link`` (odom = the start pose)
``/tf``                        ``tf2_msgs/msg/TFMessage``      ``map`` → ``odom``, ``odom`` → ``base_link``
``/tf_static``                 ``tf2_msgs/msg/TFMessage``      ``base_link`` → ``camera``, ``base_link`` → ``lidar``
``/benchbot/reset_done``       ``std_msgs/msg/String``         JSON ``{"id", "ok", "error", "environment"}``
=============================  ==============================  ==============================================

It obeys ``/cmd_vel`` (``geometry_msgs/msg/Twist``: ``linear.x`` m/s, ``angular.z`` rad/s) in real time (or
``time_scale`` times faster): every tick of 1/20 s of simulated time it integrates the newest command exactly
(unicycle) and refuses a step that would bring the footprint into the scene (the robot stays; as the direct
simulator). A command older than 0.5 s (wall) counts as zero — a dead controller cannot run the robot away.
``/benchbot/reset`` (``std_msgs/msg/String``, JSON ``{"id": ..., "environment": "name:variant", "seed": 0}``, every
field optional) reloads the scene (or another BEAR environment) and puts the robot at its start pose; the answer
comes on ``/benchbot/reset_done``. From a ROS 2 shell::

    ros2 topic pub --once /benchbot/reset std_msgs/msg/String "{data: '{\\"id\\": \\"1\\"}'}"

Taichi is driven from this process's main thread only; DDS callbacks just queue commands.
"""

from __future__ import annotations

import argparse
import json
import math
import queue
import sys
import threading
import time
from typing import Any

import numpy as np

TICK_S = 0.05  # simulated seconds per integration step (the controller's rate)
CMD_TIMEOUT_S = 0.5


def _set_pose(sim: Any, pose: np.ndarray) -> None:
    """Place the simulated robot through the simulator's public ``set_pose``."""
    sim.set_pose(pose)


class SimBridge:
    """Serve one simulated robot over ROS 2 (see the module doc).

    Args:
        env: environment string ``name:variant`` (BEAR, type ``sim_taichi``).
        robot: the simulated robot's name (default ``carter``).
        domain_id: ROS_DOMAIN_ID.
        width, height: camera size override (pixels), or None for the robot's.
        arch: Taichi device (``cpu``/``gpu``).
        time_scale: simulated seconds per wall second (1 = real time).
        camera_hz, laser_hz: publication rates (simulated time); odometry and TF go out every tick (20 Hz).
        transport: ``auto``/``cyclonedds``/``rclpy``. network: ``loopback``/``system``.
        seed: scene seed.

    Raises:
        benchbot.core.errors.BenchbotError: unknown environment/robot, or the transport/simulator cannot start.
    """

    def __init__(self, env: str, *, robot: str = "carter", domain_id: int = 0, width: int | None = None,
                 height: int | None = None, arch: str = "cpu", time_scale: float = 1.0, camera_hz: float = 10.0,
                 laser_hz: float = 10.0, transport: str = "auto", network: str = "loopback", seed: int = 0) -> None:
        from benchbot.core.registry import get_registry
        from benchbot_sim_taichi.backend import create_backend

        from benchbot_robot_ros2.transport import make_transport

        self.registry = get_registry()
        self.robot_spec = self.registry.get("robots", robot)
        options: dict[str, Any] = {"arch": arch, "seed": seed}
        if width and height:
            options.update(width=int(width), height=int(height))
        self.sim = create_backend(self.robot_spec, options)
        self.time_scale = float(time_scale)
        self.camera_period = 1.0 / float(camera_hz)
        self.laser_period = 1.0 / float(laser_hz)
        self.seed = seed
        self.env_string = env
        self.tr = make_transport(transport, domain_id, network)
        p = self.tr.publisher
        self.pub = {
            "rgb": p("/camera/color/image_raw", "sensor_msgs/msg/Image"),
            "rgb_info": p("/camera/color/camera_info", "sensor_msgs/msg/CameraInfo"),
            "depth": p("/camera/depth/image_raw", "sensor_msgs/msg/Image"),
            "depth_info": p("/camera/depth/camera_info", "sensor_msgs/msg/CameraInfo"),
            "scan": p("/scan", "sensor_msgs/msg/LaserScan"),
            "odom": p("/odom", "nav_msgs/msg/Odometry"),
            "tf": p("/tf", "tf2_msgs/msg/TFMessage"),
            "tf_static": p("/tf_static", "tf2_msgs/msg/TFMessage", latched=True),
            "reset_done": p("/benchbot/reset_done", "std_msgs/msg/String"),
        }
        self._cmd = (0.0, 0.0, -math.inf)  # v, w, wall receipt time
        self._resets: queue.Queue = queue.Queue()
        self.tr.subscribe("/cmd_vel", "geometry_msgs/msg/Twist", self._on_cmd, reliable=True)
        self.tr.subscribe("/benchbot/reset", "std_msgs/msg/String", self._on_reset, reliable=True)
        self.stop_event = threading.Event()
        self.sim_time = 0.0
        self.blocked_steps = 0
        self._load(env, seed)

    # ------------------------------------------------------------------------------------------ callbacks
    def _on_cmd(self, msg: Any) -> None:
        v, w = float(msg.linear.x), float(msg.angular.z)
        if math.isfinite(v) and math.isfinite(w):
            self._cmd = (v, w, time.monotonic())

    def _on_reset(self, msg: Any) -> None:
        self._resets.put(str(msg.data))

    # ------------------------------------------------------------------------------------------ simulation
    def _load(self, env: str, seed: int) -> None:
        environments = self.registry.scenes(env)
        if len(environments) != 1:
            from benchbot.core.errors import UsageError

            raise UsageError(f"serve-sim serves one scene, got '{env}'", "e.g. --env miniroom:1")
        self.environment = environments[0]
        self.sim.load_scene(self.environment, seed=seed)
        self.env_string = env
        self.start = self.sim.base_pose()
        self._cmd = (0.0, 0.0, -math.inf)
        self._last_camera = self._last_laser = -math.inf
        self._publish_static()

    def _handle_reset(self, raw: str) -> None:
        rid, env = "", self.env_string
        try:
            data = json.loads(raw) if raw.strip() else {}
            if not isinstance(data, dict):
                raise ValueError("the reset message must be a JSON object")
            rid = str(data.get("id", ""))
            env = str(data.get("environment") or self.env_string)
            self._load(env, int(data.get("seed", self.seed)))
            answer = {"id": rid, "ok": True, "error": "", "environment": env}
        except Exception as exc:  # noqa: BLE001 - answer, never die
            answer = {"id": rid, "ok": False, "error": str(exc), "environment": env}
        msg = self.tr.message("std_msgs/msg/String")
        msg.data = json.dumps(answer)
        self.pub["reset_done"].publish(msg)

    def _step(self) -> None:
        from benchbot_sim_taichi.kinematics import integrate_unicycle

        v, w, t = self._cmd
        if time.monotonic() - t > CMD_TIMEOUT_S:
            v = w = 0.0
        if v == 0.0 and w == 0.0:
            return
        pose = self.sim.base_pose()
        nxt = integrate_unicycle(pose, v, w, TICK_S)
        if self.sim.obstacles is not None and self.sim.obstacles.collides(nxt[:2]):
            self.blocked_steps += 1
            return
        _set_pose(self.sim, nxt)

    # ------------------------------------------------------------------------------------------ publishing
    def _tf(self, parent: str, child: str, T: np.ndarray, t_s: float) -> Any:
        from benchbot_robot_ros2.convert import fill_transform, set_stamp

        ts = self.tr.message("geometry_msgs/msg/TransformStamped")
        set_stamp(ts.header.stamp, t_s)
        ts.header.frame_id, ts.child_frame_id = parent, child
        fill_transform(ts.transform, T)
        return ts

    def _publish_static(self) -> None:
        now = time.time()
        msg = self.tr.message("tf2_msgs/msg/TFMessage")
        msg.transforms = [self._tf("base_link", "camera", self.sim.T_robot_camera, now),
                          self._tf("base_link", "lidar", self.sim.T_robot_lidar, now)]
        self.pub["tf_static"].publish(msg)

    def _publish_odom(self, now: float) -> None:
        from benchbot.core.geometry import se2_to_matrix

        from benchbot_robot_ros2.convert import fill_pose, set_stamp

        T_map_odom = se2_to_matrix(*self.start)
        T_map_base = se2_to_matrix(*self.sim.base_pose())
        T_odom_base = np.linalg.inv(T_map_odom) @ T_map_base
        odom = self.tr.message("nav_msgs/msg/Odometry")
        set_stamp(odom.header.stamp, now)
        odom.header.frame_id, odom.child_frame_id = "odom", "base_link"
        fill_pose(odom.pose.pose, T_odom_base)
        v, w, t = self._cmd
        if time.monotonic() - t <= CMD_TIMEOUT_S:
            odom.twist.twist.linear.x, odom.twist.twist.angular.z = float(v), float(w)
        self.pub["odom"].publish(odom)
        tf = self.tr.message("tf2_msgs/msg/TFMessage")
        tf.transforms = [self._tf("map", "odom", T_map_odom, now), self._tf("odom", "base_link", T_odom_base, now)]
        self.pub["tf"].publish(tf)

    def _publish_laser(self, now: float) -> None:
        from benchbot_robot_ros2.convert import fill_laser

        scan = self.sim.observe(["laser"])["laser"]
        sim = self.sim
        inc = float(sim.laser_angles[1] - sim.laser_angles[0]) if len(sim.laser_angles) > 1 else 0.0
        msg = fill_laser(self.tr.message("sensor_msgs/msg/LaserScan"), scan["scans"][:, 0], float(sim.laser_angles[0]),
                         inc, scan["range_min"], scan["range_max"], "lidar", now)
        self.pub["scan"].publish(msg)

    def _publish_camera(self, now: float) -> None:
        from benchbot_robot_ros2.convert import fill_camera_info, fill_image

        obs = self.sim.observe(["image_rgb", "image_depth"])
        K, w, h = self.sim.K, self.sim.width, self.sim.height
        self.pub["rgb"].publish(fill_image(self.tr.message("sensor_msgs/msg/Image"), obs["image_rgb"], "rgb8",
                                           "camera", now))
        self.pub["depth"].publish(fill_image(self.tr.message("sensor_msgs/msg/Image"), obs["image_depth"], "32FC1",
                                             "camera", now))
        for key in ("rgb_info", "depth_info"):
            self.pub[key].publish(fill_camera_info(self.tr.message("sensor_msgs/msg/CameraInfo"), K, w, h, "camera",
                                                   now))

    def run(self, duration_s: float | None = None) -> None:
        """Serve until :attr:`stop_event` is set (or ``duration_s`` wall seconds pass). Call from the thread that
        created the bridge (Taichi's)."""
        period = TICK_S / self.time_scale
        t_end = None if duration_s is None else time.monotonic() + duration_s
        next_t = time.monotonic()
        static_every = max(int(1.0 / TICK_S), 1)
        tick = 0
        while not self.stop_event.is_set() and (t_end is None or time.monotonic() < t_end):
            while not self._resets.empty():
                self._handle_reset(self._resets.get_nowait())
            self._step()
            self.sim_time += TICK_S
            now = time.time()
            self._publish_odom(now)
            if self.sim_time - self._last_laser >= self.laser_period - 1e-9:
                self._publish_laser(now)
                self._last_laser = self.sim_time
            if self.sim_time - self._last_camera >= self.camera_period - 1e-9:
                self._publish_camera(now)
                self._last_camera = self.sim_time
            tick += 1
            if tick % static_every == 0:
                self._publish_static()  # late joiners without transient-local support still get it
            next_t += period
            delay = next_t - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            elif delay < -1.0:
                next_t = time.monotonic()  # fell behind (slow renders): do not try to catch up

    def close(self) -> None:
        """Stop serving and release the transport and the simulator."""
        self.stop_event.set()
        self.tr.close()
        self.sim.close()


def serve(env: str, **kwargs: Any) -> None:
    """Build a :class:`SimBridge` and serve until interrupted (Ctrl-C / SIGTERM)."""
    import signal

    bridge = SimBridge(env, **kwargs)
    signal.signal(signal.SIGTERM, lambda *_: bridge.stop_event.set())
    print(f"serving {env} as a ROS 2 robot (domain {kwargs.get('domain_id', 0)}, transport {bridge.tr.name}); "
          "Ctrl-C stops", file=sys.stderr, flush=True)
    try:
        bridge.run()
    except KeyboardInterrupt:
        pass
    finally:
        bridge.close()


def parse_size(text: str | None) -> tuple[int | None, int | None]:
    """``'64x48'`` → (64, 48); None → (None, None). Raises UsageError otherwise."""
    if not text:
        return None, None
    import re

    from benchbot.core.errors import UsageError

    m = re.fullmatch(r"(\d+)[xX](\d+)", text.strip())
    if not m or int(m.group(1)) <= 0 or int(m.group(2)) <= 0:
        raise UsageError(f"--camera-size '{text}' is not WIDTHxHEIGHT", "e.g. --camera-size 320x240")
    return int(m.group(1)), int(m.group(2))


def main(argv: list[str] | None = None) -> None:
    """``python -m benchbot_robot_ros2.sim_bridge --env miniroom:1 [...]`` (same options as the CLI command)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--env", required=True)
    ap.add_argument("--robot", default="carter")
    ap.add_argument("--domain-id", type=int, default=None)
    ap.add_argument("--camera-size", default=None)
    ap.add_argument("--arch", default="cpu")
    ap.add_argument("--time-scale", type=float, default=1.0)
    ap.add_argument("--camera-hz", type=float, default=10.0)
    ap.add_argument("--transport", default="auto")
    ap.add_argument("--network", default="loopback")
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args(argv)
    import os

    domain = a.domain_id if a.domain_id is not None else int(os.environ.get("ROS_DOMAIN_ID", "0") or 0)
    w, h = parse_size(a.camera_size)
    serve(a.env, robot=a.robot, domain_id=domain, width=w, height=h, arch=a.arch, time_scale=a.time_scale,
          camera_hz=a.camera_hz, transport=a.transport, network=a.network, seed=a.seed)


if __name__ == "__main__":
    main()
