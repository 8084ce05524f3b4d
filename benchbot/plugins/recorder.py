"""Recording episodes as MCAP files with ROS 2 messages (readable by Foxglove, ``ros2 bag`` and rosbags).

:class:`EpisodeRecorder` is an observer: it is registered on the registry's plugin manager (its
``benchbot_step`` / ``benchbot_episode_finished`` hook implementations run on the backend thread) and attached to
the episode it records (:func:`attach_recorder`). It renders nothing itself: after every step it writes the
observations the episode last produced (``Episode.last_observation``), the ground-truth frames and the motion made.

Time: the simulated time (the sum of the motions' durations; 1 s per step when a backend reports none), counted
from the wall-clock time the recording started (so viewers show the real date). Every message's log time, publish
time and header stamp are that time.

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

Every channel carries ``offered_qos_profiles`` (rosbag2's Jazzy YAML: reliable, volatile, keep-last 10;
``/tf_static`` transient-local, keep-last 1) and ``topic_type_hash`` (the type's RIHS01 hash) metadata, as
``ros2 bag record`` writes them, so ``ros2 bag play`` republishes with the right QoS.

Metadata records (each ``{'json': <JSON text>}``): ``benchbot.run`` (task, robot, environment specs as the API
serves them (:func:`~benchbot.core.episode.served_environment`: no ground-truth file named), seed,
options, results format), ``benchbot.clock`` (``start_ns``: the time of the start, ns since the Unix epoch;
``clock``: ``simulated``), ``benchbot.steps`` (per step: ``step``, ``action``, ``args``, ``result``,
``scene_number``, ``pose`` [x, y, yaw], ``collided``, ``duration_s``, ``time_ns``), ``benchbot.frames`` (per
recorded observation: ``step``, ``time_ns``, ``scene_number``, ``names``, the ``image_segment`` class ids, and
``info_frame_ids`` when an ``image_*_info`` observation named a frame other than the camera's TF frame).
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from benchbot.core.episode import served_environment
from benchbot.core.errors import UsageError
from benchbot.core.geometry import matrix_to_quaternion_xyzw, se2_relative
from benchbot.core.hookspecs import hookimpl

SEP = "=" * 80

_TIME = "int32 sec\nuint32 nanosec\n"
_HEADER = "builtin_interfaces/Time stamp\nstring frame_id\n"
_VECTOR3 = "float64 x\nfloat64 y\nfloat64 z\n"
_QUATERNION = "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n"
_ROI = "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify\n"
_TRANSFORM = "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n"
_TRANSFORM_STAMPED = "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform\n"


def _concat(main: str, deps: list[tuple[str, str]]) -> str:
    return main + "".join(f"{SEP}\nMSG: {name}\n{text}" for name, text in deps)


MSGDEFS: dict[str, str] = {
    "sensor_msgs/msg/Image": _concat(
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\n"
        "uint8[] data\n",
        [("std_msgs/Header", _HEADER), ("builtin_interfaces/Time", _TIME)]),
    "sensor_msgs/msg/CameraInfo": _concat(
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\nfloat64[] d\nfloat64[9] k\n"
        "float64[9] r\nfloat64[12] p\nuint32 binning_x\nuint32 binning_y\nsensor_msgs/RegionOfInterest roi\n",
        [("std_msgs/Header", _HEADER), ("builtin_interfaces/Time", _TIME), ("sensor_msgs/RegionOfInterest", _ROI)]),
    "sensor_msgs/msg/LaserScan": _concat(
        "std_msgs/Header header\nfloat32 angle_min\nfloat32 angle_max\nfloat32 angle_increment\n"
        "float32 time_increment\nfloat32 scan_time\nfloat32 range_min\nfloat32 range_max\nfloat32[] ranges\n"
        "float32[] intensities\n",
        [("std_msgs/Header", _HEADER), ("builtin_interfaces/Time", _TIME)]),
    "tf2_msgs/msg/TFMessage": _concat(
        "geometry_msgs/TransformStamped[] transforms\n",
        [("geometry_msgs/TransformStamped", _TRANSFORM_STAMPED), ("std_msgs/Header", _HEADER),
         ("builtin_interfaces/Time", _TIME), ("geometry_msgs/Transform", _TRANSFORM),
         ("geometry_msgs/Vector3", _VECTOR3), ("geometry_msgs/Quaternion", _QUATERNION)]),
    "geometry_msgs/msg/Twist": _concat(
        "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n", [("geometry_msgs/Vector3", _VECTOR3)]),
}
"""The standard ROS 2 message definitions (ros2msg text with the dependencies appended), by datatype."""

TOPICS = {
    "image_rgb": ("/camera/color/image_raw", "sensor_msgs/msg/Image"),
    "image_rgb_info": ("/camera/color/camera_info", "sensor_msgs/msg/CameraInfo"),
    "image_depth": ("/camera/depth/image_raw", "sensor_msgs/msg/Image"),
    "image_depth_info": ("/camera/depth/camera_info", "sensor_msgs/msg/CameraInfo"),
    "segment_class": ("/camera/segment/class", "sensor_msgs/msg/Image"),
    "segment_instance": ("/camera/segment/instance", "sensor_msgs/msg/Image"),
    "laser": ("/scan", "sensor_msgs/msg/LaserScan"),
    "tf": ("/tf", "tf2_msgs/msg/TFMessage"),
    "cmd_vel": ("/cmd_vel", "geometry_msgs/msg/Twist"),
}
"""``{key: (topic, datatype)}``."""

TF_STATIC = ("/tf_static", "tf2_msgs/msg/TFMessage")

TYPE_HASHES = {
    "sensor_msgs/msg/Image": "RIHS01_d31d41a9a4c4bc8eae9be757b0beed306564f7526c88ea6a4588fb9582527d47",
    "sensor_msgs/msg/CameraInfo": "RIHS01_b3dfd68ff46c9d56c80fd3bd4ed22c7a4ddce8c8348f2f59c299e73118e7e275",
    "sensor_msgs/msg/LaserScan": "RIHS01_64c191398013af96509d518dac71d5164f9382553fce5c1f8cca5be7924bd828",
    "tf2_msgs/msg/TFMessage": "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087",
    "geometry_msgs/msg/Twist": "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a",
}
"""ROS 2 Jazzy's RIHS01 type hash (REP 2011) of each recorded datatype (channel metadata ``topic_type_hash``)."""


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


