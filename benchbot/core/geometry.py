"""Rigid-body helpers for poses in the ``map`` frame.

Conventions: metres and radians; a 7-number pose is ``[qw, qx, qy, qz, x, y, z]`` (the original BenchBot's order,
quaternion first, not always unit length: it is normalised here); an SE(2) pose is ``(x, y, yaw)``; a transform
``T_a_b`` is a (4, 4) float64 homogeneous matrix mapping points of frame ``b`` into frame ``a``; Euler angles are
static-axis x, y, z (roll, pitch, yaw; R = Rz·Ry·Rx), as ROS ``tf.transformations`` ``sxyz``. Rotations are
SciPy's (``scipy.spatial.transform.Rotation``); this module is the project's one home for them.
"""

from __future__ import annotations

import math
import warnings
from typing import Sequence

import numpy as np


def _rotation():
    """SciPy's ``Rotation`` class, imported on first use: ``scipy.spatial`` takes ~0.4 s to import, and commands
    that never rotate anything (``benchbot --help``, ``list``, ``show``) import this module."""
    from scipy.spatial.transform import Rotation

    return Rotation


def wrap_angle(angle: float) -> float:
    """Wrap ``angle`` (radians) to [-π, π)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def _unit_quaternion_xyzw(q: "Sequence[float] | np.ndarray", order: str) -> np.ndarray:
    """(4,) float64 ``[x, y, z, w]`` of ``q`` given in ``order`` (``'wxyz'`` or ``'xyzw'``), checked.

    Raises:
        ValueError: ``q`` does not have 4 finite numbers, or has zero length.
    """
    a = np.asarray(q, dtype=np.float64).reshape(-1)
    if a.shape != (4,) or not np.all(np.isfinite(a)):
        raise ValueError(f"a quaternion needs 4 finite numbers ({order}), got {a.tolist()}")
    if np.linalg.norm(a) == 0.0:
        raise ValueError("quaternion has zero length")
    return a[[1, 2, 3, 0]] if order == "wxyz" else a


def quaternion_wxyz_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix (3, 3) float64 of the quaternion ``q`` = (w, x, y, z) (the original's pose order), normalised
    first (SciPy's ``Rotation``).

    Raises:
        ValueError: ``q`` does not have 4 finite numbers, or has zero length.
    """
    return _rotation().from_quat(_unit_quaternion_xyzw(q, "wxyz")).as_matrix()


def quaternion_xyzw_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix (3, 3) float64 of the quaternion ``q`` = (x, y, z, w) (ROS order, the ``poses``
    observation's ``rotation_xyzw``), normalised first (SciPy's ``Rotation``).

    Raises:
        ValueError: ``q`` does not have 4 finite numbers, or has zero length.
    """
    return _rotation().from_quat(_unit_quaternion_xyzw(q, "xyzw")).as_matrix()


def matrix_to_quaternion_xyzw(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (4,) float64 ``[x, y, z, w]`` (ROS order) of the rotation matrix ``R`` (3, 3), w ≥ 0 (SciPy's
    ``Rotation``; a matrix that is not quite orthonormal is taken as its nearest rotation)."""
    q = _rotation().from_matrix(np.asarray(R, dtype=np.float64)).as_quat()
    return -q if q[3] < 0 else q


