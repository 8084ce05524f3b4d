"""Observation kinds: every observation a task can ask for, each declared once (docs/observations.md).

An :class:`ObservationKind` says what one observation is and how each part of BenchBot handles it:

* ``name``: its key in the observations a step returns (``image_rgb``), and its name in task and robot specs;
* ``structure``: its shapes, dtypes, units and frame in one line (the table of docs/observations.md);
* ``check``: its structure check, returning problems as one-line strings (:func:`problems`; the contract checks of
  :mod:`benchbot.plugins.testing`);
* ``channels``, ``to_messages``, ``from_messages``: the recorder's channels for it (topic, ROS 2 message type) and
  the converters to ROS 2 messages and back (:mod:`benchbot.plugins.recorder`, :mod:`benchbot.plugins.replay`);
  ``message_types`` gives the definition of a ROS 2 type that :data:`~benchbot.core.ros_messages.MSGDEFS` lacks;
* ``gym``: its entry in the Gymnasium observation space and the value there (:mod:`benchbot.gym`), if it has one;
* ``views``: what :class:`benchbot.api.tools.ObservationVisualiser` can draw of it;
* ``original_value``, ``original_callback_api``: its form on the original protocol's routes, if it has its own.

:data:`BUILT_IN` holds the seven kinds of docs/observations.md (``scene_number``, which the episode adds to every
step's observations, is none: no task asks for it). Plugins add kinds of their own sensors with the hook
``benchbot_observations``; the registry checks them (:func:`add_offered`) and keeps built-ins and plugins' kinds
together in ``Registry.observations``, which the episode (``Episode.observation_kinds``), the recorder, the replay,
the Gym environment and the contract checks read. A robot backend produces the kinds it has (``sensor``; ``poses``
is the episode's, from the backend's frame transforms).

Nothing here imports more than NumPy: the Gym space is built with the ``gymnasium.spaces`` module its caller passes,
a view draws on the matplotlib axes its caller passes.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Mapping

import numpy as np

from benchbot.core.ros_messages import (
    STANDARD_TYPES, MessageType, camera_info_message, image_array, image_message, laser_message, ros_depth,
)

#: Topics that no observation kind may use: the recorder's own (the frames ``/tf``, ``/tf_static`` and the motion
#: made, ``/cmd_vel``).
RESERVED_TOPICS = frozenset({"/tf", "/tf_static", "/cmd_vel"})

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_TOPIC = re.compile(r"^(/[A-Za-z_][A-Za-z0-9_]*)+$")
_DATATYPE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*/msg/[A-Za-z][A-Za-z0-9]*$")


@dataclass(frozen=True)
class Channel:
    """One recorder channel of an observation kind.

    Attributes:
        key: the channel's name, unique among every kind's channels (``segment_class``): the key of the dict that
            the kind's ``to_messages`` returns and that its ``from_messages`` asks for.
        topic: the ROS topic (``/camera/color/image_raw``): unique, none of :data:`RESERVED_TOPICS`.
        datatype: the ROS 2 message type (``sensor_msgs/msg/Image``): one of
            :data:`~benchbot.core.ros_messages.MSGDEFS`, or one the kind declares in ``message_types``.
    """

    key: str
    topic: str
    datatype: str


@dataclass
class RecordContext:
    """What a kind's ``to_messages`` gets besides the observation.

    Attributes:
        time_ns: the time of the observation (every header's stamp), int ns since the Unix epoch.
        frames: the recording's TF frame names: ``{'map', 'robot', 'camera', 'lidar'}`` →
            name (:func:`benchbot.plugins.recorder.tf_frames`); a message's ``frame_id`` is one of them.
        metadata: this observation's record in the recording's ``benchbot.frames`` metadata (JSON values), where a
            kind keeps what its messages cannot carry (``image_segment``'s ``class_ids``); ``from_messages`` gets
            it back. Leave its ``step``, ``time_ns``, ``scene_number`` and ``names`` as they are.
    """

    time_ns: int
    frames: dict[str, str]
    metadata: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class GymEntry:
    """An observation kind's entry in :class:`benchbot.gym.BenchBotEnv`'s ``gymnasium.spaces.Dict``.

    Attributes:
        key: the entry's key (``poses`` is served as ``pose``).
        space: ``space(spaces, value) -> gymnasium.spaces.Space``: ``spaces`` is the ``gymnasium.spaces`` module,
            ``value`` the kind's first observation (its sizes fix the space's shape).
        value: ``value(observation) -> numpy.ndarray``: the entry's value, inside the space, for an observation of
            the kind.
    """

    key: str
    space: Callable[[Any, Any], Any]
    value: Callable[[Any], np.ndarray]


@dataclass(frozen=True)
class View:
    """What :class:`benchbot.api.tools.ObservationVisualiser` draws of an observation kind, under an entry name.

    Attributes:
        name: the visualiser's entry (``image_class`` is a view of ``image_segment``).
        draw: ``draw(axes, observation)``: draws the kind's observation on a matplotlib ``Axes`` (cleared before).
        projection: the axes' projection (``'3d'``), None for flat axes.
    """

    name: str
    draw: Callable[[Any, Any], None]
    projection: str | None = None


@dataclass(frozen=True)
class ObservationKind:
    """One kind of observation, declared once (the module docstring says who reads each field).

    Attributes:
        name: the observation's key and its name in task and robot specs (letters, digits, ``_``).
        structure: its structure in one line: shapes, dtypes, units, frame (docs/observations.md).
        check: ``check(value, observations) -> [problem]``: one-line problems (each starting with the name) of the
            value; ``observations`` holds the step's other observations, for checks across them (an ``_info``'s
            size against its image). ``[]`` when it is well formed.
        sensor: True for what a robot backend's ``observe`` produces; False for what the episode builds
            (``poses``, from the backend's frame transforms): only the core declares such a kind.
        channels: the recorder's channels for it (none: it is not recorded as messages).
        message_types: definitions of the ROS 2 types of its channels that
            :data:`~benchbot.core.ros_messages.MSGDEFS` lacks.
        to_messages: ``to_messages(value, context) -> {channel key: message dict}``: the messages of one
            observation (:class:`RecordContext`); required with ``channels``. A channel left out writes nothing.
        from_messages: ``from_messages(message, metadata) -> value``: the observation back from its recorded
            messages; ``message(channel key)`` gives one decoded message (raises when the recording lacks it),
            ``metadata`` the record ``to_messages`` wrote to. Required with ``channels``; raise ``ValueError`` for a
            message it cannot read.
        gym: its Gym entry (:class:`GymEntry`), or None: left out of the Gym observation space.
        views: what the observation visualiser can draw of it (:class:`View`).
        original_value: ``original_value(value)``: its form on the original protocol's ``/connections/<name>``
            route, when it differs from the value (``image_rgb``: ``{'encoding': 'rgb8', 'data': ...}``).
        original_callback_api: the ``callback_api`` that the served config gives the robot's connection of this
            name (the original's client converts the value with it).

    Raises:
        ValueError: a malformed declaration (one line naming the field): a name, topic or datatype that is no such
            thing, two channels with one key or topic, channels without both converters, a message type for no
            channel of the kind, a ``check`` or converter that is not callable.
    """

    name: str
    structure: str
    check: Callable[[Any, Mapping[str, Any]], list[str]]
    sensor: bool = True
    channels: tuple[Channel, ...] = ()
    message_types: tuple[MessageType, ...] = ()
    to_messages: Callable[[Any, RecordContext], dict[str, dict]] | None = None
    from_messages: Callable[[Callable[[str], Any], Mapping[str, Any]], Any] | None = None
    gym: GymEntry | None = None
    views: tuple[View, ...] = ()
    original_value: Callable[[Any], Any] | None = None
    original_callback_api: str | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "channels", tuple(self.channels))
        object.__setattr__(self, "message_types", tuple(self.message_types))
        object.__setattr__(self, "views", tuple(self.views))
        if not isinstance(self.name, str) or not _NAME.match(self.name):
            raise ValueError(f"observation kind name {self.name!r}: expected letters, digits and _")
        where = f"observation kind '{self.name}'"
        if not isinstance(self.structure, str) or not self.structure.strip():
            raise ValueError(f"{where}: structure must say its shapes, dtypes, units and frame")
        if not callable(self.check):
            raise ValueError(f"{where}: check must be callable(value, observations) -> [problem]")
        keys, topics = set(), set()
        for ch in self.channels:
            if not isinstance(ch, Channel):
                raise ValueError(f"{where}: channels must be Channel(key, topic, datatype), got {ch!r}")
            if not _NAME.match(str(ch.key)) or not _TOPIC.match(str(ch.topic)) or not _DATATYPE.match(str(ch.datatype)):
                raise ValueError(f"{where}: channel {ch}: expected a key of letters, digits and _, a topic /a/b and "
                                 "a datatype package/msg/Name")
            if ch.key in keys or ch.topic in topics:
                raise ValueError(f"{where}: two channels use the key '{ch.key}' or the topic {ch.topic}")
            keys.add(ch.key)
            topics.add(ch.topic)
        if self.channels and not (callable(self.to_messages) and callable(self.from_messages)):
            raise ValueError(f"{where}: recorded channels need both to_messages and from_messages")
        datatypes = {ch.datatype for ch in self.channels}
        for mt in self.message_types:
            if not isinstance(mt, MessageType) or mt.datatype not in datatypes:
                raise ValueError(f"{where}: message_types must be MessageTypes of its channels' datatypes, got {mt!r}")
            if not re.fullmatch(r"RIHS01_[0-9a-f]{64}", str(mt.type_hash)):
                raise ValueError(f"{where}: {mt.datatype}: type_hash must be RIHS01_ and 64 hex digits")
        if self.gym is not None and not (isinstance(self.gym, GymEntry) and callable(self.gym.space)
                                         and callable(self.gym.value)):
            raise ValueError(f"{where}: gym must be a GymEntry(key, space, value)")
        if any(not isinstance(v, View) or not callable(v.draw) for v in self.views):
            raise ValueError(f"{where}: views must be View(name, draw, projection)")


# ------------------------------------------------------------------------------------------------ checks
def _got(value: Any) -> str:
    """``"<shape> <dtype>"`` of an array, else its type (for problems)."""
    return f"{getattr(value, 'shape', type(value))} {getattr(value, 'dtype', '')}"


def _check_rgb(rgb: Any, observations: Mapping[str, Any]) -> list[str]:
    if isinstance(rgb, np.ndarray) and rgb.ndim == 3 and rgb.shape[2] == 3 and rgb.dtype == np.uint8:
        return []
    return [f"image_rgb: expected (H, W, 3) uint8, got {_got(rgb)}"]


def _check_depth(depth: Any, observations: Mapping[str, Any]) -> list[str]:
    if not (isinstance(depth, np.ndarray) and depth.ndim == 2 and depth.dtype == np.float32):
        return [f"image_depth: expected (H, W) float32 metres, got {_got(depth)}"]
    if not (np.isfinite(depth).all() and (depth >= 0).all()):
        return ["image_depth: values must be finite and >= 0 (0 where nothing is hit)"]
    return []


def _info_check(name: str, image_name: str) -> Callable[[Any, Mapping[str, Any]], list[str]]:
    def check(info: Any, observations: Mapping[str, Any]) -> list[str]:
        if not isinstance(info, dict):
            return [f"{name}: expected a dict, got {type(info).__name__}"]
        missing = {"frame_id", "height", "width", "matrix_intrinsics", "matrix_projection"} - set(info)
        if missing:
            return [f"{name}: missing {', '.join(sorted(missing))}"]
        out = []
        if np.asarray(info["matrix_intrinsics"]).shape != (3, 3) or np.asarray(info["matrix_projection"]).shape != (3, 4):
            out.append(f"{name}: matrix_intrinsics must be (3, 3) and matrix_projection (3, 4)")
        image = observations.get(image_name)
        if isinstance(image, np.ndarray) and (info["height"], info["width"]) != image.shape[:2]:
            out.append(f"{name}: height/width {info['height']}x{info['width']} differ from the image {image.shape[:2]}")
        return out

    return check


def _check_laser(laser: Any, observations: Mapping[str, Any]) -> list[str]:
    if not (isinstance(laser, dict) and {"scans", "range_min", "range_max"} <= set(laser)):
        return ["laser: expected keys scans, range_min, range_max"]
    scans = np.asarray(laser["scans"])
    if scans.ndim != 2 or scans.shape[1] != 2 or scans.dtype != np.float64:
        return [f"laser.scans: expected (N, 2) float64 [range m, angle rad], got {scans.shape} {scans.dtype}"]
    if len(scans) and not ((scans[:, 1] >= -math.pi - 1e-9).all() and (scans[:, 1] < math.pi + 1e-9).all()):
        return ["laser.scans: angles must be wrapped to [-pi, pi)"]
    return []


def _check_poses(poses: Any, observations: Mapping[str, Any]) -> list[str]:
    if not isinstance(poses, dict):
        return [f"poses: expected {{frame: pose}}, got {type(poses).__name__}"]
    shapes = {"translation_xyz": (3,), "rotation_rpy": (3,), "rotation_xyzw": (4,)}
    for frame, pose in poses.items():
        if not (isinstance(pose, dict) and {"parent_frame", *shapes} <= set(pose)):
            return [f"poses['{frame}']: expected keys parent_frame, {', '.join(shapes)}"]
        for key, shape in shapes.items():
            value = np.asarray(pose[key])
            if value.shape != shape or value.dtype.kind not in "fi" or not np.isfinite(value).all():
                return [f"poses['{frame}'].{key}: expected {shape} finite numbers, got {_got(value)}"]
    return []


def _check_segment(seg: Any, observations: Mapping[str, Any]) -> list[str]:
    seg = seg or {}
    if not (isinstance(seg, dict) and {"class_segment_img", "instance_segment_img", "class_ids"} <= set(seg)):
        return ["image_segment: expected keys class_segment_img, instance_segment_img, class_ids"]
    if np.asarray(seg["instance_segment_img"]).dtype != np.int32:
        return ["image_segment.instance_segment_img: expected int32"]
    return []


# ------------------------------------------------------------------------------------------------ recorder
def _image_rgb_messages(rgb: Any, ctx: RecordContext) -> dict[str, dict]:
    return {"image_rgb": image_message(rgb, "rgb8", ctx.frames["camera"], ctx.time_ns)}


def _image_depth_messages(depth: Any, ctx: RecordContext) -> dict[str, dict]:
    return {"image_depth": image_message(ros_depth(depth), "32FC1", ctx.frames["camera"], ctx.time_ns)}


def _image_depth_value(message: Callable[[str], Any], metadata: Mapping[str, Any]) -> np.ndarray:
    depth = image_array(message("image_depth"))  # REP 118: NaN (no hit) is the API's 0.0
    return np.where(np.isfinite(depth) & (depth > 0), depth, np.float32(0.0)).astype(np.float32)


def _info_codec(name: str) -> tuple[Callable, Callable]:
    """``(to_messages, from_messages)`` of an ``image_*_info`` kind: a ``CameraInfo`` in the camera's TF frame;
    a ``frame_id`` other than that frame is kept in the metadata's ``info_frame_ids``."""
    def to_messages(info: dict, ctx: RecordContext) -> dict[str, dict]:
        cam = ctx.frames["camera"]
        if info.get("frame_id", cam) != cam:
            ctx.metadata.setdefault("info_frame_ids", {})[name] = info["frame_id"]
        return {name: camera_info_message(info, ctx.time_ns, cam)}

    def from_messages(message: Callable[[str], Any], metadata: Mapping[str, Any]) -> dict:
        msg = message(name)
        frame_id = (metadata.get("info_frame_ids") or {}).get(name, msg.header.frame_id)
        return {"frame_id": frame_id, "height": int(msg.height), "width": int(msg.width),
                "matrix_intrinsics": np.asarray(msg.k, dtype=np.float64).reshape(3, 3),
                "matrix_projection": np.asarray(msg.p, dtype=np.float64).reshape(3, 4)}

    return to_messages, from_messages


def _laser_messages(laser: dict, ctx: RecordContext) -> dict[str, dict]:
    return {"laser": laser_message(laser, ctx.frames["lidar"], ctx.time_ns)}


def _laser_value(message: Callable[[str], Any], metadata: Mapping[str, Any]) -> dict:
    msg = message("laser")
    ranges = np.asarray(msg.ranges, dtype=np.float32).astype(np.float64)
    ranges[~(ranges <= msg.range_max)] = float(msg.range_max)  # REP 117: +Inf (no return) is range_max
    angles = msg.angle_min + msg.angle_increment * np.arange(len(ranges), dtype=np.float64)
    angles = (angles + math.pi) % (2.0 * math.pi) - math.pi
    angles[angles >= math.pi - 1e-6] -= 2.0 * math.pi  # float32 rounding of −π must not wrap to +π
    return {"scans": np.stack([ranges, angles], axis=1), "range_min": float(msg.range_min),
            "range_max": float(msg.range_max)}


def _segment_messages(seg: dict, ctx: RecordContext) -> dict[str, dict]:
    cam, t = ctx.frames["camera"], ctx.time_ns
    ctx.metadata["class_ids"] = dict(seg.get("class_ids", {}))
    return {"segment_class": image_message(np.asarray(seg["class_segment_img"], np.uint8), "mono8", cam, t),
            "segment_instance": image_message(np.asarray(seg["instance_segment_img"], np.int32), "32SC1", cam, t)}


def _segment_value(message: Callable[[str], Any], metadata: Mapping[str, Any]) -> dict:
    return {"class_segment_img": image_array(message("segment_class")),
            "instance_segment_img": image_array(message("segment_instance")),
            "class_ids": dict(metadata.get("class_ids", {}))}


# ------------------------------------------------------------------------------------------------ views
def _draw_rgb(ax: Any, rgb: Any) -> None:
    ax.imshow(rgb)
    ax.set_title("image_rgb")
    ax.axis("off")


def _draw_depth(ax: Any, depth: Any) -> None:
    ax.imshow(depth, cmap="hot")
    ax.set_title("image_depth (m)")
    ax.axis("off")


def _draw_laser(ax: Any, laser: dict) -> None:
    scans = np.asarray(laser["scans"])
    x, y = scans[:, 0] * np.cos(scans[:, 1]), scans[:, 0] * np.sin(scans[:, 1])
    ax.scatter(x, y, s=2, c="k")
    ax.plot(0, 0, "r>", markersize=8)
    ax.set_aspect("equal")
    ax.set_title("laser (robot frame, m)")


#: Length of each frame's axes in the ``poses`` view, metres.
AXIS_LENGTH_M = 0.25


def _draw_poses(ax: Any, poses: dict) -> None:
    from benchbot.core.geometry import quaternion_xyzw_to_matrix  # SciPy: loaded on first use

    for frame, pose in poses.items():
        origin = np.asarray(pose["translation_xyz"], dtype=float)
        R = quaternion_xyzw_to_matrix(pose["rotation_xyzw"])
        for axis, colour in zip(R.T, "rgb"):
            end = origin + AXIS_LENGTH_M * axis
            ax.plot([origin[0], end[0]], [origin[1], end[1]], [origin[2], end[2]], colour)
        ax.text(*origin, frame, fontsize=7)
    ax.set_title("poses (map frame)")


def _draw_class(ax: Any, seg: dict) -> None:
    ax.imshow(seg["class_segment_img"], cmap="tab20", interpolation="nearest")
    ax.set_title("image_class")
    ax.axis("off")


def _draw_instance(ax: Any, seg: dict) -> None:
    ax.imshow(seg["instance_segment_img"] % 1000, cmap="tab20", interpolation="nearest")
    ax.set_title("image_instance")
    ax.axis("off")


# ------------------------------------------------------------------------------------------------ built-ins
def _pose_value(poses: dict) -> np.ndarray:
    robot = poses["robot"]
    t = robot["translation_xyz"]
    return np.array([t[0], t[1], float(robot["rotation_rpy"][2])], dtype=np.float64)


_RGB_INFO = _info_codec("image_rgb_info")
_DEPTH_INFO = _info_codec("image_depth_info")
_INFO_STRUCTURE = ("{'frame_id': 'camera', 'height': H, 'width': W, 'matrix_intrinsics': (3, 3) float64 K, "
                   "'matrix_projection': (3, 4) float64 P = [K|0]}")

BUILT_IN: dict[str, ObservationKind] = {kind.name: kind for kind in (
    ObservationKind(
        "image_rgb", "(H, W, 3) uint8, RGB order; camera frame (optical)", _check_rgb,
        channels=(Channel("image_rgb", "/camera/color/image_raw", "sensor_msgs/msg/Image"),),
        to_messages=_image_rgb_messages, from_messages=lambda message, metadata: image_array(message("image_rgb")),
        gym=GymEntry("image_rgb", lambda spaces, v: spaces.Box(0, 255, v.shape, np.uint8),
                     lambda v: np.array(v, dtype=np.uint8)),
        views=(View("image_rgb", _draw_rgb),),
        original_value=lambda v: {"encoding": "rgb8", "data": v},
        original_callback_api="api_callbacks.convert_to_rgb"),
    ObservationKind(
        "image_depth", "(H, W) float32, metres along the optical axis (z-depth); 0.0 where nothing is hit; camera "
        "frame (optical)", _check_depth,
        channels=(Channel("image_depth", "/camera/depth/image_raw", "sensor_msgs/msg/Image"),),
        to_messages=_image_depth_messages, from_messages=_image_depth_value,
        gym=GymEntry("image_depth", lambda spaces, v: spaces.Box(0.0, np.inf, v.shape, np.float32),
                     lambda v: np.clip(np.array(v, dtype=np.float32), 0.0, None)),
        views=(View("image_depth", _draw_depth),)),
    ObservationKind(
        "image_rgb_info", _INFO_STRUCTURE, _info_check("image_rgb_info", "image_rgb"),
        channels=(Channel("image_rgb_info", "/camera/color/camera_info", "sensor_msgs/msg/CameraInfo"),),
        to_messages=_RGB_INFO[0], from_messages=_RGB_INFO[1]),
    ObservationKind(
        "image_depth_info", _INFO_STRUCTURE, _info_check("image_depth_info", "image_depth"),
        channels=(Channel("image_depth_info", "/camera/depth/camera_info", "sensor_msgs/msg/CameraInfo"),),
        to_messages=_DEPTH_INFO[0], from_messages=_DEPTH_INFO[1]),
    ObservationKind(
        "laser", "{'scans': (N, 2) float64 rows [range m, angle rad] (angle wrapped to [-π, π)), 'range_min': m, "
        "'range_max': m}; lidar frame; no return reads range_max", _check_laser,
        channels=(Channel("laser", "/scan", "sensor_msgs/msg/LaserScan"),),
        to_messages=_laser_messages, from_messages=_laser_value,
        gym=GymEntry("laser", lambda spaces, v: spaces.Box(0.0, np.inf, (v["scans"].shape[0],), np.float64),
                     lambda v: np.clip(np.array(v["scans"][:, 0], dtype=np.float64), 0.0, None)),
        views=(View("laser", _draw_laser),)),
    ObservationKind(
        "poses", "{frame: {'parent_frame': 'map', 'translation_xyz': (3,) float64 m, 'rotation_rpy': (3,) float64 "
        "rad (static xyz), 'rotation_xyzw': (4,) float64 unit quaternion}} of the robot's poses (camera, lidar, "
        "robot, initial_pose)", _check_poses, sensor=False,
        gym=GymEntry("pose", lambda spaces, v: spaces.Box(-np.inf, np.inf, (3,), np.float64), _pose_value),
        views=(View("poses", _draw_poses, projection="3d"),)),
    ObservationKind(
        "image_segment", "{'class_segment_img': (H, W) uint8 class ids, 'instance_segment_img': (H, W) int32 ids "
        "class·1000 + instance (0: background), 'class_ids': {name: id}}; camera frame (optical)", _check_segment,
        channels=(Channel("segment_class", "/camera/segment/class", "sensor_msgs/msg/Image"),
                  Channel("segment_instance", "/camera/segment/instance", "sensor_msgs/msg/Image")),
        to_messages=_segment_messages, from_messages=_segment_value,
        views=(View("image_class", _draw_class), View("image_instance", _draw_instance))),
)}
"""The core's observation kinds (docs/observations.md), in the order the recorder writes them."""


# ------------------------------------------------------------------------------------------------ using kinds
def problems(observations: Mapping[str, Any], names: Iterable[str],
             kinds: Mapping[str, ObservationKind] | None = None) -> list[str]:
    """The structure problems of ``observations``, one line each: every name of ``names`` it lacks, then what the
    check of each kind present says (a check that raises is a problem too). Names of no kind are only looked for.

    Args:
        observations: a step's observations (docs/observations.md).
        names: the names it must hold.
        kinds: the kinds to check by (default :data:`BUILT_IN`; ``Registry.observations`` adds plugins' kinds).
    """
    kinds = BUILT_IN if kinds is None else kinds
    out = [f"{name}: missing" for name in names if name not in observations]
    for name, kind in kinds.items():
        if name not in observations:
            continue
        try:
            found = kind.check(observations[name], observations)
        except Exception as exc:  # noqa: BLE001 - a plugin's check must not hide the other problems
            found = [f"{name}: its check raised {exc!r}"]
        out += [str(p).replace("\n", " ") for p in found or []]
    return out


def message_types(kinds: Mapping[str, ObservationKind]) -> dict[str, MessageType]:
    """Every ROS 2 message type that ``kinds``' channels may use, by datatype: the standard ones
    (:data:`~benchbot.core.ros_messages.STANDARD_TYPES`) and those the kinds declare."""
    out = dict(STANDARD_TYPES)
    for kind in kinds.values():
        for mt in kind.message_types:
            out.setdefault(mt.datatype, mt)
    return out


def add_offered(kinds: dict[str, ObservationKind], plugin: str, offered: Any) -> tuple[list[str], list[str]]:
    """Add the kinds a plugin's ``benchbot_observations`` returned to ``kinds`` (the registry's, built-ins first),
    each only if it clashes with none there.

    Args:
        kinds: ``{name: ObservationKind}``, changed in place.
        plugin: the plugin's name (for problems).
        offered: what its hook returned: a list of :class:`ObservationKind`.

    Returns:
        ``(names added, problems)``: a problem (one line) for a result that is no list, an item that is no
        :class:`ObservationKind`, a ``sensor=False`` kind, a name, channel key or topic already taken (or a topic of
        :data:`RESERVED_TOPICS`), or a channel datatype with no definition (neither standard nor in the kind's
        ``message_types``) or with another definition than an earlier kind's.
    """
    if not isinstance(offered, (list, tuple)):
        return [], [f"plugin {plugin}: benchbot_observations() returned {type(offered).__name__}, not a list"]
    added, found = [], []
    for kind in offered:
        if not isinstance(kind, ObservationKind):
            found.append(f"plugin {plugin}: benchbot_observations() returned a {type(kind).__name__}, not a "
                         "benchbot.core.observations.ObservationKind")
            continue
        why = _clash(kinds, kind)
        if why:
            found.append(f"plugin {plugin}: observation '{kind.name}' left out: {why}")
            continue
        kinds[kind.name] = kind
        added.append(kind.name)
    return added, found


def _clash(kinds: Mapping[str, ObservationKind], kind: ObservationKind) -> str:
    """Why ``kind`` cannot join ``kinds`` (one phrase), or ``""``."""
    if not kind.sensor:
        return "only the core declares observations that the episode builds (sensor=False)"
    if kind.name in kinds:
        return "the name is taken" + (" by a built-in observation" if kind.name in BUILT_IN else "")
    keys = {ch.key: name for name, k in kinds.items() for ch in k.channels}
    topics = {ch.topic: name for name, k in kinds.items() for ch in k.channels}
    known = message_types(kinds)
    own = {mt.datatype: mt for mt in kind.message_types}
    for ch in kind.channels:
        if ch.key in keys:
            return f"channel key '{ch.key}' belongs to observation '{keys[ch.key]}'"
        if ch.topic in topics or ch.topic in RESERVED_TOPICS:
            return f"topic {ch.topic} belongs to " + (f"observation '{topics[ch.topic]}'" if ch.topic in topics
                                                      else "the recorder")
        if ch.datatype not in known and ch.datatype not in own:
            return f"{ch.topic}'s type {ch.datatype} has no definition: give it in message_types"
        if ch.datatype in known and ch.datatype in own and own[ch.datatype] != known[ch.datatype]:
            return f"{ch.datatype} is already defined otherwise"
    return ""
