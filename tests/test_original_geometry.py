"""The original's geometry where the robot starts and moves (docs/original-benchbot.md, sections 6 and 11): the start
pose is the original's, the robot's obstacles are the original's ground-truth cuboids (every furniture model lies
inside its cuboid), the original's recorded trajectories are free for carter's footprint — and so the original
``hello_benchbot``'s first 1 m move in miniroom:1, which drives straight at the bed 0.52 m ahead, is a collision
here just as it was a contact in the original's physics (whose collision check was a stub and never said so)."""

from __future__ import annotations

import os

import numpy as np
import pytest

from benchbot.core.geometry import pose7_to_se2, start_pose_to_se2, wrap_angle

BEAR = [f"{name}:{v}" for name in ("miniroom", "house") for v in range(1, 6)]


#: Where the original's recorded trajectory begins with the robot still where the simulator placed it. (In house:2
#: it had moved 0.11 m; in house:3 it was turning: 107.6°, then 133.4°.)
AT_REST = ["miniroom:1", "miniroom:2", "miniroom:3", "miniroom:4", "miniroom:5", "house:1", "house:4", "house:5"]


@pytest.mark.parametrize("env", AT_REST)
def test_the_start_pose_is_where_the_original_placed_the_robot(registry, env):
    """The start yaw is the original's, ``atan2(2(wz + xy), 1 − 2(y² + z²))`` of the quaternion as written: where
    the original's recorded trajectory begins at the start position, its first pose has that yaw within 1.5°
    (house:1's ``[1, 0, 0, 0.8]``: 99.9° here, 99.8° recorded; normalising the quaternion gave 77.3°)."""
    spec = registry.get("environments", env)
    start = start_pose_to_se2(spec["start_pose"])
    first = pose7_to_se2(spec["trajectory_poses"][0])
    assert np.hypot(*(first[:2] - start[:2])) < 0.01, (start, first)
    assert abs(wrap_angle(first[2] - start[2])) < np.radians(1.5), np.degrees([start[2], first[2]])


def test_start_yaw_of_a_unit_quaternion_is_unchanged_and_house_turns_to_the_original_s():
    assert start_pose_to_se2([0, 0, 0, 1, 6.0, 0.5, 0.3]) == pytest.approx([6.0, 0.5, np.pi])
    assert start_pose_to_se2([np.cos(0.3), 0, 0, np.sin(0.3), 1, 2, 0]) == pytest.approx([1, 2, 0.6])
    assert np.degrees(start_pose_to_se2([1, 0, 0, 0.8, -1.8, -2.5, 0.3])[2]) == pytest.approx(99.93, abs=0.01)
    assert np.degrees(pose7_to_se2([1, 0, 0, 0.8, -1.8, -2.5, 0.3])[2]) == pytest.approx(77.32, abs=0.01)
    with pytest.raises(ValueError):
        start_pose_to_se2([0, 0, 0, 0, 1, 2, 3])


@pytest.mark.slow
def test_the_episode_and_the_simulator_start_at_the_original_s_yaw(make_service):
    """house:1's robot stands at 99.9° in the simulator and the episode, and is not dirty there."""
    service = make_service("semantic_slam:active:ground_truth", "house:1")
    pose = service.call(lambda: service.episode.backend.base_pose())
    assert np.degrees(pose[2]) == pytest.approx(99.93, abs=0.01)
    assert np.degrees(service.episode.start_se2[2]) == pytest.approx(99.93, abs=0.01)
    assert service.call(lambda: service.episode.state())["is_dirty"] is False


@pytest.fixture(scope="module")
def miniroom_1(registry):
    """miniroom:1 in the furnished style, the default (the test suite's conftest picks the primitives style)."""
    from benchbot.core.session import resolve_run, start_service

    saved = os.environ.get("BENCHBOT_SIM_STYLE")
    os.environ["BENCHBOT_SIM_STYLE"] = "furnished"
    try:
        service = start_service(registry, resolve_run(registry, "semantic_slam:active:ground_truth", "carter",
                                                      "miniroom:1"), seed=0, options={"width": 64, "height": 48})
    finally:
        os.environ["BENCHBOT_SIM_STYLE"] = saved if saved is not None else ""
        if saved is None:
            del os.environ["BENCHBOT_SIM_STYLE"]
    yield service
    service.close()


@pytest.mark.slow
def test_furniture_models_lie_inside_their_cuboids(miniroom_1):
    """No furnished model is larger than the ground-truth cuboid it was fitted to (which is what the robot's
    footprint is checked against), so what the camera sees is never closer than what stops the robot."""
    from benchbot_worlds.scene.model import PRIM_TRIANGLE

    scene = miniroom_1.call(lambda: miniroom_1.episode.backend.scene)
    triangles = scene.prim_type == PRIM_TRIANGLE
    owner, index = scene.prim_object[triangles], scene.prim_axis[triangles]
    fitted = 0
    for k in range(scene.n_boxes):
        vertices = scene.tri_v[index[owner == k]].reshape(-1, 3)
        if len(vertices):
            fitted += 1
            assert (vertices.min(0) >= scene.box_min[k] - 1e-4).all(), scene.box_names[k]
            assert (vertices.max(0) <= scene.box_max[k] + 1e-4).all(), scene.box_names[k]
    assert fitted >= 15  # the furnished style: models for (nearly) every object


@pytest.mark.slow
def test_the_original_trajectory_is_free_and_hello_benchbot_meets_the_bed(miniroom_1):
    """Every pose the original robot recorded keeps carter's 0.25 m footprint clear of every obstacle; from the
    start pose, the bed's cuboid is 0.515 m straight ahead, so a 1 m move stops after about a quarter of a metre
    with ``COLLISION`` (the original's first move of ``hello_benchbot`` drove into it too)."""

    def check():
        backend = miniroom_1.episode.backend
        obstacles, start = backend.obstacles, backend.base_pose()
        for pose in backend.scene.trajectory_se2:
            assert obstacles.clearance(pose[:2])[0] > 0.05, pose
        ahead = np.array([np.cos(start[2]), np.sin(start[2])])
        clearance, name = obstacles.clearance(start[:2] + 0.3 * ahead)
        assert "bed" in name and clearance < 0
        goal = start.copy()
        goal[:2] += 1.0 * ahead
        outcome = backend.move_to(goal)
        travelled = float(np.hypot(*(backend.base_pose()[:2] - start[:2])))
        backend.set_pose(start)
        return outcome, travelled, name

    outcome, travelled, name = miniroom_1.call(check)
    assert outcome.collided
    assert 0.2 < travelled < 0.27, travelled  # 0.515 m to the bed's cuboid less the 0.25 m footprint