def rpy_to_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Rotation (3, 3) float64 of static-axis (x, y, z) Euler angles in radians: R = Rz(yaw)·Ry(pitch)·Rx(roll)."""
    return _rotation().from_euler("xyz", [roll, pitch, yaw]).as_matrix()


def matrix_to_rpy(R: np.ndarray) -> tuple[float, float, float]:
    """Static-axis (x, y, z) Euler angles ``(roll, pitch, yaw)`` in radians of ``R`` (3, 3), R = Rz·Ry·Rx (SciPy's
    ``Rotation.as_euler('xyz')``; at gimbal lock, pitch ±π/2, yaw is 0 and roll takes the whole turn)."""
    with warnings.catch_warnings():  # gimbal lock is a property of the angles, not an error of the caller's
        warnings.simplefilter("ignore", UserWarning)
        roll, pitch, yaw = _rotation().from_matrix(np.asarray(R, dtype=np.float64)).as_euler("xyz")
    return (float(roll), float(pitch), float(yaw))


def pose7_to_matrix(pose: "list[float] | np.ndarray") -> np.ndarray:
    """``T_map_pose`` (4, 4) float64 of a 7-number pose ``[qw, qx, qy, qz, x, y, z]`` (quaternion normalised).

    Raises:
        ValueError: if ``pose`` does not have 7 numbers or its quaternion has zero length.
    """
    p = np.asarray(pose, dtype=np.float64).reshape(-1)
    if p.shape != (7,):
        raise ValueError(f"a pose needs 7 numbers [qw,qx,qy,qz,x,y,z], got {p.shape[0]}")
    T = np.eye(4)
    T[:3, :3] = quaternion_wxyz_to_matrix(p[:4])
    T[:3, 3] = p[4:]
    return T


def pose7_to_se2(pose: "list[float] | np.ndarray") -> np.ndarray:
    """SE(2) pose (3,) float64 ``[x, y, yaw]`` of a 7-number pose: position x, y and the yaw of its rotation."""
    T = pose7_to_matrix(pose)
    return np.array([T[0, 3], T[1, 3], math.atan2(T[1, 0], T[0, 0])])


def start_pose_to_se2(pose: "list[float] | np.ndarray") -> np.ndarray:
    """SE(2) pose (3,) float64 ``[x, y, yaw]`` where the original's simulator placed the robot for an environment's
    ``start_pose`` ``[qw, qx, qy, qz, x, y, z]``: the yaw of the rotation matrix that the unit-quaternion formula
    gives for the four numbers *as written*, ``atan2(2(qw·qz + qx·qy), 1 − 2(qy² + qz²))``, without normalising
    them (the original wrote the start pose into its simulator's configuration as it was). For a unit quaternion
    this is :func:`pose7_to_se2`'s yaw; for house's ``[1, 0, 0, 0.8]`` it is 99.9° where normalising gives 77.3° —
    and the original's recorded trajectory of house:1 begins at the start position with a yaw of 99.8°
    (docs/original-benchbot.md, section 10).

    Raises:
        ValueError: not 7 finite numbers, or a quaternion of zeros.
    """
    p = np.asarray(pose, dtype=np.float64).reshape(-1)
    if p.shape[0] != 7 or not np.isfinite(p).all():
        raise ValueError(f"a pose needs 7 finite numbers [qw,qx,qy,qz,x,y,z], got {p.tolist()}")
    w, x, y, z = p[:4]
    if not (w or x or y or z):
        raise ValueError("the quaternion of a pose cannot be all zeros")
    return np.array([p[4], p[5], math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))])


def se2_to_matrix(x: float, y: float, yaw: float, z: float = 0.0) -> np.ndarray:
    """``T`` (4, 4) float64 of a planar pose at height ``z`` (metres), rotated by ``yaw`` (radians) about +z."""
    c, s = math.cos(yaw), math.sin(yaw)
    T = np.eye(4)
    T[:2, :2] = [[c, -s], [s, c]]
    T[:3, 3] = (x, y, z)
    return T


def se2_to_matrices(poses: np.ndarray) -> np.ndarray:
    """(N, 4, 4) float64 ``T`` of N planar poses ``[x m, y m, yaw rad]`` (N, 3) on the floor (z = 0): each is
    :func:`se2_to_matrix` of one row."""
    poses = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    T = np.zeros((len(poses), 4, 4))
    T[:, 0, 0], T[:, 0, 1], T[:, 1, 0], T[:, 1, 1] = c, -s, s, c
    T[:, :2, 3] = poses[:, :2]
    T[:, 2, 2] = T[:, 3, 3] = 1.0
    return T


def se2_compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """SE(2) product ``a · b`` of two (3,) poses ``[x, y, yaw]``; yaw wrapped to [-π, π)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return np.array([a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], wrap_angle(a[2] + b[2])])


def se2_relative(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """SE(2) ``a⁻¹ · b``: pose ``b`` (3,) expressed in the frame of pose ``a`` (3,)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return np.array([c * dx + s * dy, -s * dx + c * dy, wrap_angle(b[2] - a[2])])


def se2_compose_many(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """SE(2) products ``a · b`` of poses ``[x, y, yaw]`` in arrays (..., 3) that broadcast together: each is
    :func:`se2_compose` of one pair (yaw wrapped to [-π, π)); float64 (..., 3)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack([a[..., 0] + c * b[..., 0] - s * b[..., 1], a[..., 1] + s * b[..., 0] + c * b[..., 1],
                     wrap_angle(a[..., 2] + b[..., 2])], axis=-1)


def se2_relative_many(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """SE(2) ``a⁻¹ · b`` of poses in arrays (..., 3) that broadcast together: each is :func:`se2_relative` of one
    pair; float64 (..., 3)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    dx, dy = b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]
    return np.stack([c * dx + s * dy, -s * dx + c * dy, wrap_angle(b[..., 2] - a[..., 2])], axis=-1)


def pose_observation(T_parent_frame: np.ndarray, parent_frame: str) -> dict:
    """One entry of the ``poses`` observation (docs/observations.md) from ``T_parent_frame`` (4, 4).

    Returns:
        ``{'parent_frame': str, 'translation_xyz': (3,) float64 metres, 'rotation_rpy': (3,) float64 [roll, pitch,
        yaw] radians (static xyz), 'rotation_xyzw': (4,) float64 unit quaternion [x, y, z, w]}``: the three arrays
        are NumPy arrays, as the original API documented, in process and over either protocol alike.
    """
    T = np.asarray(T_parent_frame, dtype=np.float64)
    return {
        "parent_frame": parent_frame,
        "translation_xyz": T[:3, 3].copy(),
        "rotation_rpy": np.array(matrix_to_rpy(T[:3, :3]), dtype=np.float64),
        "rotation_xyzw": matrix_to_quaternion_xyzw(T[:3, :3]),
    }
