"""``Ros2RobotBackend``: a :class:`~benchbot.core.robot.RobotBackend` for any robot reachable over ROS 2.

The robot spec (type ``ros2``) declares its connections like the original BenchBot's robot YAML
(docs/original-benchbot.md, section 3):
``ros_to_api`` connections (``ros_topic``, ``ros_type``, optional ``callback_robot: module:function`` turning the
message into the observation) are subscribed; the ``api_to_ros`` actions publish ``geometry_msgs/msg/Twist`` on their
``ros_topic`` (``/cmd_vel``). The ``ros2`` block configures the rest (defaults in :data:`DEFAULTS`, documented in
docs/ros2.md): transport, domain, TF frames, odometry, timeouts, the laser safety distance and how a scene resets.

Motion: :class:`benchbot.core.motion.PoseController` closed-loop on the ground-truth pose (TF ``map → base``), at
``rate_hz`` (20 Hz; × ``time_scale`` for a simulator running faster than real time). Before each command the laser
scan is checked: if the footprint circle (``footprint_radius_m``) would come within ``safety_distance_m`` of a laser
return during the next step, a zero Twist is sent and the motion ends with ``collided=True`` (→ COLLISION).
Faults — odometry, laser or TF silent for longer than ``sensor_timeout_s`` during a motion, TF lost, no fresh
observation — publish a zero Twist at once and raise :class:`~benchbot.core.errors.RobotFaultError` (a
``BackendError``; the server answers 503, the client shows one line). Silence is judged by what the robot sent,
not by when this process got round to reading it (:mod:`benchbot_robot_ros2.watchdog`): a motion starts only once
every watched topic has sent a new message (a header stamp that moved on), and during it a topic is silent when no
such message arrived over ``sensor_timeout_s`` of punctual control periods — time in which this process was not
scheduled (a machine under heavy load) never counts against the robot.

Observations: the newest *valid* message of each topic, converted on receipt (malformed messages are dropped and
counted in :attr:`Ros2RobotBackend.rejected`); after a motion, :meth:`observe` waits for messages received after the
robot stopped and settled, so observations always show the final pose.
"""

from __future__ import annotations

import importlib
import json
import math
import threading
import time
import uuid
from dataclasses import replace
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from benchbot.core import settings
from benchbot.core.errors import BackendError, RobotFaultError
from benchbot.core.geometry import se2_relative, se2_to_matrix, start_pose_to_se2
from benchbot.core.motion import ControllerGains, PoseController
from benchbot.core.specs import first_error
from benchbot.core.robot import MotionOutcome, RobotBackend
from benchbot_robot_ros2.settings import ROS2_TIME_SCALE, ROS_DOMAIN_ID
from benchbot_robot_ros2.watchdog import SilenceWatch, header_stamp_s

#: Defaults of the robot spec's ``ros2`` block (see docs/ros2.md).
DEFAULTS: dict[str, Any] = {
    "transport": "auto",            # auto (rclpy when importable) | rclpy | cyclonedds
    "domain_id": 0,                 # ROS_DOMAIN_ID; the environment variable ROS_DOMAIN_ID overrides it
    "network": "system",            # loopback: Cyclone DDS on lo only (unless CYCLONEDDS_URI is set) | system
    "odom_topic": "/odom",
    "tf_topic": "/tf",
    "tf_static_topic": "/tf_static",
    "base_frame": "base_link",      # the TF frame of BenchBot's robot frame
    "frames": {},                   # BenchBot pose name -> TF frame (default: the same name; robot -> base_frame)
    "ground_truth": "tf",           # tf: TF global_frame -> base_frame | odometry: the odometry pose, taken as map
    "rate_hz": 20.0,
    "time_scale": 1.0,              # > 1 only with a simulator running that much faster than real time
    "settle_s": 0.65,
    "sensor_timeout_s": 0.4,        # odometry/laser/TF send nothing new this long during a motion: fault
    "observation_timeout_s": 5.0,   # no fresh message for an observation within this: error
    "startup_timeout_s": 60.0,      # topics/TF must appear (and a simulator reset finish) within this
    "footprint_radius_m": 0.25,
    "safety_distance_m": 0.1,       # stop this far before the footprint would touch a laser return; 0: off
    "reset": "drive",               # drive: drive back to the start pose | topic: ask a simulator (reset_topic)
    "reset_topic": "/benchbot/reset",
    "reset_done_topic": "/benchbot/reset_done",
}

