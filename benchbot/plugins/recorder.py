"""Recording episodes as MCAP files with ROS 2 messages (readable by Foxglove, ``ros2 bag`` and rosbags).

:class:`EpisodeRecorder` is an observer: it is registered on the registry's plugin manager (its
``benchbot_step`` / ``benchbot_episode_finished`` hook implementations run on the backend thread) and attached to
the episode it records (:func:`attach_recorder`). It renders nothing itself: after every step it writes the
observations the episode last produced (``Episode.last_observation``), the ground-truth frames and the motion made.

Time (:func:`benchbot.core.robot.episode_clock`): in a simulator (``clock: simulated``) the simulated time, the sum
of the motions' durations (1 s per step when a backend reports none), counted from the wall-clock time the
recording started (so viewers show the real date); on a real robot (an environment of type ``real``, ``clock:
wall``) the wall clock at each step. Every message's log time, publish time and header stamp are that time.

Frames (:func:`tf_frames`): one name per frame, from the robot definition, in every header and transform: the
robot's ``global_frame`` (``map``); for a ROS 2 robot (type ``ros2``) the TF frames of its ``ros2`` block
(``ros2.frames.robot`` or ``ros2.base_frame``, ``ros2.frames.camera``, ``ros2.frames.lidar``), otherwise
``robot_frame`` (``robot``), ``camera`` (optical) and ``lidar``.

==============================  ===============================  ==========================================
topic                           type                             content
==============================  ===============================  ==========================================
``/camera/color/image_raw``     ``sensor_msgs/msg/Image``        ``image_rgb``, ``rgb8``
``/camera/color/camera_info``   ``sensor_msgs/msg/CameraInfo``   ``image_rgb_info`` (K, P; no distortion)
``/camera/depth/image_raw``     ``sensor_msgs/msg/Image``        ``image_depth``, ``32FC1`` metres; NaN where
                                                                 nothing is hit (REP 118; the API's 0.0)
``/camera/depth/camera_info``   ``sensor_msgs/msg/CameraInfo``   ``image_depth_info``
``/camera/segment/class``       ``sensor_msgs/msg/Image``        ``image_segment`` class ids, ``mono8``
``/camera/segment/instance``    ``sensor_msgs/msg/Image``        ``image_segment`` instance ids, ``32SC1``
``/scan``                       ``sensor_msgs/msg/LaserScan``    ``laser`` (ranges float32, m; +Inf where no
                                                                 return, REP 117; ``angle_min`` in [-π, π))
``/tf``                         ``tf2_msgs/msg/TFMessage``       map → robot (ground truth), every step
``/tf_static``                  ``tf2_msgs/msg/TFMessage``       robot → camera, robot → lidar (at the start,
                                                                 and again if they change)
``/cmd_vel``                    ``geometry_msgs/msg/Twist``      the motion made (robot frame, m/s, rad/s)
==============================  ===============================  ==========================================

The observations' rows are their kinds' channels (:data:`benchbot.core.observations.BUILT_IN`): the recorder
writes, for every kind of the episode's (``Episode.observation_kinds``: a plugin's own kinds too, from the hook
``benchbot_observations``) in the step's observations, what the kind's ``to_messages`` makes of it, on the kind's
topics, with the type definitions of :data:`~benchbot.core.ros_messages.MSGDEFS` or the kind's ``message_types``.

Every channel carries ``offered_qos_profiles`` (rosbag2's Jazzy YAML: reliable, volatile, keep-last 10;
``/tf_static`` transient-local, keep-last 1) and ``topic_type_hash`` (the type's RIHS01 hash) metadata, as
``ros2 bag record`` writes them, so ``ros2 bag play`` republishes with the right QoS.

Metadata records (each ``{'json': <JSON text>}``): ``benchbot.run`` (task, robot, environment specs as the API
serves them (:func:`~benchbot.core.episode.served_environment`: no ground-truth file named), seed,
options, results format), ``benchbot.clock`` (``start_ns``: the time of the start, ns since the Unix epoch;
``clock``: ``simulated`` or ``wall``), ``benchbot.steps`` (per step: ``step``, ``action``, ``args``, ``result``,
``scene_number``, ``pose`` [x, y, yaw], ``collided``, ``duration_s``, ``time_ns``), ``benchbot.frames`` (per
recorded observation: ``step``, ``time_ns``, ``scene_number``, ``names``, the ``image_segment`` class ids, and
``info_frame_ids`` when an ``image_*_info`` observation named a frame other than the camera's TF frame).
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchbot.core import observations as observation_kinds
from benchbot.core.episode import served_environment
from benchbot.core.errors import UsageError
from benchbot.core.geometry import se2_relative
from benchbot.core.hookspecs import hookimpl
from benchbot.core.robot import episode_clock
from benchbot.core.ros_messages import MSGDEFS, transform_message

#: The recorder's own channels, ``{key: (topic, datatype)}``: the frames and the motion made. The observations'
#: channels are their kinds' (:mod:`benchbot.core.observations`: ``Channel``).
TOPICS = {
    "tf": ("/tf", "tf2_msgs/msg/TFMessage"),
    "cmd_vel": ("/cmd_vel", "geometry_msgs/msg/Twist"),
}

TF_STATIC = ("/tf_static", "tf2_msgs/msg/TFMessage")


def offered_qos_profiles(latched: bool = False) -> str:
    """The ``offered_qos_profiles`` channel metadata of rosbag2 (Jazzy, metadata version 9): one reliable profile,
    volatile keep-last 10, or transient-local keep-last 1 for a ``latched`` topic (``/tf_static``)."""
    infinite = "{sec: 9223372036, nsec: 854775807}"
    return ("- history: keep_last\n"
            f"  depth: {1 if latched else 10}\n"
            "  reliability: reliable\n"
            f"  durability: {'transient_local' if latched else 'volatile'}\n"
            f"  deadline: {infinite}\n"
            f"  lifespan: {infinite}\n"
            "  liveliness: automatic\n"
            f"  liveliness_lease_duration: {infinite}\n"
            "  avoid_ros_namespace_conventions: false")


def tf_frames(robot: dict) -> dict[str, str]:
    """The TF frame names a recording of ``robot`` (a robot spec) uses: ``{'map', 'robot', 'camera', 'lidar'}``.

    ``map`` is ``global_frame``. A ROS 2 robot (type ``ros2``, or a ``ros2`` block) names the others as its ROS
    side does: ``ros2.frames.robot`` (else ``ros2.base_frame``, else ``base_link``), ``ros2.frames.camera`` and
    ``ros2.frames.lidar`` (else ``camera``, ``lidar``); any other robot uses ``robot_frame`` (``robot``),
    ``camera`` and ``lidar``. Leading slashes are dropped.
    """
    ros2 = robot.get("ros2") if isinstance(robot.get("ros2"), dict) else None
    if ros2 is not None or robot.get("type") == "ros2":
        ros2 = ros2 or {}
        named = ros2.get("frames") if isinstance(ros2.get("frames"), dict) else {}
        out = {"robot": named.get("robot", ros2.get("base_frame", "base_link")),
               "camera": named.get("camera", "camera"), "lidar": named.get("lidar", "lidar")}
    else:
        out = {"robot": robot.get("robot_frame", "robot"), "camera": "camera", "lidar": "lidar"}
    out["map"] = robot.get("global_frame", "map")
    return {k: str(v).strip("/") or k for k, v in out.items()}


DEFAULT_STEP_S = 1.0


class EpisodeRecorder:
    """Writes one episode to ``path`` (an ``.mcap`` file, written to ``path.tmp`` and renamed when finished).

    Args:
        path: the MCAP file to write.
        run: the run's specs: ``{'task', 'robot', 'environments', 'results_format'}`` (dicts) plus ``seed``
            (int) and ``options`` (dict); stored as the ``benchbot.run`` metadata. Its ``robot`` names the frames
            (:func:`tf_frames`).

    Attributes:
        start_ns: the recording's time origin, ns since the Unix epoch (the wall clock at :meth:`attach`, whole ms).
        time_ns: the current time, ns since the Unix epoch: simulated, or the wall clock at the last step.
        clock: ``simulated`` or ``wall`` (:func:`~benchbot.core.robot.episode_clock` of the episode's environments,
            set by :meth:`attach`).
        tf_names: the TF frame names, :func:`tf_frames` of the robot. frames, steps: the metadata being built.

    Every method runs on the backend thread (observer hooks, or ``BackendService.call``).
    """

    def __init__(self, path: Path | str, run: dict) -> None:
        self.path = Path(path)
        self.run = run
        self.tf_names = tf_frames(run.get("robot") or {})
        self.episode: Any = None
        self.writer: Any = None
        self.start_ns = 0
        self.time_ns = 0
        self.clock = "simulated"
        self.steps: list[dict] = []
        self.frames: list[dict] = []
        self._recorded_obs: Any = None
        self._last_duration: float | None = None
        self._pose_before: np.ndarray | None = None
        self.kinds: dict[str, Any] = dict(observation_kinds.BUILT_IN)  # the episode's, from attach()
        self._types: dict[str, Any] = {}
        self._serialize: Any = None
        self._encoders: dict[str, Any] = {}
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._static: dict[str, np.ndarray] = {}
        self.closed = False

    # ------------------------------------------------------------------------------------------ lifecycle
    def attach(self, episode: Any) -> None:
        """Start recording ``episode`` (backend thread): opens the file, writes the frames at the start time.

        Raises:
            UsageError: the file (or its folder) cannot be created, or the ``record`` extra is not installed.
        """
        try:
            from mcap.writer import CompressionType, Writer
            from mcap_ros2._dynamic import serialize_dynamic
        except ImportError:
            raise UsageError("--record needs the MCAP writer", "install it: uv pip install 'benchbot[record]'") from None

        self.episode = episode
        self._tmp = self.path.with_name(f".{self.path.name}.tmp")
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = open(self._tmp, "wb")
        except OSError as exc:
            raise UsageError(f"{self.path}: cannot write the recording ({exc.strerror or exc})",
                             "choose a writable --record path") from None
        self.writer = Writer(self._file, compression=CompressionType.ZSTD)
        self.writer.start(profile="ros2", library="benchbot recorder")
        self.kinds = getattr(episode, "observation_kinds", None) or observation_kinds.BUILT_IN
        self._types = observation_kinds.message_types(self.kinds)
        self._serialize = serialize_dynamic
        for datatype in MSGDEFS:  # the standard types up front; another kind's type when first written
            self._schema(datatype)
        self.start_ns = self.time_ns = time.time_ns() // 1_000_000 * 1_000_000
        self.clock = episode_clock(getattr(episode, "environments", None) or [])
        backend = episode.backend
        original_move_to = backend.move_to

        def move_to(goal: np.ndarray):  # the motion's duration gives the simulated time
            outcome = original_move_to(goal)
            self._last_duration = float(getattr(outcome, "duration_s", 0.0) or 0.0)
            return outcome

        backend.move_to = move_to  # instance attribute: shadows the method for this backend only
        self._pose_before = np.asarray(backend.base_pose(), dtype=np.float64)
        self._write_tf()

    def _schema(self, datatype: str) -> int:
        """The schema id of ``datatype`` (registered, with its encoder, on first use)."""
        if datatype not in self._schemas:
            text = self._types[datatype].definition
            self._schemas[datatype] = self.writer.register_schema(datatype, "ros2msg", text.encode())
            self._encoders[datatype] = self._serialize(datatype, text)[datatype]
        return self._schemas[datatype]

    def _channel(self, topic: str, datatype: str) -> int:
        if topic not in self._channels:
            self._channels[topic] = self.writer.register_channel(
                topic, "cdr", self._schema(datatype),
                {"offered_qos_profiles": offered_qos_profiles(latched=topic == TF_STATIC[0]),
                 "topic_type_hash": self._types[datatype].type_hash})
        return self._channels[topic]

    def _write_to(self, topic: str, datatype: str, message: dict) -> None:
        self.writer.add_message(self._channel(topic, datatype), log_time=self.time_ns,
                                data=self._encoders[datatype](message), publish_time=self.time_ns)

    def _write(self, key: str, message: dict) -> None:
        self._write_to(*TOPICS[key], message)

    def _write_tf(self) -> None:
        """``/tf``: map → robot now; ``/tf_static``: robot → camera/lidar when first seen or changed."""
        f = self.tf_names
        frames = self.episode.backend.frame_transforms()
        T_map_robot = frames.get(self.episode.robot.get("robot_frame", "robot"), frames.get("robot"))
        T_robot_map = np.linalg.inv(T_map_robot)
        self._write("tf", {"transforms": [transform_message(T_map_robot, f["map"], f["robot"], self.time_ns)]})
        static = {name: T_robot_map @ frames[name] for name in ("camera", "lidar") if name in frames}
        if any(name not in self._static or not np.allclose(T, self._static[name], rtol=0, atol=1e-9)
               for name, T in static.items()):
            self._static = static
            self._write_to(*TF_STATIC, {"transforms": [transform_message(T, f["robot"], f[name], self.time_ns)
                                                       for name, T in static.items()]})

    def _flush_observation(self) -> None:
        """Write ``episode.last_observation`` if it is new (at the time of the step it was taken at)."""
        last = getattr(self.episode, "last_observation", None)
        if last is None or last[1] is self._recorded_obs:
            return
        step, obs = last
        self._recorded_obs = obs
        t = self.steps[step - 1]["time_ns"] if 0 < step <= len(self.steps) else (self.start_ns if step == 0
                                                                                 else self.time_ns)
        saved, self.time_ns = self.time_ns, t
        try:
            frame = {"step": step, "time_ns": t, "scene_number": int(obs.get("scene_number", 0)),
                     "names": sorted(k for k in obs if k != "scene_number"
                                     and (k not in self.kinds or self.kinds[k].sensor))}
            context = observation_kinds.RecordContext(t, self.tf_names, frame)
            for name, kind in self.kinds.items():  # in the kinds' order; what no kind channels is only named
                if name in obs and kind.channels:
                    messages = kind.to_messages(obs[name], context)
                    for channel in kind.channels:
                        if channel.key in messages:
                            self._write_to(channel.topic, channel.datatype, messages[channel.key])
            self.frames.append(frame)
        finally:
            self.time_ns = saved

    # ------------------------------------------------------------------------------------------ hooks
    @hookimpl
    def benchbot_step(self, info: dict) -> None:
        """After every action (backend thread): the previous observation, then this step's frames and motion."""
        if self.episode is None or self.closed:
            return
        self._flush_observation()
        duration = self._last_duration if self._last_duration and self._last_duration > 0 else DEFAULT_STEP_S
        self._last_duration = None
        pose = np.asarray(info["pose"], dtype=np.float64)
        before = self._pose_before if self._pose_before is not None else pose
        self._pose_before = pose
        if self.clock == "wall":  # a real robot: the time the step ended (never before the last one)
            self.time_ns = max(time.time_ns(), self.time_ns + 1)
        else:
            self.time_ns += int(round(duration * 1e9))
        self.steps.append({
            "step": int(info["step"]), "action": info.get("action"), "args": dict(info.get("args") or {}),
            "result": info.get("result"), "scene_number": int(info.get("scene_number", 0)),
            "pose": pose.tolist(), "collided": bool(self.episode.collided), "duration_s": duration,
            "time_ns": self.time_ns,
        })
        self._write_tf()
        delta = se2_relative(before, pose)  # the motion made, in the robot frame at its start
        self._write("cmd_vel", {"linear": {"x": float(delta[0] / duration), "y": float(delta[1] / duration), "z": 0.0},
                                "angular": {"x": 0.0, "y": 0.0, "z": float(delta[2] / duration)}})

    @hookimpl
    def benchbot_episode_finished(self, info: dict) -> None:
        """The episode ended: finish the file."""
        self.finish()

    def finish(self) -> None:
        """Write the last observation and the metadata, close the file and move it into place (idempotent;
        backend thread)."""
        if self.closed or self.writer is None:
            return
        self.closed = True
        self._flush_observation()
        self.writer.add_metadata("benchbot.run", {"json": json.dumps(self.run, default=_jsonable)})
        self.writer.add_metadata("benchbot.clock", {"json": json.dumps({"start_ns": self.start_ns,
                                                                        "clock": self.clock})})
        self.writer.add_metadata("benchbot.steps", {"json": json.dumps(self.steps)})
        self.writer.add_metadata("benchbot.frames", {"json": json.dumps(self.frames)})
        self.writer.finish()
        self._file.close()
        self._tmp.replace(self.path)