def ros_ranges(ranges: np.ndarray, range_max: float) -> np.ndarray:
    """Laser ranges (N,) metres, no return read as ``range_max`` (the API's convention) → float32 with +Inf for no
    return (REP 117)."""
    r = np.asarray(ranges, dtype=np.float32).reshape(-1).copy()
    r[~(r < np.float32(range_max))] = np.inf
    return r


def ros_depth(depth: np.ndarray) -> np.ndarray:
    """Depth (H, W) metres, 0.0 where nothing is hit (the API's convention) → float32 with NaN there (REP 118)."""
    d = np.asarray(depth, dtype=np.float32).copy()
    d[~(d > 0) | ~np.isfinite(d)] = np.nan
    return d


def wrap_angle_min(a: float) -> float:
    """``a`` (rad) wrapped to [-π, π); within 1e-6 below +π counts as -π (a float32 -π wrapped around)."""
    a = (float(a) + math.pi) % (2.0 * math.pi) - math.pi
    return -math.pi if a >= math.pi - 1e-6 else max(a, -math.pi)


DEFAULT_STEP_S = 1.0


def _stamp(time_ns: int) -> dict:
    return {"sec": int(time_ns // 1_000_000_000), "nanosec": int(time_ns % 1_000_000_000)}


def _header(time_ns: int, frame_id: str) -> dict:
    return {"stamp": _stamp(time_ns), "frame_id": frame_id}


def image_message(array: np.ndarray, encoding: str, frame_id: str, time_ns: int) -> dict:
    """A ``sensor_msgs/msg/Image`` dict for ``array`` (H, W[, C]) in ``encoding`` (little-endian, dense rows)."""
    array = np.ascontiguousarray(array)
    h, w = array.shape[:2]
    return {"header": _header(time_ns, frame_id), "height": h, "width": w, "encoding": encoding,
            "is_bigendian": 0, "step": int(array.strides[0]), "data": array.tobytes()}


def camera_info_message(info: dict, time_ns: int, frame_id: str | None = None) -> dict:
    """A ``sensor_msgs/msg/CameraInfo`` dict from an ``image_*_info`` observation (plumb-bob, zero distortion), in
    ``frame_id`` (default: the observation's ``frame_id``)."""
    return {"header": _header(time_ns, frame_id or info.get("frame_id", "camera")), "height": int(info["height"]),
            "width": int(info["width"]), "distortion_model": "plumb_bob", "d": [0.0] * 5,
            "k": np.asarray(info["matrix_intrinsics"], dtype=np.float64).ravel().tolist(),
            "r": np.eye(3).ravel().tolist(),
            "p": np.asarray(info["matrix_projection"], dtype=np.float64).ravel().tolist(),
            "binning_x": 0, "binning_y": 0,
            "roi": {"x_offset": 0, "y_offset": 0, "height": 0, "width": 0, "do_rectify": False}}


def laser_message(laser: dict, frame_id: str, time_ns: int) -> dict:
    """A ``sensor_msgs/msg/LaserScan`` from a ``laser`` observation (rows ``[range, angle]`` at uniform angles):
    ``angle_min`` wrapped to [-π, π), ``angle_max = angle_min + (N - 1) · increment``, no return (``range_max``)
    as +Inf (REP 117)."""
    scans = np.asarray(laser["scans"], dtype=np.float64)
    n = len(scans)
    a0 = wrap_angle_min(scans[0, 1]) if n else 0.0
    inc = float((scans[1, 1] - a0 + math.pi) % (2 * math.pi) - math.pi) if n > 1 else 0.0
    return {"header": _header(time_ns, frame_id), "angle_min": a0, "angle_max": a0 + inc * max(n - 1, 0),
            "angle_increment": inc, "time_increment": 0.0, "scan_time": 0.0,
            "range_min": float(laser["range_min"]), "range_max": float(laser["range_max"]),
            "ranges": ros_ranges(scans[:, 0], laser["range_max"]).tolist() if n else [], "intensities": []}


def transform_message(T: np.ndarray, parent: str, child: str, time_ns: int) -> dict:
    """A ``geometry_msgs/msg/TransformStamped`` for ``T`` (4, 4) ``T_parent_child``."""
    q = matrix_to_quaternion_xyzw(T[:3, :3])
    return {"header": _header(time_ns, parent), "child_frame_id": child,
            "transform": {"translation": dict(zip("xyz", map(float, T[:3, 3]))),
                          "rotation": dict(zip("xyzw", map(float, q)))}}


class EpisodeRecorder:
    """Writes one episode to ``path`` (an ``.mcap`` file, written to ``path.tmp`` and renamed when finished).

    Args:
        path: the MCAP file to write.
        run: the run's specs: ``{'task', 'robot', 'environments', 'results_format'}`` (dicts) plus ``seed``
            (int) and ``options`` (dict); stored as the ``benchbot.run`` metadata. Its ``robot`` names the frames
            (:func:`tf_frames`).

    Attributes:
        start_ns: the recording's time origin, ns since the Unix epoch (the wall clock at :meth:`attach`, whole ms).
        time_ns: the current simulated time, ns since the Unix epoch.
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
        self.steps: list[dict] = []
        self.frames: list[dict] = []
        self._recorded_obs: Any = None
        self._last_duration: float | None = None
        self._pose_before: np.ndarray | None = None
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
        for datatype, text in MSGDEFS.items():
            self._schemas[datatype] = self.writer.register_schema(datatype, "ros2msg", text.encode())
            self._encoders[datatype] = serialize_dynamic(datatype, text)[datatype]
        self.start_ns = self.time_ns = time.time_ns() // 1_000_000 * 1_000_000
        backend = episode.backend
        original_move_to = backend.move_to

        def move_to(goal: np.ndarray):  # the motion's duration gives the simulated time
            outcome = original_move_to(goal)
            self._last_duration = float(getattr(outcome, "duration_s", 0.0) or 0.0)
            return outcome

        backend.move_to = move_to  # instance attribute: shadows the method for this backend only
        self._pose_before = np.asarray(backend.base_pose(), dtype=np.float64)
        self._write_tf()

    def _channel(self, topic: str, datatype: str) -> int:
        if topic not in self._channels:
            self._channels[topic] = self.writer.register_channel(
                topic, "cdr", self._schemas[datatype],
                {"offered_qos_profiles": offered_qos_profiles(latched=topic == TF_STATIC[0]),
                 "topic_type_hash": TYPE_HASHES[datatype]})
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
        cam, lidar = self.tf_names["camera"], self.tf_names["lidar"]
        try:
            frame = {"step": step, "time_ns": t, "scene_number": int(obs.get("scene_number", 0)),
                     "names": sorted(k for k in obs if k not in ("scene_number", "poses"))}
            if "image_rgb" in obs:
                self._write("image_rgb", image_message(obs["image_rgb"], "rgb8", cam, t))
            if "image_depth" in obs:
                self._write("image_depth", image_message(ros_depth(obs["image_depth"]), "32FC1", cam, t))
            for name in ("image_rgb_info", "image_depth_info"):
                if name in obs:
                    self._write(name, camera_info_message(obs[name], t, cam))
                    if obs[name].get("frame_id", cam) != cam:
                        frame.setdefault("info_frame_ids", {})[name] = obs[name]["frame_id"]
            if "laser" in obs:
                self._write("laser", laser_message(obs["laser"], lidar, t))
            if "image_segment" in obs:
                seg = obs["image_segment"]
                self._write("segment_class", image_message(np.asarray(seg["class_segment_img"], np.uint8), "mono8", cam, t))
                self._write("segment_instance", image_message(np.asarray(seg["instance_segment_img"], np.int32), "32SC1", cam, t))
                frame["class_ids"] = dict(seg.get("class_ids", {}))
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
                                                                        "clock": "simulated"})})
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
        service: the :class:`~benchbot.core.server.BackendService` running the episode.
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