#: The schema of what this backend reads of a robot spec beyond ``schemas/``: its ``connections`` and ``ros2`` block
#: (package data, validated by :func:`benchbot.core.specs.first_error`).
ROBOT_SCHEMA = Path(__file__).resolve().parent / "schemas" / "robot.schema.json"

_DEFAULT_CONVERTERS = {
    "image_rgb": "benchbot_robot_ros2.convert:image_rgb",
    "image_depth": "benchbot_robot_ros2.convert:image_depth",
    "image_rgb_info": "benchbot_robot_ros2.convert:camera_info",
    "image_depth_info": "benchbot_robot_ros2.convert:camera_info",
    "laser": "benchbot_robot_ros2.convert:laser",
}
_BY_TYPE = {
    "sensor_msgs/msg/Image": "benchbot_robot_ros2.convert:image_array",
    "sensor_msgs/msg/CameraInfo": "benchbot_robot_ros2.convert:camera_info",
    "sensor_msgs/msg/LaserScan": "benchbot_robot_ros2.convert:laser",
}


def _import_callable(path: str) -> Callable:
    """``module:function`` (or ``module.function``) → the callable.

    Raises:
        BackendError: it cannot be imported.
    """
    mod, sep, attr = path.partition(":")
    if not sep:
        mod, _, attr = path.rpartition(".")
    try:
        return getattr(importlib.import_module(mod), attr)
    except Exception as exc:  # noqa: BLE001
        raise BackendError(f"translation callback '{path}' cannot be imported: {exc!r}",
                           "give callback_robot as 'package.module:function'") from exc


def _override(cfg: dict, field: str, value: Any, source: str, convert: Callable[[Any], Any], hint: str) -> None:
    """Set ``cfg[field]`` to ``convert(value)``, a value from outside the robot spec (``source``: an environment
    variable or an option), checked against the field's schema in :data:`ROBOT_SCHEMA`.

    Raises:
        BackendError: ``"<source> = <value>: <problem>"`` (one line): it does not convert or does not match.
    """
    try:
        converted = convert(value)
    except (TypeError, ValueError) as exc:
        kind = "an integer" if convert is int else "a number"
        raise BackendError(f"{source} = {value!r}: expected {kind} ({exc})", hint) from None
    error = first_error({"ros2": {field: converted}}, ROBOT_SCHEMA)
    if error:
        raise BackendError(f"{source} = {value!r}: {error[1]}", hint)
    cfg[field] = converted