def _jsonable(obj: Any) -> Any:
    if hasattr(obj, "tolist"):
        return obj.tolist()
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


def attach_recorder(registry: Any, service: Any, run_spec: Any, path: Path | str, *, seed: int = 0,
                    options: dict | None = None) -> EpisodeRecorder:
    """Record ``service``'s episode to ``path``: registers an :class:`EpisodeRecorder` on ``registry``'s plugin
    manager and attaches it on the backend thread. Call :func:`detach_recorder` when the episode is over.

    Args:
        registry: the :class:`~benchbot.core.registry.Registry` whose hooks the episode calls.
        service: the :class:`~benchbot.server.BackendService` running the episode.
        run_spec: its :class:`~benchbot.core.session.RunSpec`.
        path: the ``.mcap`` file to write.
    """
    recorder = EpisodeRecorder(path, {  # environments as the API serves them: no file that holds ground truth
        "task": run_spec.task, "robot": run_spec.robot,
        "environments": [served_environment(e) for e in run_spec.environments],
        "results_format": run_spec.results_format, "env_string": run_spec.env_string, "seed": seed,
        "options": dict(options or {}),
    })
    service.call(recorder.attach, service.episode)
    registry.plugin_manager.register(recorder)
    return recorder


def detach_recorder(registry: Any, service: Any, recorder: EpisodeRecorder) -> Path:
    """Finish ``recorder``'s file (on the backend thread) and unregister it; returns the file's path."""
    try:
        service.call(recorder.finish)
    finally:
        if registry.plugin_manager.is_registered(recorder):
            registry.plugin_manager.unregister(recorder)
    return recorder.path
