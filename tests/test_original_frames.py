"""The original BenchBot's frame conventions, checked with its own example's geometry.

The original `semantic_slam_attempt` example (VoteNet) builds its network input from the depth image as points
``(x, depth, -y)`` — VoteNet's *depth* frame (x right, y forward, z up) — and VoteNet's ``parse_predictions``
returns the detected boxes' corners in its *upright camera* frame (``flip_axis_to_camera``: x right, y down,
z forward), to which the example applies ``poses['camera']``. That is the camera's optical frame, the frame the
original reported (docs/original-benchbot.md, section 5) and the one reported here (docs/observations.md). The test
runs that pipeline without the network: every object's pixels, taken through the same two frames and
``poses['camera']``, land inside the object's box in miniroom:1 — at the right height — and the room's own pixels
stay between its floor and ceiling.
"""

from __future__ import annotations

import numpy as np
import pytest


def _original_world_T_camera(rotation_xyzw, translation_xyz) -> np.ndarray:
    """The example's ``compute_world_T_camera``: a (4, 4) matrix for row vectors, ``P_w = P_c @ w_T_c``."""
    x, y, z, w = np.asarray(rotation_xyzw, dtype=np.float64)
    R = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])
    rotation, translation = np.eye(4), np.eye(4)
    rotation[:3, :3] = R.T
    translation[3, :3] = translation_xyz
    return rotation @ translation


def _original_point_cloud(obs: dict) -> np.ndarray:
    """The example's ``convert_depth_to_pointcloud``: (H·W, 3) points ``(x, depth, -y)`` (VoteNet's depth frame)."""
    depth, info = obs["image_depth"], obs["image_depth_info"]
    K = info["matrix_intrinsics"]
    u, v = np.meshgrid(np.arange(info["width"]), np.arange(info["height"]))
    x3 = (u - K[0, 2]) * depth / K[0, 0]
    y3 = (v - K[1, 2]) * depth / K[1, 1]
    return np.stack((x3.flatten(), depth.flatten(), -y3.flatten()), axis=1)


def _votenet_flip_axis_to_camera(points: np.ndarray) -> np.ndarray:
    """VoteNet's ``flip_axis_to_camera`` (models/ap_helper.py): depth frame (x right, y forward, z up) → upright
    camera frame (x right, y down, z forward), the frame of the corners ``parse_predictions`` returns."""
    out = points[:, [0, 2, 1]].copy()
    out[:, 1] *= -1
    return out


def _to_world(points_camera: np.ndarray, camera_pose: dict) -> np.ndarray:
    w_T_c = _original_world_T_camera(camera_pose["rotation_xyzw"], camera_pose["translation_xyz"])
    homogeneous = np.concatenate([points_camera, np.ones((len(points_camera), 1))], axis=1)
    return (homogeneous @ w_T_c)[:, :3]


@pytest.fixture(scope="module")
def miniroom_views():
    """Observations of carter (160×120) at five poses of miniroom:1's trajectory, with segmentation, and the scene."""
    from benchbot.core.registry import get_registry
    from benchbot.core.session import resolve_run, start_service

    reg = get_registry()
    service = start_service(reg, resolve_run(reg, "semantic_slam:passive:ground_truth", "carter", "miniroom:1"),
                            options={"width": 160, "height": 120})
    ep = service.episode
    views = []
    try:
        for step in range(0, 25, 5):
            while (ep.trajectory_next or 0) < step:
                assert service.call(ep.act, "move_next", {}) == "SUCCESS"
            obs = service.call(ep.observe, ["image_depth", "image_depth_info", "poses"])
            obs["image_segment"] = service.call(ep.backend.observe, ["image_segment"])["image_segment"]
            views.append(obs)
        yield views, ep.backend.scene
    finally:
        service.close()


def test_the_original_examples_boxes_land_on_the_objects(miniroom_views):
    views, scene = miniroom_views
    checked = 0
    for obs in views:
        hit = obs["image_depth"].flatten() > 0
        instance = obs["image_segment"]["instance_segment_img"].flatten()
        world = _to_world(_votenet_flip_axis_to_camera(_original_point_cloud(obs)), obs["poses"]["camera"])
        room = hit & (instance == 0)
        assert world[room, 2].min() > scene.room_min[2] - 0.02 and world[room, 2].max() < scene.room_max[2] + 0.02
        for k, inst in enumerate(scene.box_instance):
            mask = hit & (instance == inst)
            if mask.sum() < 20:
                continue
            pts = world[mask]
            lo, hi = scene.box_min[k] - 0.03, scene.box_max[k] + 0.03
            inside = np.all((pts >= lo) & (pts <= hi), axis=1)
            assert inside.mean() > 0.99, f"{scene.box_names[k]}: {inside.mean():.3f} of its points in its box"
            checked += 1
    assert checked >= 10  # objects of several classes, low and high, seen from several poses


def test_the_camera_pose_is_optical_so_the_votenet_input_frame_alone_misplaces_points(miniroom_views):
    """Applying ``poses['camera']`` to the network's *input* points ``(x, depth, -y)`` (skipping VoteNet's flip back
    to camera axes) puts the scene below the floor: the camera pose is the optical frame, not VoteNet's depth frame."""
    views, scene = miniroom_views
    obs = views[0]
    hit = obs["image_depth"].flatten() > 0
    wrong = _to_world(_original_point_cloud(obs), obs["poses"]["camera"])[hit]
    assert np.median(wrong[:, 2]) < scene.room_min[2] - 0.5
    cam = obs["poses"]["camera"]
    R = _original_world_T_camera(cam["rotation_xyzw"], cam["translation_xyz"])[:3, :3].T
    np.testing.assert_allclose(R[:, 1], [0, 0, -1], atol=1e-9)  # the camera's y axis points down: optical
