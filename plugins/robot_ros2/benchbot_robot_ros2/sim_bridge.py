"""The Taichi simulator served as a ROS 2 robot (``benchbot ros2 serve-sim --env ENV``).

Runs the ``carter`` robot of ``benchbot_sim_taichi`` in one environment and, over ROS 2 (rclpy or Cyclone DDS, as
the node ``benchbot_sim``), publishes what the robot ``carter_ros2`` reads:

=============================  ==============================  ==============================================
topic                          type                            content
=============================  ==============================  ==============================================
``/clock``                     ``rosgraph_msgs/msg/Clock``     simulated time, every tick (1/20 s simulated)
``/camera/color/image_raw``    ``sensor_msgs/msg/Image``       ``rgb8``, frame: the camera's (optical)
``/camera/color/camera_info``  ``sensor_msgs/msg/CameraInfo``  K, P = [K|0], no distortion, the same frame
``/camera/depth/image_raw``    ``sensor_msgs/msg/Image``       ``32FC1`` metres along the optical axis; NaN where
                                                               nothing is hit (REP 118)
``/camera/depth/camera_info``  ``sensor_msgs/msg/CameraInfo``  as the colour camera's
``/scan``                      ``sensor_msgs/msg/LaserScan``   frame: the laser's; 360 beams, ``angle_min`` -π,
                                                               +Inf where nothing is in range (REP 117)
``/odom``                      ``nav_msgs/msg/Odometry``       odom → base (odom = the start pose); twist: the
                                                               motion made in the last tick (0 when refused)
``/tf``                        ``tf2_msgs/msg/TFMessage``      map → odom, odom → base
``/tf_static``                 ``tf2_msgs/msg/TFMessage``      base → camera (optical), base → laser
``/benchbot/reset_done``       ``std_msgs/msg/String``         JSON ``{"id", "ok", "error", "environment"}``
=============================  ==============================  ==============================================

Every other observation kind of the registry (plugins' included) that both the simulated robot and the ROS robot
definition observe goes out with the camera, on its recorder channels' topics and types, converted as a recording
holds it (a plugin's IMU on ``/imu/data``; :func:`published_kinds`).

Frame and topic names come from one place, the ROS robot definition served (``carter_ros2``, or another with
``--ros-robot``, such as ``turtlebot4``'s ``oakd_…`` frames and topics): ``global_frame`` (``map``),
``ros2.frames.robot`` or ``ros2.base_frame`` (``base_link``), ``ros2.frames.camera`` (``camera``) and
``ros2.frames.lidar`` (``lidar``); the odometry frame is ``odom``. The same names are in the images, camera infos,
scans, odometry and TF. The topics of the table are ``carter_ros2``'s; another definition's connections
(``image_rgb``, ``image_depth``, their ``_info``, ``laser``, ``move_next``) and ``ros2.odom_topic``,
``ros2.tf_topic``, ``ros2.tf_static_topic`` rename them (:func:`ros_topics`).

Time: every message is stamped with the simulated time, published on ``/clock`` (ROS's ``use_sim_time``
convention): it starts at the wall-clock time the scene was ready (not when the process started: loading a
furnished scene takes tens of seconds) and advances 1/20 s per tick, ``time_scale`` ticks of 1/20 s per 1/20 wall
second (fewer when rendering cannot keep up). ROS nodes must run with ``use_sim_time:=true`` to see velocities and
timeouts right when ``time_scale`` ≠ 1 (or the simulation lags).

It obeys ``/cmd_vel`` (``geometry_msgs/msg/Twist``: ``linear.x`` m/s, ``angular.z`` rad/s) in simulated time: every
tick it integrates the newest command exactly (unicycle) and refuses a step that would bring the footprint into
the scene (the robot stays; as the direct simulator). A command older than 0.5 s (wall) counts as zero — a dead
controller cannot run the robot away.
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

from benchbot.core.seeding import environment_world_seed

TICK_S = 0.05  # simulated seconds per integration step (the controller's rate)
TICK_NS = 50_000_000
CMD_TIMEOUT_S = 0.5
NODE_NAME = "benchbot_sim"
ODOM_FRAME = "odom"


def ros_frames(ros_robot: dict) -> dict[str, str]:
    """TF frame names of a ROS robot definition (type ``ros2``): ``{'map', 'robot', 'camera', 'lidar'}`` from
    ``global_frame``, ``ros2.frames.robot`` (else ``ros2.base_frame``, else ``base_link``), ``ros2.frames.camera``
    and ``ros2.frames.lidar`` (else ``camera``/``lidar``).

    Raises:
        benchbot.core.errors.UsageError: a frame name that is empty or not a string, or two names the same.
    """
    from benchbot.core.errors import UsageError

    ros2 = ros_robot.get("ros2") or {}
    frames = ros2.get("frames") or {}
    out = {"map": ros_robot.get("global_frame", "map"),
           "robot": frames.get("robot", ros2.get("base_frame", "base_link")),
           "camera": frames.get("camera", "camera"), "lidar": frames.get("lidar", "lidar")}
    for key, name in out.items():
        if not isinstance(name, str) or not name.strip("/"):
            raise UsageError(f"robot '{ros_robot.get('name')}': frame {key} is {name!r}", "give TF frame names")
        out[key] = name.strip("/")
    if len(set(out.values()) | {ODOM_FRAME}) != 5:
        raise UsageError(f"robot '{ros_robot.get('name')}': frames {out} are not distinct (nor from '{ODOM_FRAME}')",
                         "give each frame its own name")
    return out


def _recorded_topic(observation: str) -> str:
    """The topic a recording holds the core's observation kind ``observation`` on (its one channel's,
    :data:`benchbot.core.observations.BUILT_IN`): serve-sim publishes it where ``--record`` records it."""
    from benchbot.core.observations import BUILT_IN

    (channel,) = BUILT_IN[observation].channels
    return channel.topic


#: The topics served, by key: ``carter_ros2``'s names (:func:`ros_topics` reads another definition's); the sensors'
#: are the recorder's channels of their observation kinds.
DEFAULT_TOPICS = {"rgb": _recorded_topic("image_rgb"), "rgb_info": _recorded_topic("image_rgb_info"),
                  "depth": _recorded_topic("image_depth"), "depth_info": _recorded_topic("image_depth_info"),
                  "scan": _recorded_topic("laser"), "odom": "/odom", "tf": "/tf", "tf_static": "/tf_static",
                  "cmd_vel": "/cmd_vel"}


#: The observation kinds the bridge publishes with converters of its own, on the topics of the ROS robot definition
#: served (:func:`ros_topics`): the camera's and the laser's. Every other kind is read from the registry
#: (:func:`published_kinds`).
PUBLISHED_HERE = ("image_rgb", "image_rgb_info", "image_depth", "image_depth_info", "laser")


def published_kinds(kinds: dict, robot: dict, ros_robot: dict) -> dict:
    """``{kind name: (ObservationKind, {channel key: topic})}``: the observation kinds (``kinds``: the registry's,
    plugins' included: ``Registry.observations``) that the bridge publishes through their own recorder converters
    (``ObservationKind.to_messages``): the sensor kinds with channels, beyond :data:`PUBLISHED_HERE`, that both the
    simulated ``robot`` and the ROS robot definition served (``ros_robot``) observe (a plugin's IMU). Each goes
    out on its channels' topics, or, for a kind of one channel, on the ``ros_topic`` of the definition's connection
    of its name when it gives one (as :func:`ros_topics` renames the camera's and the laser's)."""
    both = set(robot.get("observations") or []) & set(ros_robot.get("observations") or [])
    connections = ros_robot.get("connections") or {}
    out = {}
    for name, kind in kinds.items():
        if name in both and name not in PUBLISHED_HERE and kind.sensor and kind.channels:
            renamed = (connections.get(name) or {}).get("ros_topic") if len(kind.channels) == 1 else None
            out[name] = (kind, {c.key: renamed or c.topic for c in kind.channels})
    return out


def ros_topics(ros_robot: dict) -> dict[str, str]:
    """The topics a ROS robot definition (type ``ros2``) reads and commands, by :data:`DEFAULT_TOPICS`' keys: its
    connections' ``ros_topic`` (``image_rgb`` → ``rgb``, ``image_rgb_info`` → ``rgb_info``, ``image_depth``,
    ``image_depth_info``, ``laser`` → ``scan``, ``move_next`` → ``cmd_vel``) and ``ros2.odom_topic``,
    ``ros2.tf_topic``, ``ros2.tf_static_topic``; :data:`DEFAULT_TOPICS` for what it does not name.

    Raises:
        benchbot.core.errors.UsageError: a topic that is not a string starting with ``/``.
    """
    from benchbot.core.errors import UsageError

    connections = ros_robot.get("connections") or {}
    ros2 = ros_robot.get("ros2") or {}
    named = {"rgb": "image_rgb", "rgb_info": "image_rgb_info", "depth": "image_depth",
             "depth_info": "image_depth_info", "scan": "laser", "cmd_vel": "move_next"}
    out = dict(DEFAULT_TOPICS)
    for key, connection in named.items():
        topic = (connections.get(connection) or {}).get("ros_topic")
        if topic is not None:
            out[key] = topic
    for key in ("odom", "tf", "tf_static"):
        out[key] = ros2.get(f"{key}_topic", out[key])
    for key, topic in out.items():
        if not isinstance(topic, str) or not topic.startswith("/"):
            raise UsageError(f"robot '{ros_robot.get('name')}': topic {key} is {topic!r}", "give ROS topics as /name")
    return out


def _set_pose(sim: Any, pose: np.ndarray) -> None:
    """Place the simulated robot through the simulator's public ``set_pose``."""
    sim.set_pose(pose)


#: What serve-sim needs of a simulator's robot backend besides :class:`benchbot.core.robot.RobotBackend`: the robot
#: placed directly (the bridge integrates /cmd_vel itself), its obstacles, the sensors' mounts (4x4, footprint frame),
#: the camera's intrinsics and size.
SIMULATOR_INTERFACE = ("set_pose", "obstacles", "T_footprint_robot", "T_footprint_camera", "T_footprint_lidar",
                       "robot_frame_height", "K", "width", "height")


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
        seed: the run's seed: with the environment's name and variant it fixes the scene
            (:func:`benchbot.core.seeding.environment_world_seed`, as in an episode with that seed).
        ros_robot: the ROS robot definition served (a robot name, or a spec dict): its frame and topic names are
            used (:func:`ros_frames`, :func:`ros_topics`).

    Attributes:
        frames: ``{'map', 'robot', 'camera', 'lidar'}`` → TF frame name. clock_ns: the simulated time (int ns).

    Raises:
        benchbot.core.errors.BenchbotError: unknown environment/robot, or the transport/simulator cannot start.
    """

    def __init__(self, env: str, *, robot: str = "carter", domain_id: int = 0, width: int | None = None,
                 height: int | None = None, arch: str = "cpu", time_scale: float = 1.0, camera_hz: float = 10.0,
                 laser_hz: float = 10.0, transport: str = "auto", network: str = "loopback", seed: int = 0,
                 ros_robot: str | dict = "carter_ros2") -> None:
        from benchbot.core.registry import get_registry

        from benchbot_robot_ros2.transport import make_transport

        self.registry = get_registry()
        self.robot_spec = self.registry.get("robots", robot)
        definition = ros_robot if isinstance(ros_robot, dict) else self.registry.get("robots", ros_robot)
        self.frames = ros_frames(definition)
        self.topics = ros_topics(definition)
        self.clock_ns = time.time_ns() // 1_000_000 * 1_000_000  # until the scene is ready (below)
        options: dict[str, Any] = {"arch": arch, "seed": seed}
        if width and height:
            options.update(width=int(width), height=int(height))
        # the simulator comes from whichever plugin offers the robot's type (benchbot-sim-taichi for carter)
        self.sim = self.registry.backend_factory(self.robot_spec["type"])(self.robot_spec, options)
        missing = [a for a in SIMULATOR_INTERFACE if not hasattr(self.sim, a)]
        if missing:
            from benchbot.core.errors import BackendError

            raise BackendError(f"robot '{robot}' (type {self.robot_spec['type']}) is no simulated robot that serve-sim "
                               f"can drive: its backend lacks {', '.join(missing)}",
                               "serve a robot of a simulator plugin, e.g. --robot carter (benchbot-sim-taichi)")
        self.time_scale = float(time_scale)
        self.camera_period = 1.0 / float(camera_hz)
        self.laser_period = 1.0 / float(laser_hz)
        self.seed = seed
        self.env_string = env
        self.tr = make_transport(transport, domain_id, network, NODE_NAME)
        p, t = self.tr.publisher, self.topics
        self.pub = {
            "clock": p("/clock", "rosgraph_msgs/msg/Clock"),
            "rgb": p(t["rgb"], "sensor_msgs/msg/Image"),
            "rgb_info": p(t["rgb_info"], "sensor_msgs/msg/CameraInfo"),
            "depth": p(t["depth"], "sensor_msgs/msg/Image"),
            "depth_info": p(t["depth_info"], "sensor_msgs/msg/CameraInfo"),
            "scan": p(t["scan"], "sensor_msgs/msg/LaserScan"),
            "odom": p(t["odom"], "nav_msgs/msg/Odometry"),
            "tf": p(t["tf"], "tf2_msgs/msg/TFMessage"),
            "tf_static": p(t["tf_static"], "tf2_msgs/msg/TFMessage", latched=True),
            "reset_done": p("/benchbot/reset_done", "std_msgs/msg/String"),
        }
        #: ``{kind name: (ObservationKind, {channel key: (publisher, ROS type)})}``: the kinds of the registry
        #: published with their own converters (:func:`published_kinds`); a kind whose message type the transport
        #: lacks is left out with a warning on stderr
        self.kinds: dict[str, tuple[Any, dict[str, tuple[Any, str]]]] = {}
        for kind, topics in published_kinds(self.registry.observations, self.robot_spec, definition).values():
            try:
                channels = {c.key: (p(topics[c.key], c.datatype), c.datatype) for c in kind.channels}
            except Exception as exc:  # noqa: BLE001 - the type is unknown to this transport: the others still go out
                print(f"warning: observation {kind.name} is not published: {exc}", file=sys.stderr)
                continue
            self.kinds[kind.name] = (kind, channels)
        self._cmd = (0.0, 0.0, -math.inf)  # v, w, wall receipt time
        self._twist = (0.0, 0.0)  # the motion made in the last tick: v m/s, w rad/s
        self._resets: queue.Queue = queue.Queue()
        self.tr.subscribe(t["cmd_vel"], "geometry_msgs/msg/Twist", self._on_cmd, reliable=True)
        self.tr.subscribe("/benchbot/reset", "std_msgs/msg/String", self._on_reset, reliable=True)
        self.stop_event = threading.Event()
        self.sim_time = 0.0
        self.blocked_steps = 0
        self._load(env, seed)
        # simulated time starts now that the scene is ready, at the wall clock (not when the process started)
        self.clock_ns = time.time_ns() // 1_000_000 * 1_000_000
        self._publish_static()

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
        self.sim.load_scene(self.environment, seed=environment_world_seed(seed, self.environment))
        self.env_string = env
        self.start = self.sim.base_pose()
        self._cmd = (0.0, 0.0, -math.inf)
        self._twist = (0.0, 0.0)
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
        """Integrate the newest fresh command for one tick; :attr:`_twist` becomes the motion made (exact unicycle
        integration: the command, or zero when the step is refused)."""
        from benchbot.core.motion import integrate_unicycle

        self._twist = (0.0, 0.0)
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
        self._twist = (v, w)

    # ------------------------------------------------------------------------------------------ publishing
    def _tf(self, parent: str, child: str, T: np.ndarray, t_ns: int) -> Any:
        from benchbot_robot_ros2.convert import fill_transform, set_stamp

        ts = self.tr.message("geometry_msgs/msg/TransformStamped")
        set_stamp(ts.header.stamp, t_ns=t_ns)
        ts.header.frame_id, ts.child_frame_id = parent, child
        fill_transform(ts.transform, T)
        return ts

    def _publish_static(self) -> None:
        f = self.frames
        msg = self.tr.message("tf2_msgs/msg/TFMessage")
        T_robot_footprint = np.linalg.inv(self.sim.T_footprint_robot)  # the base frame is the robot frame's height up
        msg.transforms = [self._tf(f["robot"], f["camera"], T_robot_footprint @ self.sim.T_footprint_camera,
                                   self.clock_ns),
                          self._tf(f["robot"], f["lidar"], T_robot_footprint @ self.sim.T_footprint_lidar,
                                   self.clock_ns)]
        self.pub["tf_static"].publish(msg)

    def _publish_clock(self) -> None:
        from benchbot_robot_ros2.convert import set_stamp

        msg = self.tr.message("rosgraph_msgs/msg/Clock")
        set_stamp(msg.clock, t_ns=self.clock_ns)
        self.pub["clock"].publish(msg)

    def _publish_odom(self) -> None:
        from benchbot.core.geometry import se2_to_matrix

        from benchbot_robot_ros2.convert import fill_pose, set_stamp

        f, now = self.frames, self.clock_ns
        T_map_odom = se2_to_matrix(*self.start)
        T_map_base = se2_to_matrix(*self.sim.base_pose(), z=self.sim.robot_frame_height)
        T_odom_base = np.linalg.inv(T_map_odom) @ T_map_base
        odom = self.tr.message("nav_msgs/msg/Odometry")
        set_stamp(odom.header.stamp, t_ns=now)
        odom.header.frame_id, odom.child_frame_id = ODOM_FRAME, f["robot"]
        fill_pose(odom.pose.pose, T_odom_base)
        odom.twist.twist.linear.x, odom.twist.twist.angular.z = (float(v) for v in self._twist)
        self.pub["odom"].publish(odom)
        tf = self.tr.message("tf2_msgs/msg/TFMessage")
        tf.transforms = [self._tf(f["map"], ODOM_FRAME, T_map_odom, now),
                         self._tf(ODOM_FRAME, f["robot"], T_odom_base, now)]
        self.pub["tf"].publish(tf)

    def _publish_laser(self) -> None:
        from benchbot.core.ros_messages import ros_ranges
        from benchbot_robot_ros2.convert import fill_laser, wrap_angles

        scan = self.sim.observe(["laser"])["laser"]
        sim = self.sim
        inc = float(sim.laser_angles[1] - sim.laser_angles[0]) if len(sim.laser_angles) > 1 else 0.0
        msg = fill_laser(self.tr.message("sensor_msgs/msg/LaserScan"),
                         ros_ranges(scan["scans"][:, 0], scan["range_max"]), float(wrap_angles(sim.laser_angles[0])),
                         inc, scan["range_min"], scan["range_max"], self.frames["lidar"], 0.0, t_ns=self.clock_ns)
        self.pub["scan"].publish(msg)

    def _publish_camera(self) -> None:
        from benchbot.core.ros_messages import ros_depth
        from benchbot_robot_ros2.convert import fill_camera_info, fill_image

        obs = self.sim.observe(["image_rgb", "image_depth"])
        K, w, h, cam, now = self.sim.K, self.sim.width, self.sim.height, self.frames["camera"], self.clock_ns
        self.pub["rgb"].publish(fill_image(self.tr.message("sensor_msgs/msg/Image"), obs["image_rgb"], "rgb8",
                                           cam, 0.0, t_ns=now))
        self.pub["depth"].publish(fill_image(self.tr.message("sensor_msgs/msg/Image"), ros_depth(obs["image_depth"]),
                                             "32FC1", cam, 0.0, t_ns=now))
        for key in ("rgb_info", "depth_info"):
            self.pub[key].publish(fill_camera_info(self.tr.message("sensor_msgs/msg/CameraInfo"), K, w, h, cam, 0.0,
                                                   t_ns=now))

    def _publish_kinds(self) -> None:
        """The registry's kinds the robot observes beyond the camera's and laser's (:attr:`kinds`), each converted by
        its own ``to_messages`` (as a recording holds it) and published on its channels' topics."""
        if not self.kinds:
            return
        from benchbot.core.observations import RecordContext

        from benchbot_robot_ros2.convert import fill_from_dict

        obs = self.sim.observe(list(self.kinds))
        context = RecordContext(self.clock_ns, dict(self.frames), {})
        for name, (kind, channels) in self.kinds.items():
            for key, message in kind.to_messages(obs[name], context).items():
                publisher, ros_type = channels[key]
                publisher.publish(fill_from_dict(self.tr.message(ros_type), message))

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
            self.clock_ns += TICK_NS
            self._publish_clock()
            self._publish_odom()
            if self.sim_time - self._last_laser >= self.laser_period - 1e-9:
                self._publish_laser()
                self._last_laser = self.sim_time
            if self.sim_time - self._last_camera >= self.camera_period - 1e-9:
                self._publish_camera()
                self._publish_kinds()
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
    """Build a :class:`SimBridge` (its stages shown on stderr: :func:`benchbot.cli.common.showing_stages`), say one
    "ready" line, and serve until interrupted. Ctrl-C re-raises KeyboardInterrupt once the bridge is closed (the
    command exits 130, as ``benchbot run`` does); SIGTERM stops serving and returns."""
    import signal

    from benchbot.cli.common import showing_stages

    with showing_stages(env):
        bridge = SimBridge(env, **kwargs)
    signal.signal(signal.SIGTERM, lambda *_: bridge.stop_event.set())
    print(f"ready: serving {env} as a ROS 2 robot (domain {kwargs.get('domain_id', 0)}, transport {bridge.tr.name}); "
          "Ctrl-C stops", file=sys.stderr, flush=True)
    try:
        bridge.run()
    finally:
        bridge.close()


def parse_size(text: str | None) -> tuple[int | None, int | None]:
    """``'64x48'`` → (64, 48); None → (None, None). Raises UsageError otherwise, and for a side of more than
    :data:`~benchbot.core.limits.MAX_CAMERA_SIDE` (8192) pixels (checked on the digits, before any number is made)."""
    if not text:
        return None, None
    import re

    from benchbot.core.errors import UsageError
    from benchbot.core.limits import MAX_CAMERA_SIDE

    side = int(MAX_CAMERA_SIDE.value())
    m = re.fullmatch(r"(\d+)[xX](\d+)", text.strip())
    sides = [int(g) if len(g.lstrip("0")) <= 12 else side + 1 for g in m.groups()] if m else [0]
    if min(sides) <= 0:
        raise UsageError(f"--camera-size '{text}' is not WIDTHxHEIGHT", "e.g. --camera-size 320x240")
    if max(sides) > side:
        raise UsageError(f"--camera-size '{text}': each side must be at most {side} pixels",
                         f"e.g. --camera-size 640x480 (at most {side}x{side})")
    return sides[0], sides[1]


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
    ap.add_argument("--ros-robot", default="carter_ros2")
    a = ap.parse_args(argv)
    from benchbot.core import settings
    from benchbot_robot_ros2.settings import ROS_DOMAIN_ID

    domain = a.domain_id if a.domain_id is not None else settings.value(ROS_DOMAIN_ID)
    w, h = parse_size(a.camera_size)
    serve(a.env, robot=a.robot, domain_id=domain, width=w, height=h, arch=a.arch, time_scale=a.time_scale,
          camera_hz=a.camera_hz, transport=a.transport, network=a.network, seed=a.seed, ros_robot=a.ros_robot)


if __name__ == "__main__":
    main()
