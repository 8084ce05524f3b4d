"""The episode state machine on the real Taichi simulator (docs/protocol.md, with the listed bugs fixed)."""

from __future__ import annotations


import numpy as np
import pytest

from benchbot.core.errors import ActionError
from benchbot.core.geometry import pose7_to_se2, start_pose_to_se2

PASSIVE = "semantic_slam:passive:ground_truth"
ACTIVE = "semantic_slam:active:ground_truth"
SCD_ACTIVE = "scd:active:ground_truth"
DEAD_RECKONING = "semantic_slam:active:dead_reckoning"


def test_passive_trajectory_runs_to_finished(make_service, registry):
    service = make_service(PASSIVE, "miniroom:4")  # the shortest trajectory (33 poses)
    ep = service.episode
    trajectory = registry.get("environments", "miniroom:4")["trajectory_poses"]
    assert ep.actions == ["move_next"] and not ep.is_finished
    results = [service.call(ep.act, "move_next") for _ in trajectory]
    assert results[:-1] == ["SUCCESS"] * (len(trajectory) - 1) and results[-1] == "FINISHED"
    assert ep.actions == [] and ep.is_finished and not ep.collided
    assert np.allclose(ep.backend.base_pose()[:2], pose7_to_se2(trajectory[-1])[:2], atol=0.02)
    with pytest.raises(ActionError, match="FINISHED"):
        service.call(ep.act, "move_next")


def test_actions_outside_the_task_are_refused(make_service):
    ep = make_service(PASSIVE, "miniroom:1").episode
    with pytest.raises(ActionError, match="not an action of this task"):
        ep.act("move_distance", {"distance": 0.1})
    active = make_service(ACTIVE, "miniroom:1").episode
    with pytest.raises(ActionError, match="finite number"):
        active.act("move_distance", {"distance": "far"})


@pytest.mark.slow
def test_observations_have_the_reference_structures(make_service):
    service = make_service(PASSIVE, "miniroom:1")
    ep = service.episode
    obs = service.call(ep.observe)
    assert obs["image_rgb"].shape == (48, 64, 3) and obs["image_rgb"].dtype == np.uint8
    assert obs["image_depth"].shape == (48, 64) and obs["image_depth"].dtype == np.float32
    assert obs["image_rgb_info"]["matrix_intrinsics"].shape == (3, 3)
    assert obs["image_rgb_info"]["matrix_projection"].shape == (3, 4)
    assert obs["laser"]["scans"].shape[1] == 2
    assert set(obs["poses"]) == {"camera", "lidar", "robot", "initial_pose"}
    robot = obs["poses"]["robot"]
    assert robot["parent_frame"] == "map" and robot["translation_xyz"].shape == (3,)
    assert np.isclose(np.linalg.norm(robot["rotation_xyzw"]), 1.0)
    assert obs["scene_number"] == 0
    with pytest.raises(ActionError, match="not part of task"):
        service.call(ep.observe, ["image_segment"])


def test_initial_pose_is_reported_at_the_robot_frames_height(registry):
    """The robot frame's height (sim_taichi's ``sensors.robot_frame_height_m``) is that of ``robot`` and of
    ``initial_pose`` alike, before and after a motion, in both localisation modes."""
    from benchbot.core.episode import Episode
    from benchbot_sim_taichi.backend import create_backend

    robot = dict(registry.get("robots", "carter"))
    robot["sensors"] = {**robot.get("sensors", {}), "robot_frame_height_m": 0.3}
    for task in (ACTIVE, DEAD_RECKONING):
        ep = Episode(registry.get("tasks", task), robot, registry.scenes("miniroom:1"),
                     create_backend(robot, {"width": 32, "height": 24, "arch": "cpu"}))
        try:
            before = ep.observe(["poses"])["poses"]
            assert ep.act("move_angle", {"angle": 20}) == "SUCCESS"
            after = ep.observe(["poses"])["poses"]
            for poses in (before, after):
                assert poses["robot"]["translation_xyz"][2] == pytest.approx(0.3)
                assert poses["initial_pose"]["translation_xyz"][2] == pytest.approx(0.3)
            np.testing.assert_allclose(after["initial_pose"]["translation_xyz"], before["robot"]["translation_xyz"])
        finally:
            ep.backend.close()


def test_moving_makes_dirty_and_collision_ends_actions(make_service):
    service = make_service(ACTIVE, "miniroom:1")
    ep = service.episode
    assert service.call(ep.act, "move_angle", {"angle": 30}) == "SUCCESS"
    assert ep.dirty  # more than 2 degrees from the start pose
    result = "SUCCESS"
    for _ in range(20):  # straight ahead until something is hit
        result = service.call(ep.act, "move_distance", {"distance": 1.0})
        if result != "SUCCESS":
            break
    assert result == "COLLISION" and ep.collided and ep.actions == []
    with pytest.raises(ActionError, match="COLLISION"):
        service.call(ep.act, "move_angle", {"angle": 10})
    assert service.call(ep.reset) and not ep.collided and not ep.dirty and ep.actions


def test_next_reset_and_restart(make_service, registry):
    service = make_service(SCD_ACTIVE, "house:1:2")
    ep = service.episode
    start_2 = start_pose_to_se2(registry.get("environments", "house:2")["start_pose"])
    service.call(ep.act, "move_angle", {"angle": 45})
    first_initial = ep.initial_pose.copy()
    assert service.call(ep.next) is True and ep.scene_index == 1
    assert np.allclose(ep.backend.base_pose(), start_2, atol=1e-9)
    assert ep.initial_pose is None  # fixed: not carried over from scene 1
    service.call(ep.act, "move_angle", {"angle": 45})
    assert not np.allclose(ep.initial_pose, first_initial)
    assert service.call(ep.next) is False  # last scene
    service.call(ep.act, "move_distance", {"distance": 0.2})
    assert service.call(ep.restart) and ep.scene_index == 1 and ep.initial_pose is not None
    assert service.call(ep.reset) and ep.scene_index == 0  # fixed: really scene 0
    assert ep.selected_environment() == {"name": "house", "variant": 1, "number": 0}
    start_1 = start_pose_to_se2(registry.get("environments", "house:1")["start_pose"])
    assert np.allclose(ep.backend.base_pose(), start_1, atol=1e-9)


def test_dead_reckoning_poses_drift_deterministically(make_service):
    def run(seed):
        service = make_service(DEAD_RECKONING, "miniroom:1", seed=seed)
        ep = service.episode
        for action, args in [("move_angle", {"angle": 90}), ("move_distance", {"distance": 0.3})] * 2:
            service.call(ep.act, action, args)
        obs = service.call(ep.observe, ["poses"])
        return obs["poses"]["robot"]["translation_xyz"], ep.backend.base_pose()

    believed, truth = run(seed=3)
    believed_again, _ = run(seed=3)
    assert np.array_equal(believed, believed_again)
    assert not np.allclose(believed[:2], truth[:2], atol=1e-4)
    assert np.allclose(believed[:2], truth[:2], atol=0.3)