def ros2_config(robot_spec: dict, options: dict | None = None) -> dict[str, Any]:
    """The robot spec's ``ros2`` block over :data:`DEFAULTS`; ``ROS_DOMAIN_ID`` and ``BENCHBOT_ROS2_TIME_SCALE``
    (environment) and ``options['ros2_domain_id']`` override. Units as in :data:`DEFAULTS`: seconds, metres, hertz;
    ``domain_id`` an int, the others floats or strings.

    The spec (its ``connections`` and ``ros2`` block) is checked against :data:`ROBOT_SCHEMA`, the overrides against
    the same schema's fields.

    Raises:
        BackendError: one line naming the field (``robot '<name>': ros2.<field>: <problem>``, or the environment
            variable or option): a field that does not match :data:`ROBOT_SCHEMA` (a value of the wrong type, a
            domain id outside 0..232, a ``rate_hz`` or ``time_scale`` not positive, an unknown ``transport``,
            ``network``, ``ground_truth`` or ``reset``; an action connection publishing anything but a Twist, an
            observation connection with a ``ros_topic`` but no ``ros_type``), or an override that is not one.
    """
    error = first_error(robot_spec, ROBOT_SCHEMA)
    if error:
        field = error[0].removeprefix("$.")
        hint = ("an observation's ros_topic needs its ros_type (e.g. sensor_msgs/msg/Image); the actions publish "
                "geometry_msgs/msg/Twist" if field.startswith("connections.") else
                "see docs/ros2.md (Writing a robot YAML) for the ros2 block")
        raise BackendError(f"robot '{robot_spec.get('name')}': {field}: {error[1]}",
                           f"{hint}; schema benchbot_robot_ros2/schemas/robot.schema.json")
    cfg = {**DEFAULTS, **(robot_spec.get("ros2") or {})}
    options = options or {}
    # Values from outside the spec: converted and checked here, against the schema's fields, naming their source.
    domain_hint = "use a domain id 0..232"
    if settings.source(ROS_DOMAIN_ID) == "environment":
        _override(cfg, "domain_id", settings.get(ROS_DOMAIN_ID), ROS_DOMAIN_ID.name, int, domain_hint)
    if options.get("ros2_domain_id") is not None:
        _override(cfg, "domain_id", options["ros2_domain_id"], "options.ros2_domain_id", int, domain_hint)
    if settings.get(ROS2_TIME_SCALE):
        _override(cfg, "time_scale", settings.get(ROS2_TIME_SCALE), ROS2_TIME_SCALE.name, float,
                  "simulated seconds per wall second, > 0 (e.g. 1.0)")
    cfg["domain_id"] = int(cfg["domain_id"])
    for k in ("rate_hz", "time_scale", "settle_s", "sensor_timeout_s", "observation_timeout_s", "startup_timeout_s",
              "footprint_radius_m", "safety_distance_m"):
        cfg[k] = float(cfg[k])
    return cfg


class _Latest:
    """The newest valid converted value of one topic, with its receipt time (monotonic)."""

    def __init__(self) -> None:
        self.value: Any = None
        self.t = -math.inf
        self.count = 0
        self.cond = threading.Condition()

    def set(self, value: Any) -> None:
        with self.cond:
            self.value, self.t = value, time.monotonic()
            self.count += 1
            self.cond.notify_all()

    def wait_after(self, t0: float, timeout: float) -> Any:
        deadline = time.monotonic() + timeout
        with self.cond:
            while self.t <= t0:
                left = deadline - time.monotonic()
                if left <= 0:
                    return None
                self.cond.wait(left)
            return self.value


