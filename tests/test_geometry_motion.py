"""Poses and the original pose controller (docs/original-benchbot.md, section 6), on plain numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchbot.core.geometry import (
    matrix_to_quaternion_xyzw, matrix_to_rpy, pose7_to_matrix, pose7_to_se2, quaternion_wxyz_to_matrix,
    quaternion_xyzw_to_matrix, rpy_to_matrix, se2_compose, se2_relative, wrap_angle,
)
from benchbot.core.motion import ControllerGains, PoseController


def test_euler_angles_are_static_xyz_and_round_trip():
    roll, pitch, yaw = 0.2, -0.4, 2.5
    Rx = np.array([[1, 0, 0], [0, math.cos(roll), -math.sin(roll)], [0, math.sin(roll), math.cos(roll)]])
    Ry = np.array([[math.cos(pitch), 0, math.sin(pitch)], [0, 1, 0], [-math.sin(pitch), 0, math.cos(pitch)]])
    Rz = np.array([[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0], [0, 0, 1]])
    assert np.allclose(rpy_to_matrix(roll, pitch, yaw), Rz @ Ry @ Rx, atol=1e-12)
    assert matrix_to_rpy(Rz @ Ry @ Rx) == pytest.approx((roll, pitch, yaw), abs=1e-12)


def test_gimbal_lock_gives_angles_of_the_same_rotation_without_a_warning(recwarn):
    R = rpy_to_matrix(0.3, math.pi / 2, -0.5)  # pitch straight up: roll and yaw turn about the same axis
    angles = matrix_to_rpy(R)
    assert np.allclose(rpy_to_matrix(*angles), R, atol=1e-9) and not recwarn.list


def test_quaternion_orders_and_bad_quaternions():
    w, x, y, z = 0.7, 0.1, -0.2, 0.3
    assert np.allclose(quaternion_wxyz_to_matrix([w, x, y, z]), quaternion_xyzw_to_matrix([x, y, z, w]))
    q = matrix_to_quaternion_xyzw(quaternion_xyzw_to_matrix([x, y, z, -w]))  # w ≥ 0, unit length
    assert q[3] >= 0 and np.linalg.norm(q) == pytest.approx(1.0)
    for bad in ([0, 0, 0, 0], [1, 0, float("nan"), 0], [1, 0, 0]):
        with pytest.raises(ValueError, match="quaternion"):
            quaternion_xyzw_to_matrix(bad)


def test_unnormalised_start_pose_is_normalised():
    # house start pose [1,0,0,0.8,...] is yaw 77.3 degrees once normalised (docs/simulator.md)
    x, y, yaw = pose7_to_se2([1, 0, 0, 0.8, -1.8, -2.5, 0.3])
    assert (x, y) == (-1.8, -2.5)
    assert math.degrees(yaw) == pytest.approx(77.32, abs=0.01)


def test_rotation_roundtrip():
    T = pose7_to_matrix([0.7, 0.1, -0.2, 0.3, 1, 2, 3])
    q = matrix_to_quaternion_xyzw(T[:3, :3])
    T2 = pose7_to_matrix([q[3], q[0], q[1], q[2], 1, 2, 3])
    assert np.allclose(T, T2)
    roll, pitch, yaw = matrix_to_rpy(pose7_to_matrix([math.cos(0.3), 0, 0, math.sin(0.3), 0, 0, 0])[:3, :3])
    assert (roll, pitch) == pytest.approx((0, 0)) and yaw == pytest.approx(0.6)


def test_se2_inverse_and_wrap():
    a, b = np.array([1.0, 2.0, 0.5]), np.array([-1.0, 0.5, 3.0])
    assert np.allclose(se2_compose(a, se2_relative(a, b)), [b[0], b[1], wrap_angle(b[2])])
    assert wrap_angle(math.pi) == pytest.approx(-math.pi)


def _drive(goal, start=(0.0, 0.0, 0.0)):
    pose = np.array(start, dtype=float)
    ctl = PoseController(np.array(goal), ControllerGains())
    steps = 0
    while (cmd := ctl.command(pose)) is not None:
        v, w = cmd
        assert -0.6 - 1e-9 <= v <= 1.5 + 1e-9 and abs(w) <= 1.0 + 1e-9
        dt = 0.05
        pose = np.array([pose[0] + v * dt * math.cos(pose[2]), pose[1] + v * dt * math.sin(pose[2]), wrap_angle(pose[2] + w * dt)])
        steps += 1
    return pose, steps


@pytest.mark.parametrize("goal", [(0.5, 0.0, 0.0), (-0.4, 0.0, 0.0), (0.0, 0.0, math.radians(90)), (1.0, 0.8, 2.0)])
def test_controller_reaches_goal_within_tolerance(goal):
    pose, steps = _drive(goal)
    assert math.hypot(pose[0] - goal[0], pose[1] - goal[1]) <= 0.02
    assert abs(wrap_angle(pose[2] - goal[2])) <= math.radians(1.0) + 1e-6
    assert steps < 2 * 30 * 20


def test_goal_behind_drives_backwards():
    ctl = PoseController(np.array([-1.0, 0.0, 0.0]))
    v, _ = ctl.command(np.zeros(3))
    assert v < 0
