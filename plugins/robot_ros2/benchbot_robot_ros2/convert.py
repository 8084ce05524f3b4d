"""Translations between ROS 2 messages and BenchBot's observation structures (docs/observations.md).

Everything here is duck-typed on the ROS field names, so it works on the IDL structs of
:mod:`benchbot_robot_ros2.msgs` and on ``rclpy`` messages alike. Readers validate what they get and raise
``ValueError`` naming the problem for a malformed message (wrong sizes, unknown encoding, non-finite values) — the
backend reports it instead of crashing. Units: metres, radians, seconds; quaternions ``(x, y, z, w)``.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from benchbot.core.geometry import matrix_to_quaternion_xyzw, quaternion_xyzw_to_matrix, wrap_angle

#: bytes per pixel and channel count of the image encodings we read/write
ENCODINGS = {"rgb8": (3, 3), "bgr8": (3, 3), "rgba8": (4, 4), "bgra8": (4, 4), "mono8": (1, 1), "8UC1": (1, 1),
             "32FC1": (4, 1), "16UC1": (2, 1), "32SC1": (4, 1)}


# ------------------------------------------------------------------------------------------ time and geometry
def fill_from_dict(msg: Any, values: dict) -> Any:
    """Fill a message from a message dict (field → value; a nested message as a dict, as an observation kind's
    ``to_messages`` gives, :mod:`benchbot.core.observations`): nested messages are filled in place, other fields
    set; returns ``msg``."""
    for key, value in values.items():
        current = getattr(msg, key, None)
        if isinstance(value, dict) and current is not None and not isinstance(current, (dict, str, bytes, int, float)):
            fill_from_dict(current, value)
        else:
            setattr(msg, key, value)
    return msg


def set_stamp(stamp: Any, t_s: float | None = None, *, t_ns: int | None = None) -> None:
    """Write a time into a ``builtin_interfaces/Time``: ``t_ns`` (integer nanoseconds, exact) if given, else ``t_s``
    (float seconds), else now (wall clock)."""
    if t_ns is not None:
        stamp.sec, stamp.nanosec = int(t_ns) // 1_000_000_000, int(t_ns) % 1_000_000_000
        return
    t_s = time.time() if t_s is None else t_s
    sec = int(math.floor(t_s))
    stamp.sec = sec
    stamp.nanosec = min(int((t_s - sec) * 1e9), 999_999_999)


def _matrix(t: Any, q: Any) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = quaternion_xyzw_to_matrix([q.x, q.y, q.z, q.w])  # ValueError: not 4 finite numbers, or 0
    T[:3, 3] = [float(t.x), float(t.y), float(t.z)]
    if not np.all(np.isfinite(T)):
        raise ValueError("non-finite translation")
    return T


def transform_to_matrix(tr: Any) -> np.ndarray:
    """``geometry_msgs/Transform`` → (4, 4) float64."""
    return _matrix(tr.translation, tr.rotation)


def pose_to_matrix(pose: Any) -> np.ndarray:
    """``geometry_msgs/Pose`` → (4, 4) float64."""
    return _matrix(pose.position, pose.orientation)


def matrix_to_se2(T: np.ndarray) -> np.ndarray:
    """(4, 4) → (3,) ``[x, y, yaw]`` (yaw of the static-xyz Euler angles, as the original)."""
    return np.array([T[0, 3], T[1, 3], math.atan2(T[1, 0], T[0, 0])])


def fill_transform(tr: Any, T: np.ndarray) -> None:
    """Write (4, 4) ``T`` into a ``geometry_msgs/Transform``."""
    q = matrix_to_quaternion_xyzw(T[:3, :3])
    tr.translation.x, tr.translation.y, tr.translation.z = (float(v) for v in T[:3, 3])
    tr.rotation.x, tr.rotation.y, tr.rotation.z, tr.rotation.w = (float(v) for v in q)


def fill_pose(pose: Any, T: np.ndarray) -> None:
    """Write (4, 4) ``T`` into a ``geometry_msgs/Pose``."""
    q = matrix_to_quaternion_xyzw(T[:3, :3])
    pose.position.x, pose.position.y, pose.position.z = (float(v) for v in T[:3, 3])
    pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = (float(v) for v in q)


# ------------------------------------------------------------------------------------------ readers
def _buffer(data: Any) -> np.ndarray:
    if isinstance(data, (bytes, bytearray, memoryview)):
        return np.frombuffer(data, dtype=np.uint8)
    if hasattr(data, "tobytes") and not isinstance(data, np.ndarray):  # array.array of rclpy
        return np.frombuffer(data.tobytes(), dtype=np.uint8)
    return np.asarray(data, dtype=np.uint8).reshape(-1)


def image_array(msg: Any) -> np.ndarray:
    """``sensor_msgs/Image`` → array: (H, W, C) uint8 for colour encodings (RGB order; alpha dropped), (H, W)
    uint8/float32/int32 for ``mono8``/``32FC1``/``32SC1``; ``16UC1`` (millimetres) → float32 metres.

    Raises:
        ValueError: unknown encoding, zero size, a step too small, or too little data.
    """
    h, w, enc = int(msg.height), int(msg.width), str(msg.encoding)
    if enc not in ENCODINGS:
        raise ValueError(f"unsupported image encoding {enc!r} (supported: {', '.join(ENCODINGS)})")
    bpp, channels = ENCODINGS[enc]
    step = int(msg.step)
    if h <= 0 or w <= 0 or h * w > 50_000_000:
        raise ValueError(f"invalid image size {w}x{h}")
    if step < w * bpp:
        raise ValueError(f"image step {step} < width {w} × {bpp} bytes")
    buf = _buffer(msg.data)
    if buf.size < step * h:
        raise ValueError(f"image data has {buf.size} bytes, expected {step * h}")
    rows = buf[: step * h].reshape(h, step)[:, : w * bpp]
    if enc in ("32FC1", "16UC1", "32SC1"):
        end = ">" if int(msg.is_bigendian) else "<"
        kind = {"32FC1": "f4", "16UC1": "u2", "32SC1": "i4"}[enc]
        arr = np.ascontiguousarray(rows).view(end + kind).reshape(h, w)
        if enc == "16UC1":
            return (arr.astype(np.float32) / 1000.0)
        return arr.astype(np.float32 if enc == "32FC1" else np.int32)
    arr = np.ascontiguousarray(rows).reshape(h, w, channels) if channels > 1 else np.ascontiguousarray(rows)
    if enc in ("bgr8", "bgra8"):
        arr = arr[:, :, 2::-1] if enc == "bgra8" else arr[:, :, ::-1]
    elif enc == "rgba8":
        arr = arr[:, :, :3]
    return np.ascontiguousarray(arr)


def image_rgb(msg: Any) -> np.ndarray:
    """``sensor_msgs/Image`` → (H, W, 3) uint8 RGB (``mono8`` is repeated on three channels).

    Raises:
        ValueError: see :func:`image_array`; a depth encoding.
    """
    arr = image_array(msg)
    if arr.dtype != np.uint8:
        raise ValueError(f"expected a colour image, got encoding {msg.encoding!r}")
    return np.repeat(arr[:, :, None], 3, axis=2) if arr.ndim == 2 else arr


def image_depth(msg: Any) -> np.ndarray:
    """``sensor_msgs/Image`` (``32FC1`` metres or ``16UC1`` millimetres) → (H, W) float32 metres along the optical
    axis; NaN, ±inf and negatives become 0.0 ("no hit"), as the simulated carter reports them.

    Raises:
        ValueError: see :func:`image_array`; a colour encoding.
    """
    if str(msg.encoding) not in ("32FC1", "16UC1"):
        raise ValueError(f"expected a depth image (32FC1 or 16UC1), got encoding {msg.encoding!r}")
    d = image_array(msg).astype(np.float32, copy=True)
    d[~np.isfinite(d) | (d < 0)] = 0.0
    return d


def camera_info(msg: Any) -> dict:
    """``sensor_msgs/CameraInfo`` → ``{frame_id, height, width, matrix_intrinsics (3,3) float64, matrix_projection
    (3,4) float64}``.

    Raises:
        ValueError: wrong array sizes or non-finite values.
    """
    k = np.asarray(list(msg.k), dtype=np.float64)
    p = np.asarray(list(msg.p), dtype=np.float64)
    if k.size != 9 or p.size != 12 or not (np.all(np.isfinite(k)) and np.all(np.isfinite(p))):
        raise ValueError("camera info: k must be 9 and p 12 finite numbers")
    return {"frame_id": str(msg.header.frame_id), "height": int(msg.height), "width": int(msg.width),
            "matrix_intrinsics": k.reshape(3, 3), "matrix_projection": p.reshape(3, 4)}


def wrap_angles(angles: np.ndarray) -> np.ndarray:
    """Angles (rad, any shape) → float64 wrapped to [-π, π). An angle within 1e-6 rad below +π becomes -π: that is
    -π rounded to float32 (``LaserScan`` angles are float32, and float32(-π) < -π) wrapped around."""
    a = (np.asarray(angles, dtype=np.float64) + math.pi) % (2 * math.pi) - math.pi
    a = np.where(a >= math.pi - 1e-6, -math.pi, a)
    return np.maximum(a, -math.pi)


def laser(msg: Any) -> dict:
    """``sensor_msgs/LaserScan`` → ``{'scans': (N, 2) float64 [range m, angle rad wrapped to [-π, π)],
    'range_min', 'range_max'}`` (BenchBot's observation, docs/observations.md). REP 117 readings: NaN (invalid) and
    +Inf or anything beyond ``range_max`` (no return) become ``range_max``, -Inf (too close) and negatives 0.

    Raises:
        ValueError: non-finite or inverted limits.
    """
    r = np.asarray(msg.ranges, dtype=np.float64).reshape(-1)
    a0, inc = float(msg.angle_min), float(msg.angle_increment)
    rmin, rmax = float(msg.range_min), float(msg.range_max)
    if not all(math.isfinite(v) for v in (a0, inc, rmin, rmax)) or rmax <= 0 or rmin > rmax:
        raise ValueError(f"laser scan with invalid limits (angle_min {a0}, increment {inc}, range {rmin}..{rmax})")
    r = np.where(np.isnan(r) | (r > rmax), rmax, r)
    r = np.clip(r, 0.0, rmax)
    angles = wrap_angles(a0 + inc * np.arange(r.size, dtype=np.float64))
    return {"scans": np.stack([r, angles], axis=1), "range_min": rmin, "range_max": rmax}


def odometry_se2(msg: Any) -> np.ndarray:
    """``nav_msgs/Odometry`` → (3,) ``[x, y, yaw]`` of its child frame in its header frame.

    Raises:
        ValueError: a non-finite pose or a degenerate quaternion.
    """
    return matrix_to_se2(pose_to_matrix(msg.pose.pose))


# ------------------------------------------------------------------------------------------ writers
def fill_twist(msg: Any, v: float, w: float) -> Any:
    """Set a ``geometry_msgs/Twist`` to forward speed ``v`` (m/s) and yaw rate ``w`` (rad/s); returns it."""
    msg.linear.x, msg.linear.y, msg.linear.z = float(v), 0.0, 0.0
    msg.angular.x, msg.angular.y, msg.angular.z = 0.0, 0.0, float(w)
    return msg


def fill_image(msg: Any, arr: np.ndarray, encoding: str, frame_id: str, t_s: float, *,
               t_ns: int | None = None) -> Any:
    """Fill a ``sensor_msgs/Image`` from ``arr`` ((H, W, 3) uint8 for ``rgb8``, (H, W) float32 for ``32FC1``,
    (H, W) uint8 for ``mono8``, (H, W) int32 for ``32SC1``), little-endian, stamped ``t_ns`` (int ns) or ``t_s``
    (s); returns it."""
    arr = np.ascontiguousarray(arr)
    set_stamp(msg.header.stamp, t_s, t_ns=t_ns)
    msg.header.frame_id = frame_id
    msg.height, msg.width = int(arr.shape[0]), int(arr.shape[1])
    msg.encoding = encoding
    msg.is_bigendian = 0
    msg.step = int(arr.shape[1] * ENCODINGS[encoding][0])
    msg.data = arr.astype({"32FC1": "<f4", "32SC1": "<i4"}.get(encoding, np.uint8), copy=False).tobytes()
    return msg


def fill_camera_info(msg: Any, K: np.ndarray, width: int, height: int, frame_id: str, t_s: float, *,
                     t_ns: int | None = None) -> Any:
    """Fill a ``sensor_msgs/CameraInfo`` of a pinhole camera without distortion (P = [K|0]), stamped ``t_ns`` (int
    ns) or ``t_s`` (s); returns it."""
    set_stamp(msg.header.stamp, t_s, t_ns=t_ns)
    msg.header.frame_id = frame_id
    msg.height, msg.width = int(height), int(width)
    msg.distortion_model = "plumb_bob"
    msg.d = [0.0] * 5
    msg.k = [float(v) for v in np.asarray(K, dtype=np.float64).reshape(9)]
    msg.r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    P = np.zeros((3, 4))
    P[:, :3] = K
    msg.p = [float(v) for v in P.reshape(12)]
    return msg


def fill_laser(msg: Any, ranges: np.ndarray, angle_min: float, angle_increment: float, range_min: float,
               range_max: float, frame_id: str, t_s: float, *, t_ns: int | None = None) -> Any:
    """Fill a ``sensor_msgs/LaserScan`` (ranges in metres, float32 on the wire, as given: see
    :func:`benchbot.core.ros_messages.ros_ranges` for REP 117's +Inf), stamped ``t_ns`` (int ns) or ``t_s`` (s); returns it. ``angle_max`` is
    ``angle_min + (N - 1) · angle_increment``."""
    set_stamp(msg.header.stamp, t_s, t_ns=t_ns)
    msg.header.frame_id = frame_id
    n = len(ranges)
    msg.angle_min = float(angle_min)
    msg.angle_increment = float(angle_increment)
    msg.angle_max = float(angle_min + angle_increment * max(n - 1, 0))
    msg.time_increment, msg.scan_time = 0.0, 0.0
    msg.range_min, msg.range_max = float(range_min), float(range_max)
    msg.ranges = np.asarray(ranges, dtype=np.float32)
    msg.intensities = np.zeros(0, dtype=np.float32)
    return msg


def wrap(a: float) -> float:
    """Angle wrapped to [-π, π)."""
    return wrap_angle(a)
