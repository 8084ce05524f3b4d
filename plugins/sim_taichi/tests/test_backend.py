"""TaichiSimBackend: the RobotBackend contract, motion, collisions, observations, determinism."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchbot.core.errors import BackendError
from benchbot.core.geometry import pose7_to_se2, se2_compose, se2_relative, start_pose_to_se2
from benchbot.core.robot import MotionOutcome, RobotBackend

ALL = ["image_rgb", "image_depth", "image_rgb_info", "image_depth_info", "laser", "image_segment"]


def _reached(pose, goal):
    e = se2_relative(pose, goal)
    return math.hypot(e[0], e[1]) <= 0.01 + 1e-9 and abs(e[2]) <= math.radians(1.0) + 1e-9


def _count_calls(monkeypatch, owner, name: str) -> list:
    """Wrap ``owner.name`` so that each call appends to the returned list (the calls still happen)."""
    calls, real = [], getattr(owner, name)
    monkeypatch.setattr(owner, name, lambda *a, **k: calls.append(1) or real(*a, **k))
    return calls


@pytest.mark.slow
def test_factory_and_start_pose(bear_envs, carter_spec):
    from benchbot_sim_taichi import plugin

    b = plugin.benchbot_robot_backends()["sim_taichi"](carter_spec, {"width": 32, "height": 24})
    assert isinstance(b, RobotBackend)
    with pytest.raises(BackendError):
        b.observe(["image_rgb"])
    env = bear_envs["house:1"]  # start quaternion [1,0,0,0.8] is not unit length
    b.load_scene(env)
    p = b.base_pose()
    assert p.shape == (3,) and p.dtype == np.float64
    np.testing.assert_allclose(p, start_pose_to_se2(env["start_pose"]))
    assert math.degrees(p[2]) == pytest.approx(99.93, abs=0.01)  # as the original placed it (not 77.32)
    tf = b.frame_transforms()
    assert set(tf) >= {"robot", "camera", "lidar"}
    assert tf["robot"][2, 3] == pytest.approx(0.244)  # carter's robot frame, as the original's (its rigid body)
    cam = tf["camera"]
    # optical frame: z forward (= robot +x), x right (= robot -y), y down; where the original's left camera was:
    # 0.81 m above the robot frame (0.244 m), 0.11 m ahead and 0.06 m to the left
    R_robot = tf["robot"][:3, :3]
    np.testing.assert_allclose(cam[:3, 2], R_robot[:, 0], atol=1e-12)
    np.testing.assert_allclose(cam[:3, 0], -R_robot[:, 1], atol=1e-12)
    np.testing.assert_allclose(cam[:3, 1], [0, 0, -1], atol=1e-12)
    assert cam[2, 3] == pytest.approx(0.244 + 0.81)
    assert cam[2, 3] - tf["robot"][2, 3] == pytest.approx(0.81)
    np.testing.assert_allclose(np.linalg.inv(tf["robot"])[:2] @ cam[:, 3], [0.11, 0.06], atol=1e-9)
    assert tf["lidar"][2, 3] == pytest.approx(0.62)
    b.close()


def test_carter_is_as_tall_as_its_camera_and_furnishing_knows_it(carter_spec):
    """The camera sits where the original's did (1.054 m): the robot's height, the furnishing's clearance and the
    backend's defaults all say the same robot."""
    from benchbot_sim_taichi.backend import DEFAULT_SENSORS
    from benchbot_worlds.homes.furnish_space import ROBOT_HEIGHT_M

    sensors = carter_spec["sensors"]
    assert sensors["max_height_m"] >= sensors["camera"]["mount_xyz"][2]
    assert sensors["max_height_m"] == ROBOT_HEIGHT_M == DEFAULT_SENSORS["max_height_m"]
    assert sensors["camera"]["mount_xyz"] == DEFAULT_SENSORS["camera"]["mount_xyz"]
    assert sensors["laser"]["mount_xyz"] == DEFAULT_SENSORS["laser"]["mount_xyz"]


