"""ROS 2 messages as BenchBot's recordings hold them: the standard message definitions, their type hashes, and the
builders and readers that the observation kinds (:mod:`benchbot.core.observations`) and the recorder use.

A message here is a plain dict in the field layout of its ROS 2 type (what ``mcap_ros2``'s dynamic encoder takes);
a message read back is whatever object the MCAP decoder gives, read by field name. Conventions of the API against
ROS's: depth 0.0 where nothing is hit (the API) is NaN in a ``32FC1`` image (REP 118); a laser range equal to
``range_max`` (no return, the API) is +Inf in a ``LaserScan`` (REP 117). Units: metres, radians; time in integer
nanoseconds since the Unix epoch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

SEP = "=" * 80

_TIME = "int32 sec\nuint32 nanosec\n"
_HEADER = "builtin_interfaces/Time stamp\nstring frame_id\n"
_VECTOR3 = "float64 x\nfloat64 y\nfloat64 z\n"
_QUATERNION = "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n"
_ROI = "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify\n"
_TRANSFORM = "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation\n"
_TRANSFORM_STAMPED = "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/Transform transform\n"

#: Definitions of the message types that message definitions depend on, by name (``std_msgs/Header``): append the
#: ones a definition uses with :func:`definition`.
DEPENDENCIES: dict[str, str] = {
    "std_msgs/Header": _HEADER, "builtin_interfaces/Time": _TIME, "geometry_msgs/Vector3": _VECTOR3,
    "geometry_msgs/Quaternion": _QUATERNION, "sensor_msgs/RegionOfInterest": _ROI,
    "geometry_msgs/Transform": _TRANSFORM, "geometry_msgs/TransformStamped": _TRANSFORM_STAMPED,
}


def definition(main: str, dependencies: list[str]) -> str:
    """A ``ros2msg`` schema text (as MCAP stores it): the type's own fields ``main``, then each named dependency's
    definition (from :data:`DEPENDENCIES`) after a line of ``=`` and ``MSG: <name>``.

    Raises:
        KeyError: a dependency that :data:`DEPENDENCIES` does not hold.
    """
    return main + "".join(f"{SEP}\nMSG: {name}\n{DEPENDENCIES[name]}" for name in dependencies)


MSGDEFS: dict[str, str] = {
    "sensor_msgs/msg/Image": definition(
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\n"
        "uint8[] data\n", ["std_msgs/Header", "builtin_interfaces/Time"]),
    "sensor_msgs/msg/CameraInfo": definition(
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\nfloat64[] d\nfloat64[9] k\n"
        "float64[9] r\nfloat64[12] p\nuint32 binning_x\nuint32 binning_y\nsensor_msgs/RegionOfInterest roi\n",
        ["std_msgs/Header", "builtin_interfaces/Time", "sensor_msgs/RegionOfInterest"]),
    "sensor_msgs/msg/LaserScan": definition(
        "std_msgs/Header header\nfloat32 angle_min\nfloat32 angle_max\nfloat32 angle_increment\n"
        "float32 time_increment\nfloat32 scan_time\nfloat32 range_min\nfloat32 range_max\nfloat32[] ranges\n"
        "float32[] intensities\n", ["std_msgs/Header", "builtin_interfaces/Time"]),
    "tf2_msgs/msg/TFMessage": definition(
        "geometry_msgs/TransformStamped[] transforms\n",
        ["geometry_msgs/TransformStamped", "std_msgs/Header", "builtin_interfaces/Time", "geometry_msgs/Transform",
         "geometry_msgs/Vector3", "geometry_msgs/Quaternion"]),
    "geometry_msgs/msg/Twist": definition(
        "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular\n", ["geometry_msgs/Vector3"]),
}
"""The standard ROS 2 message definitions (ros2msg text with the dependencies appended), by datatype."""

TYPE_HASHES = {
    "sensor_msgs/msg/Image": "RIHS01_d31d41a9a4c4bc8eae9be757b0beed306564f7526c88ea6a4588fb9582527d47",
    "sensor_msgs/msg/CameraInfo": "RIHS01_b3dfd68ff46c9d56c80fd3bd4ed22c7a4ddce8c8348f2f59c299e73118e7e275",
    "sensor_msgs/msg/LaserScan": "RIHS01_64c191398013af96509d518dac71d5164f9382553fce5c1f8cca5be7924bd828",
    "tf2_msgs/msg/TFMessage": "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087",
    "geometry_msgs/msg/Twist": "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a",
}
"""ROS 2 Jazzy's RIHS01 type hash (REP 2011) of each datatype of :data:`MSGDEFS` (channel metadata
``topic_type_hash``)."""


@dataclass(frozen=True)
class MessageType:
    """A ROS 2 message type that a recording can hold, beyond :data:`MSGDEFS`: what an observation kind of a plugin
    declares for a datatype of its own (``sensor_msgs/msg/Imu``).

    Attributes:
        datatype: ``package/msg/Name``.
        definition: its ``ros2msg`` text with every dependency appended (:func:`definition` builds one from
            :data:`DEPENDENCIES`), as ``ros2 bag record`` stores it in MCAP.
        type_hash: its ROS 2 Jazzy type hash, ``RIHS01_<64 hex digits>`` (REP 2011; ``rosbags``'
            ``Typestore.hash_rihs01`` computes it).
    """

    datatype: str
    definition: str
    type_hash: str


#: :data:`MSGDEFS` and :data:`TYPE_HASHES` as :class:`MessageType`\ s, by datatype.
STANDARD_TYPES: dict[str, MessageType] = {name: MessageType(name, text, TYPE_HASHES[name])
                                          for name, text in MSGDEFS.items()}


# ------------------------------------------------------------------------------------------------ conventions
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


# ------------------------------------------------------------------------------------------------ builders
def stamp(time_ns: int) -> dict:
    """A ``builtin_interfaces/msg/Time`` dict for ``time_ns`` (int ns since the Unix epoch)."""
    return {"sec": int(time_ns // 1_000_000_000), "nanosec": int(time_ns % 1_000_000_000)}


def header(time_ns: int, frame_id: str) -> dict:
    """A ``std_msgs/msg/Header`` dict: stamped ``time_ns`` (int ns), in frame ``frame_id``."""
    return {"stamp": stamp(time_ns), "frame_id": frame_id}


def image_message(array: np.ndarray, encoding: str, frame_id: str, time_ns: int) -> dict:
    """A ``sensor_msgs/msg/Image`` dict for ``array`` (H, W[, C]) in ``encoding`` (little-endian, dense rows)."""
    array = np.ascontiguousarray(array)
    h, w = array.shape[:2]
    return {"header": header(time_ns, frame_id), "height": h, "width": w, "encoding": encoding,
            "is_bigendian": 0, "step": int(array.strides[0]), "data": array.tobytes()}


def camera_info_message(info: dict, time_ns: int, frame_id: str | None = None) -> dict:
    """A ``sensor_msgs/msg/CameraInfo`` dict from an ``image_*_info`` observation (plumb-bob, zero distortion), in
    ``frame_id`` (default: the observation's ``frame_id``)."""
    return {"header": header(time_ns, frame_id or info.get("frame_id", "camera")), "height": int(info["height"]),
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
    return {"header": header(time_ns, frame_id), "angle_min": a0, "angle_max": a0 + inc * max(n - 1, 0),
            "angle_increment": inc, "time_increment": 0.0, "scan_time": 0.0,
            "range_min": float(laser["range_min"]), "range_max": float(laser["range_max"]),
            "ranges": ros_ranges(scans[:, 0], laser["range_max"]).tolist() if n else [], "intensities": []}


def transform_message(T: np.ndarray, parent: str, child: str, time_ns: int) -> dict:
    """A ``geometry_msgs/msg/TransformStamped`` for ``T`` (4, 4) ``T_parent_child``."""
    from benchbot.core.geometry import matrix_to_quaternion_xyzw  # SciPy: loaded on first use

    q = matrix_to_quaternion_xyzw(T[:3, :3])
    return {"header": header(time_ns, parent), "child_frame_id": child,
            "transform": {"translation": dict(zip("xyz", map(float, T[:3, 3]))),
                          "rotation": dict(zip("xyzw", map(float, q)))}}


# ------------------------------------------------------------------------------------------------ readers
#: The image encodings :func:`image_array` reads: ``{encoding: (dtype, channels)}``.
IMAGE_ENCODINGS = {"rgb8": (np.uint8, 3), "mono8": (np.uint8, 1), "32FC1": (np.float32, 1), "32SC1": (np.int32, 1)}


def image_array(msg: Any) -> np.ndarray:
    """A ``sensor_msgs/msg/Image`` read back: (H, W, 3) uint8 for ``rgb8``, (H, W) uint8 / float32 / int32 for
    ``mono8`` / ``32FC1`` / ``32SC1``, in native byte order (either ``is_bigendian``; padded rows allowed).

    Raises:
        ValueError: an encoding other than those of :data:`IMAGE_ENCODINGS`.
    """
    if msg.encoding not in IMAGE_ENCODINGS:
        raise ValueError(f"unsupported image encoding '{msg.encoding}' (recordings use "
                         f"{', '.join(IMAGE_ENCODINGS)})")
    dtype, channels = IMAGE_ENCODINGS[msg.encoding]
    dtype = np.dtype(dtype).newbyteorder(">" if msg.is_bigendian else "<")
    row = np.frombuffer(bytes(msg.data), dtype=np.uint8).reshape(msg.height, msg.step)
    itemsize = dtype.itemsize * channels
    pixels = np.ascontiguousarray(row[:, : msg.width * itemsize]).view(dtype).astype(dtype.newbyteorder("="))
    return pixels.reshape(msg.height, msg.width, channels) if channels > 1 else pixels.reshape(msg.height, msg.width)