class Ros2RobotBackend(RobotBackend):
    """A robot of type ``ros2`` (see the module docstring).

    Args:
        robot_spec: the validated robot spec (``connections`` with ``ros_topic``/``ros_type``; ``ros2`` block).
        options: ``ros2_domain_id`` (int) overrides the domain; ``transport`` (a :class:`Transport`, for tests);
            others (``seed``, ``width``/``height``: a real camera's size cannot change) are ignored.

    Raises:
        BackendError: invalid configuration, an unsupported message type, or the transport cannot start.
    """

    def __init__(self, robot_spec: dict, options: dict | None = None) -> None:
        from benchbot_robot_ros2.naming import normalise_type
        from benchbot_robot_ros2.tf import TfBuffer
        from benchbot_robot_ros2.transport import make_transport

        self.robot_spec = dict(robot_spec)
        options = dict(options or {})
        self.cfg = ros2_config(self.robot_spec, options)
        self.global_frame = str(self.robot_spec.get("global_frame", "map"))
        self.base_frame = str(self.cfg["base_frame"])
        self.gains = replace(ControllerGains(), rate_hz=self.cfg["rate_hz"], settle_s=self.cfg["settle_s"],
                             speed_factor=float(self.robot_spec.get("speed_factor", 1.0) or 1.0))
        self.transport = options.get("transport") or make_transport(self.cfg["transport"], self.cfg["domain_id"],
                                                                    self.cfg["network"])
        self._own_transport = "transport" not in options
        self.tf = TfBuffer(max_age_s=max(self.cfg["sensor_timeout_s"], 0.05) * 2.5)
        self.rejected: dict[str, int] = {}
        self.last_problem = ""
        self._latest: dict[str, _Latest] = {}
        self._converters: dict[str, Callable] = {}
        self._moving = False
        self._fresh_after = -math.inf
        self._closed = False
        self._scene_start: np.ndarray | None = None
        self._reset_acks: dict[str, dict] = {}
        self._reset_cond = threading.Condition()
        self._watches = self._make_watches()

        # actions: Twist publisher on the actions' topic (ros2_config checked that they publish Twists)
        cmd_topic = None
        for name in ("move_next", "move_distance", "move_angle"):
            conn = (self.robot_spec.get("connections") or {}).get(name)
            if conn and conn.get("ros_topic"):
                cmd_topic = cmd_topic or conn["ros_topic"]
        self.cmd_topic = cmd_topic or "/cmd_vel"
        try:
            self._cmd = self.transport.publisher(self.cmd_topic, "geometry_msgs/msg/Twist")
            # observations
            for name, conn in (self.robot_spec.get("connections") or {}).items():
                if conn.get("connection") not in ("ros_to_api", "roscache_to_api") or not conn.get("ros_topic"):
                    continue
                ros_type = normalise_type(conn["ros_type"])  # ros2_config checked that a topic has its type
                # Not in the schema: which translation a connection needs depends on this package's tables.
                path = conn.get("callback_robot") or _DEFAULT_CONVERTERS.get(name) or _BY_TYPE.get(ros_type)
                if path is None:
                    raise BackendError(f"connection '{name}' ({ros_type}) needs a callback_robot translation",
                                       "give callback_robot: 'module:function' returning the observation")
                self._converters[name] = _import_callable(path)
                self._latest[name] = _Latest()
                self.transport.subscribe(conn["ros_topic"], ros_type, self._receiver(name))
            self._latest["_odom"] = _Latest()
            self.transport.subscribe(self.cfg["odom_topic"], "nav_msgs/msg/Odometry", self._on_odom)
            self._latest["_tf"] = _Latest()
            self.transport.subscribe(self.cfg["tf_topic"], "tf2_msgs/msg/TFMessage", self._on_tf)
            self.transport.subscribe(self.cfg["tf_static_topic"], "tf2_msgs/msg/TFMessage",
                                     lambda m: self._on_tf(m, static=True), latched=True)
            if self.cfg["reset"] == "topic":
                self._reset_pub = self.transport.publisher(self.cfg["reset_topic"], "std_msgs/msg/String")
                self.transport.subscribe(self.cfg["reset_done_topic"], "std_msgs/msg/String", self._on_reset_done,
                                         reliable=True)
        except KeyError as exc:
            raise BackendError(str(exc.args[0]), "use one of the supported ROS 2 message types (docs/ros2.md)") from exc

    # ------------------------------------------------------------------------------------------ receivers
    def _reject(self, name: str, exc: Exception) -> None:
        self.rejected[name] = self.rejected.get(name, 0) + 1
        self.last_problem = f"{name}: {exc}"

    def _receiver(self, name: str) -> Callable[[Any], None]:
        convert = self._converters[name]

        def receive(msg: Any) -> None:
            try:
                value = convert(msg)
            except Exception as exc:  # noqa: BLE001 - malformed message: keep the previous one
                self._reject(name, exc)
                return
            self._latest[name].set(value)
            if name in self._watches:
                self._watches[name].note(header_stamp_s(msg))

        return receive

    def _on_odom(self, msg: Any) -> None:
        from benchbot_robot_ros2.convert import odometry_se2

        try:
            se2 = odometry_se2(msg)
        except Exception as exc:  # noqa: BLE001
            self._reject("odometry", exc)
            return
        self._latest["_odom"].set(se2)
        self._watches["odometry"].note(header_stamp_s(msg))

    def _on_tf(self, msg: Any, static: bool = False) -> None:
        try:
            self.tf.add_message(msg, static=static)
        except Exception as exc:  # noqa: BLE001
            self._reject("tf", exc)
            return
        if not static:
            self._latest["_tf"].set(True)
            self._watches["tf"].note(header_stamp_s(msg))

    def _on_reset_done(self, msg: Any) -> None:
        try:
            data = json.loads(str(msg.data))
            rid = str(data["id"])
        except Exception as exc:  # noqa: BLE001
            self._reject("reset_done", exc)
            return
        with self._reset_cond:
            self._reset_acks[rid] = data
            self._reset_cond.notify_all()

    # ------------------------------------------------------------------------------------------ safety
    def stop(self) -> None:
        """Publish a zero Twist (best effort: never raises)."""
        try:
            from benchbot_robot_ros2.convert import fill_twist

            self._cmd.publish(fill_twist(self.transport.message("geometry_msgs/msg/Twist"), 0.0, 0.0))
        except Exception:  # noqa: BLE001
            pass

    def _fault(self, message: str, hint: str) -> RobotFaultError:
        self.stop()
        self.stop()
        return RobotFaultError(message, hint)

    def _make_watches(self) -> dict[str, SilenceWatch]:
        """One :class:`~benchbot_robot_ros2.watchdog.SilenceWatch` per watched topic: ``odometry``, ``tf`` and
        the laser connection (``laser``) when the robot has one."""
        limit = self.cfg["sensor_timeout_s"]
        period = 1.0 / (self.cfg["rate_hz"] * self.cfg["time_scale"])
        # a check at most this late still counts in full; later ones (a starved process) count no more than this
        max_step = max(2.0 * period, 0.1)
        setting = f"ros2.sensor_timeout_s of robot '{self.robot_spec.get('name')}'"
        topics = {"odometry": self.cfg["odom_topic"], "tf": self.cfg["tf_topic"]}
        laser = (self.robot_spec.get("connections") or {}).get("laser") or {}
        if laser.get("ros_topic"):
            topics["laser"] = laser["ros_topic"]
        return {what: SilenceWatch(what, topic, limit, max_step, setting) for what, topic in topics.items()}

    def _watched(self) -> dict[str, SilenceWatch]:
        """The watches a motion checks: odometry; TF with ``ground_truth: tf``; the laser when the safety check
        uses it."""
        out = {"odometry": self._watches["odometry"]}
        if self.cfg["ground_truth"] == "tf":
            out["tf"] = self._watches["tf"]
        if "laser" in self._watches and "laser" in self._latest and self.cfg["safety_distance_m"] > 0:
            out["laser"] = self._watches["laser"]
        return out

    def _check_fresh(self) -> None:
        """Take what DDS has queued for the watched topics (``Transport.poll``), then judge each
        (:meth:`SilenceWatch.check`): a topic that sent nothing new over ``sensor_timeout_s`` of punctual control
        periods is a fault.

        Raises:
            RobotFaultError: (after a zero Twist) one line naming the topic, its last header stamp and the setting
                ``ros2.sensor_timeout_s``.
        """
        watched = self._watched()
        self.transport.poll([w.topic for w in watched.values()])
        now = time.monotonic()
        for watch in watched.values():
            watch.check(now)
            if watch.silent:
                raise self._fault(watch.fault_line(),
                                  "check the robot's drivers and the network (ROS_DOMAIN_ID, CYCLONEDDS_URI); a "
                                  f"slower sensor needs a larger {watch.setting}")

    def _await_fresh(self) -> None:
        """Before a motion: wait until every watched topic has sent a new message (one control period or so).

        Raises:
            RobotFaultError: a topic sent nothing new within ``sensor_timeout_s`` (see :meth:`_check_fresh`).
        """
        watched = self._watched()
        now = time.monotonic()
        for watch in watched.values():
            watch.restart(now)
        period = 1.0 / (self.cfg["rate_hz"] * self.cfg["time_scale"])
        while True:
            self._check_fresh()
            if all(w.fresh for w in watched.values()):
                return
            time.sleep(period / 2)

    def _blocked(self, v: float, dt: float) -> bool:
        """Whether the next step at forward speed ``v`` (m/s) for ``dt`` (s) would bring the footprint within the
        safety distance of a laser return (points in the robot frame, straight-line sweep)."""
        s = self.cfg["safety_distance_m"]
        scan = self._latest.get("laser")
        if s <= 0 or scan is None or scan.value is None or abs(v) < 1e-6:
            return False
        r = self.cfg["footprint_radius_m"] + s
        rng, ang = scan.value["scans"][:, 0], scan.value["scans"][:, 1]
        valid = (rng > scan.value["range_min"]) & (rng < scan.value["range_max"])
        px, py = rng[valid] * np.cos(ang[valid]), rng[valid] * np.sin(ang[valid])
        try:
            T = self.tf.lookup(self.base_frame, self._laser_frame) if self._laser_frame else np.eye(4)
        except LookupError:
            T = np.eye(4)
        x = T[0, 0] * px + T[0, 1] * py + T[0, 3]
        y = T[1, 0] * px + T[1, 1] * py + T[1, 3]
        if v < 0:
            x = -x
        inside = np.abs(y) < r
        if not np.any(inside):
            return False
        # distance the centre can still travel before the circle of radius r touches each point
        free = x[inside] - np.sqrt(np.maximum(r * r - y[inside] ** 2, 0.0))
        ahead = x[inside] > -1e-9
        return bool(np.any(free[ahead] < abs(v) * dt + 1e-6))

    @property
    def _laser_frame(self) -> str | None:
        scan = self._latest.get("laser")
        frames = self.cfg.get("frames") or {}
        return frames.get("lidar", "lidar") if scan is not None else None

    # ------------------------------------------------------------------------------------------ contract
    def _wait_ready(self, t0: float, timeout: float) -> None:
        """Wait until odometry, TF (global → base) and every observation topic have a message received after
        ``t0``. Raises RobotFaultError naming the missing topics."""
        deadline = time.monotonic() + timeout
        for name, latest in self._latest.items():
            if latest.wait_after(t0, max(deadline - time.monotonic(), 0.0)) is None:
                topic = {"_odom": self.cfg["odom_topic"], "_tf": self.cfg["tf_topic"]}.get(name) or \
                    self.robot_spec["connections"][name]["ros_topic"]
                raise self._fault(f"ROS 2 robot '{self.robot_spec.get('name')}': no valid message on {topic} within "
                                  f"{timeout:.0f} s" + (f" (last problem: {self.last_problem})" if self.last_problem
                                                        else ""),
                                  "is the robot (or `benchbot ros2 serve-sim`) running on the same ROS_DOMAIN_ID?")
        while True:
            try:
                self.base_pose()
                return
            except BackendError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.05)

    def load_scene(self, environment: dict, *, seed: int = 0) -> None:
        """Put the robot at the environment's start pose: ``reset: topic`` asks the simulator (a ``std_msgs/String``
        JSON ``{id, environment, start_pose, seed}`` on ``reset_topic``, answered with ``{id, ok, error}`` on
        ``reset_done_topic``); ``reset: drive`` drives there with the pose controller. Then waits for fresh
        messages on every topic.

        Raises:
            BackendError: no answer/topics within ``startup_timeout_s``, the simulator refused, or the robot could
                not drive back.
        """
        start = start_pose_to_se2(environment["start_pose"])
        timeout = self.cfg["startup_timeout_s"]
        self.stop()
        if self.cfg["reset"] == "topic":
            rid = uuid.uuid4().hex
            payload = json.dumps({"id": rid, "environment": f"{environment['name']}:{environment['variant']}",
                                  "start_pose": list(map(float, environment["start_pose"])), "seed": int(seed)})
            deadline = time.monotonic() + timeout
            msg = self.transport.message("std_msgs/msg/String")
            msg.data = payload
            with self._reset_cond:
                while rid not in self._reset_acks:
                    if time.monotonic() > deadline:
                        raise BackendError(f"the simulator did not answer the reset on {self.cfg['reset_topic']} "
                                           f"within {timeout:.0f} s",
                                           "start it with `benchbot ros2 serve-sim --env ENV` on the same domain")
                    self._reset_cond.release()
                    try:
                        self._reset_pub.publish(msg)
                    finally:
                        self._reset_cond.acquire()
                    self._reset_cond.wait(0.5)
                ack = self._reset_acks.pop(rid)
            if not ack.get("ok", False):
                raise BackendError(f"the simulator refused the reset: {ack.get('error', 'unknown error')}",
                                   "check the environment name and the simulator's log")
            self._wait_ready(time.monotonic(), timeout)
        else:
            self._wait_ready(-math.inf, timeout)
            outcome = self.move_to(start)
            err = se2_relative(self.base_pose(), start)
            if outcome.collided or math.hypot(err[0], err[1]) > 0.05:
                raise BackendError(f"the robot could not drive back to the start pose {np.round(start, 3).tolist()}"
                                   f" (now {np.round(self.base_pose(), 3).tolist()})",
                                   "clear the way, or place the robot at the start pose by hand")
        self._scene_start = start
        self._fresh_after = time.monotonic()

    def base_pose(self) -> np.ndarray:
        """(3,) ``[x m, y m, yaw rad]`` of the base in the global frame: TF ``global_frame → base_frame``
        (``ground_truth: tf``) or the odometry pose (``ground_truth: odometry``).

        Raises:
            RobotFaultError: TF lost / no odometry (after publishing a zero Twist).
        """
        from benchbot_robot_ros2.convert import matrix_to_se2
        from benchbot_robot_ros2.tf import TfLookupError

        if self.cfg["ground_truth"] == "odometry":
            value = self._latest["_odom"].value
            if value is None:
                raise self._fault("no odometry received yet", f"is {self.cfg['odom_topic']} published?")
            return np.asarray(value, dtype=np.float64).copy()
        try:
            return matrix_to_se2(self.tf.lookup(self.global_frame, self.base_frame))
        except TfLookupError as exc:
            raise self._fault(f"TF lost: {exc}", f"is the localiser publishing {self.global_frame} → "
                                                 f"{self.base_frame} on {self.cfg['tf_topic']}?") from exc

    def odometry_pose(self) -> np.ndarray:
        """(3,) ``[x, y, yaw]``: the newest odometry pose (in the odometry message's frame, usually ``odom``): what
        a dead-reckoning robot believes. Raises RobotFaultError without odometry."""
        value = self._latest["_odom"].value
        if value is None:
            raise self._fault("no odometry received yet", f"is {self.cfg['odom_topic']} published?")
        return np.asarray(value, dtype=np.float64).copy()

    def move_to(self, goal: np.ndarray) -> MotionOutcome:
        """Drive to ``goal`` (3,) ``[x, y, yaw]`` (global frame) with the pose controller at ``rate_hz``,
        publishing Twists on the actions' topic; stops before a laser-detected contact (``collided=True``).

        Raises:
            RobotFaultError: a fault (see the module doc); the robot was stopped. BackendError: the backend is
                closed.
        """
        if self._closed:
            raise BackendError("the ROS 2 backend is closed", "")
        from benchbot_robot_ros2.convert import fill_twist

        goal = np.asarray(goal, dtype=np.float64).reshape(3)
        ctl = PoseController(goal, self.gains)
        scale = self.cfg["time_scale"]
        dt = 1.0 / self.gains.rate_hz
        period = dt / scale
        collided = False
        self._moving = True
        try:
            self._await_fresh()
            t_start = next_t = time.monotonic()
            while True:
                self._check_fresh()
                cmd = ctl.command(self.base_pose())
                if cmd is None:
                    break
                if self._blocked(cmd[0], dt):
                    collided = True
                    break
                self._cmd.publish(fill_twist(self.transport.message("geometry_msgs/msg/Twist"), cmd[0], cmd[1]))
                next_t += period
                time.sleep(max(next_t - time.monotonic(), 0.0))
        except BaseException:
            self.stop()
            raise
        finally:
            self._moving = False
        self.stop()
        time.sleep(self.gains.settle_s / scale)
        self.stop()
        self._fresh_after = time.monotonic()
        return MotionOutcome(collided=collided, duration_s=(time.monotonic() - t_start) * scale)

    def frame_transforms(self) -> dict[str, np.ndarray]:
        """``T_global_<frame>`` (4, 4) for the spec's ``poses`` (TF frames mapped by ``ros2.frames``; ``robot`` →
        ``base_frame``).

        Raises:
            RobotFaultError: a frame is not in TF (after a zero Twist).
        """
        from benchbot_robot_ros2.tf import TfLookupError

        frames = dict(self.cfg.get("frames") or {})
        frames.setdefault(self.robot_spec.get("robot_frame", "robot"), self.base_frame)
        frames.setdefault("robot", self.base_frame)
        out = {}
        names = [n for n in self.robot_spec.get("poses", ["robot"]) if n != "initial_pose"]
        for name in dict.fromkeys(names + ["robot"]):
            tf_name = frames.get(name, name)
            try:
                if self.cfg["ground_truth"] == "odometry" and tf_name == self.base_frame:
                    out[name] = se2_to_matrix(*self.base_pose())
                else:
                    out[name] = self.tf.lookup(self.global_frame, tf_name)
            except TfLookupError as exc:
                raise self._fault(f"TF lost: {exc}", f"is frame '{tf_name}' published on /tf or /tf_static?") from exc
        return out

    def observe(self, names: Sequence[str]) -> dict[str, Any]:
        """Observations in the structures of docs/observations.md, each from a message received after the last
        motion ended (waits up to ``observation_timeout_s``).

        Raises:
            KeyError: a name this robot has no topic for. RobotFaultError: no fresh message in time.
        """
        for n in names:
            if n not in self._latest or n.startswith("_"):
                raise KeyError(n)
        out: dict[str, Any] = {}
        for n in names:
            value = self._latest[n].wait_after(self._fresh_after, self.cfg["observation_timeout_s"])
            if value is None:
                raise self._fault(f"no fresh message for '{n}' on {self.robot_spec['connections'][n]['ros_topic']} "
                                  f"within {self.cfg['observation_timeout_s']:.1f} s"
                                  + (f" (last problem: {self.last_problem})" if self.last_problem else ""),
                                  "check the sensor driver")
            out[n] = _copy(value)
        return out

    def close(self) -> None:
        """Stop the robot and release the transport."""
        if self._closed:
            return
        self.stop()
        self._closed = True
        if self._own_transport:
            self.transport.close()


def _copy(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.copy()
    if isinstance(value, dict):
        return {k: _copy(v) for k, v in value.items()}
    return value


def create_backend(robot_spec: dict, options: dict) -> Ros2RobotBackend:
    """Factory of the ``ros2`` robot type: ``create_backend(robot_spec, options) -> Ros2RobotBackend``."""
    return Ros2RobotBackend(robot_spec, options)