def test_observe_structures_and_cache(bear_envs, make_backend, monkeypatch):
    b = make_backend(40, 30)
    b.load_scene(bear_envs["miniroom:1"])
    calls = _count_calls(monkeypatch, b._renderer, "render")
    obs = b.observe(ALL)
    assert set(obs) == set(ALL)
    obs2 = b.observe(["image_depth", "image_segment", "image_rgb"])
    assert len(calls) == 1
    rgb, depth = obs["image_rgb"], obs["image_depth"]
    assert rgb.shape == (30, 40, 3) and rgb.dtype == np.uint8
    assert depth.shape == (30, 40) and depth.dtype == np.float32 and np.all(depth > 0)
    assert np.array_equal(obs2["image_depth"], depth)
    for k in ("image_rgb_info", "image_depth_info"):
        info = obs[k]
        assert info["frame_id"] == "camera" and (info["height"], info["width"]) == (30, 40)
        K, P = info["matrix_intrinsics"], info["matrix_projection"]
        assert K.shape == (3, 3) and P.shape == (3, 4) and K.dtype == np.float64
        np.testing.assert_array_equal(P[:, :3], K)
        np.testing.assert_array_equal(P[:, 3], 0)
    las = obs["laser"]
    sc = las["scans"]
    assert sc.shape == (360, 2) and sc.dtype == np.float64
    assert np.all(sc[:, 1] >= -math.pi) and np.all(sc[:, 1] < math.pi)
    assert np.all(sc[:, 0] <= las["range_max"]) and np.all(sc[:, 0] >= 0.25)  # nothing inside the footprint
    seg = obs["image_segment"]
    cls, inst, ids = seg["class_segment_img"], seg["instance_segment_img"], seg["class_ids"]
    assert cls.shape == (30, 40) and inst.shape == (30, 40) and inst.dtype == np.int32
    assert ids["background"] == 30 and ids["bed"] == 21
    fg = inst > 0
    assert fg.any() and (~fg).any()
    np.testing.assert_array_equal(inst[fg] // 1000, cls[fg])
    assert np.all(cls[~fg] == 30)
    with pytest.raises(KeyError):
        b.observe(["image_rgb", "nonsense"])
    # moving invalidates the cache
    b.move_to(se2_compose(b.base_pose(), np.array([0.0, 0.0, math.radians(30)])))
    b.observe(["image_rgb"])
    assert len(calls) == 2


def test_borrowed_observations_are_the_cached_arrays_with_the_same_values(bear_envs, make_backend):
    b = make_backend(40, 30)
    b.load_scene(bear_envs["miniroom:1"])
    owned, borrowed = b.observe(ALL), b.observe_borrowed(ALL)
    again = b.observe_borrowed(ALL)
    for name, key in (("image_rgb", None), ("image_depth", None), ("laser", "scans"),
                      ("image_segment", "instance_segment_img"), ("image_segment", "class_segment_img")):
        mine, lent, lent_again = (o[name] if key is None else o[name][key] for o in (owned, borrowed, again))
        assert mine.dtype == lent.dtype and np.array_equal(mine, lent), name
        assert not np.shares_memory(mine, lent), f"observe gives {name} as a copy the caller owns"
        if key != "class_segment_img":  # converted to uint8: a new array each time
            assert np.shares_memory(lent, lent_again), f"observe_borrowed gives {name} without a copy"
            assert not lent.flags.writeable and mine.flags.writeable, "lent arrays cannot be written through"
    # the renderer never writes into a pose's arrays again: a new pose gets new ones
    b.move_to(se2_compose(b.base_pose(), np.array([0.0, 0.0, math.radians(30)])))
    moved = b.observe_borrowed(["image_rgb"])["image_rgb"]
    assert not np.shares_memory(moved, lent_again) and np.array_equal(borrowed["image_rgb"], owned["image_rgb"])


def test_move_distance_and_angle(bear_envs, make_backend):
    b = make_backend()
    b.load_scene(bear_envs["miniroom:1"])
    # turn to face free space (+x from the start at (1.2, 1.5) is open), then drive
    for goal_rel in ([0.0, 0.0, math.radians(90)], [0.3, 0.0, 0.0], [-0.2, 0.0, 0.0], [0.0, 0.0, math.radians(-45)]):
        start = b.base_pose()
        goal = se2_compose(start, np.array(goal_rel))
        out = b.move_to(goal)
        assert isinstance(out, MotionOutcome) and not out.collided
        assert _reached(b.base_pose(), goal)
        assert out.duration_s > 0.65


def test_drive_into_wall_collides(synthetic_env, make_backend):
    from benchbot_sim_taichi.kinematics import Obstacles

    env = synthetic_env([("chair", (1.0, 3.0, 0.4), (0.4, 0.4, 0.8))])
    b = make_backend()
    b.load_scene(env)
    wall_x = b.scene.room_max[0]
    out = b.move_to(np.array([wall_x + 1.0, 0.0, 0.0]))
    p = b.base_pose()
    assert out.collided
    assert p[0] < wall_x - b.radius  # stopped short of the wall
    assert wall_x - b.radius - p[0] < 0.1  # ...but close to it
    assert b.obstacles.clearance(p[:2])[0] > 0
    # furniture collides too
    b.load_scene(env)
    out = b.move_to(np.array([1.0, 3.0, math.pi / 2]))
    assert out.collided
    c, what = b.obstacles.clearance(b.base_pose()[:2])
    assert 0 < c < 0.1 and what == "chair_0"
    # an object above the robot's max height does not block it
    high = synthetic_env([("table", (1.0, 0.0, 1.6), (0.6, 0.6, 0.4))], name="high")
    b.load_scene(high)
    assert not b.move_to(np.array([1.0, 0.0, 0.0])).collided
    assert isinstance(b.obstacles, Obstacles)


@pytest.mark.slow
def test_all_trajectories_collision_free(bear_envs, carter_spec):
    """Driving the start pose through every trajectory pose of all ten environments never collides and reaches each
    pose within 0.01 m / 1°. (Kinematics only: no rendering.)"""
    from benchbot_sim_taichi.backend import sensor_config
    from benchbot_sim_taichi.kinematics import Obstacles, drive
    from benchbot_worlds.scene.build import build_scene

    sensors = sensor_config(carter_spec)
    for key, env in bear_envs.items():
        scene = build_scene(env)
        obstacles = Obstacles.from_scene(scene, sensors["footprint_radius_m"], sensors["max_height_m"])
        pose = scene.start_se2.copy()
        assert obstacles.clearance(pose[:2])[0] > 0, key
        for i, goal in enumerate(scene.trajectory_se2):
            pose, out = drive(pose, goal, obstacles)
            assert not out.collided, (key, i, obstacles.clearance(pose[:2]))
            assert _reached(pose, goal), (key, i)


def test_backend_trajectory_and_determinism(bear_envs, make_backend):
    env = bear_envs["miniroom:2"]
    runs = []
    for _ in range(2):
        b = make_backend(32, 24, seed=3)
        b.load_scene(env, seed=3)
        seq = []
        for p in env["trajectory_poses"][:6]:
            out = b.move_to(pose7_to_se2(p))
            assert not out.collided
            seq.append((b.base_pose(), b.observe(ALL)))
        runs.append(seq)
    for (pa, oa), (pb, ob) in zip(*runs):
        assert np.array_equal(pa, pb)
        for k in ("image_rgb", "image_depth"):
            assert np.array_equal(oa[k], ob[k])
        assert np.array_equal(oa["laser"]["scans"], ob["laser"]["scans"])
        for k in ("class_segment_img", "instance_segment_img"):
            assert np.array_equal(oa["image_segment"][k], ob["image_segment"][k])
    # another seed changes object colours, not geometry
    b = make_backend(32, 24)
    b.load_scene(env, seed=4)
    b.move_to(pose7_to_se2(env["trajectory_poses"][0]))
    o = b.observe(["image_depth"])
    b2 = make_backend(32, 24)
    b2.load_scene(env, seed=3)
    b2.move_to(pose7_to_se2(env["trajectory_poses"][0]))
    assert np.array_equal(o["image_depth"], b2.observe(["image_depth"])["image_depth"])


def test_robot_frame_height_lifts_the_robot_frame_only(bear_envs, carter_spec):
    """``sensors.robot_frame_height_m`` puts the robot frame that high above the floor (the original's carter: 0.244 m);
    the sensors stay where their mounts (from the footprint on the floor) put them: the same camera and lidar
    transforms, bit for bit, and the same images."""
    from benchbot_sim_taichi.backend import TaichiSimBackend

    def backend(height):
        spec = {**carter_spec, "sensors": {**carter_spec.get("sensors", {}), "robot_frame_height_m": height}}
        b = TaichiSimBackend(spec, {"arch": "cpu", "width": 32, "height": 24})
        b.load_scene(bear_envs["miniroom:1"])
        b.move_to(pose7_to_se2(bear_envs["miniroom:1"]["trajectory_poses"][0]))
        return b

    low, high = backend(0.0), backend(0.244)
    tf_low, tf_high = low.frame_transforms(), high.frame_transforms()
    assert tf_low["robot"][2, 3] == 0.0 and tf_high["robot"][2, 3] == 0.244
    np.testing.assert_array_equal(tf_high["robot"][:2], tf_low["robot"][:2])
    for frame in ("camera", "lidar"):
        np.testing.assert_array_equal(tf_high[frame], tf_low[frame])
    assert np.array_equal(high.observe(["image_depth"])["image_depth"], low.observe(["image_depth"])["image_depth"])
    low.close(), high.close()
    for bad in (-0.1, "high", True):
        spec = {**carter_spec, "sensors": {**carter_spec.get("sensors", {}), "robot_frame_height_m": bad}}
        with pytest.raises(BackendError) as e:
            TaichiSimBackend(spec, {"arch": "cpu"})
        assert "sensors.robot_frame_height_m" in e.value.message and "\n" not in e.value.message


def test_start_pose_in_collision_is_an_error(synthetic_env, make_backend):
    env = synthetic_env([("chair", (0.1, 0.0, 0.4), (0.4, 0.4, 0.8))])
    with pytest.raises(BackendError) as e:
        make_backend().load_scene(env)
    assert "chair_0" in e.value.message


def test_images_and_laser_of_a_pose_come_from_one_launch_with_the_same_values(bear_envs, make_backend, monkeypatch):
    both = make_backend(40, 30)
    both.load_scene(bear_envs["house:1"])
    launches = _count_calls(monkeypatch, both._renderer, "_launch")
    together = both.observe(["image_rgb", "image_depth", "image_segment", "laser"])
    assert len(launches) == 1
    apart = make_backend(40, 30)
    apart.load_scene(bear_envs["house:1"])
    separately = {**apart.observe(["laser"]), **apart.observe(["image_rgb", "image_depth", "image_segment"])}
    for key in ("image_rgb", "image_depth"):
        assert np.array_equal(together[key], separately[key])
    assert np.array_equal(together["laser"]["scans"], separately["laser"]["scans"])
    assert all(np.array_equal(together["image_segment"][k], separately["image_segment"][k])
               for k in ("class_segment_img", "instance_segment_img"))


def test_load_scene_renders_the_start_pose_once_so_that_no_request_waits_for_a_compile(bear_envs, make_backend,
                                                                                        monkeypatch):
    """Taichi compiles its kernels at the first render: load_scene renders the start pose (images and scan, one
    launch) so that a client's first request, with its own timeout, finds them compiled; it keeps no frame, so noise
    set after loading still applies to the first observation."""
    from benchbot_sim_taichi.render.renderer import Renderer

    launches = _count_calls(monkeypatch, Renderer, "_launch")
    b = make_backend(40, 30)
    b.load_scene(bear_envs["miniroom:1"])
    assert len(launches) == 1
    b.noise["depth_dropout"] = 0.5
    depth = b.observe(["image_depth"])["image_depth"]
    assert len(launches) == 2 and (depth == 0.0).mean() > 0.3  # dropped pixels
