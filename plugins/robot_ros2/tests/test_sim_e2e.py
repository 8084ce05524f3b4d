"""The simulator served over ROS 2 (a subprocess) driven by the ROS 2 backend: the observations have exactly the
structures of the directly simulated carter, the robot follows the trajectory, and a solution scores the same."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from benchbot.core.episode import Episode
from benchbot.core.registry import get_registry
from benchbot_robot_ros2.backend import Ros2RobotBackend

TASK = "semantic_slam:passive:ground_truth"


def _structure(v):
    if isinstance(v, dict):
        return {k: _structure(x) for k, x in v.items()}
    if isinstance(v, np.ndarray):
        return ("ndarray", v.dtype.str, v.shape)
    if isinstance(v, tuple):
        return ("tuple", len(v))
    return type(v).__name__


@pytest.mark.slow
def test_carter_ros2_observations_match_carter(sim_bridge, monkeypatch):
    from benchbot_sim_taichi.backend import create_backend

    domain, time_scale = sim_bridge
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain))
    monkeypatch.setenv("BENCHBOT_ROS2_TIME_SCALE", str(time_scale))
    reg = get_registry()
    task, env = reg.get("tasks", TASK), reg.scenes("miniroom:4")
    ros = Episode(task, reg.get("robots", "carter_ros2"), env,
                  Ros2RobotBackend(reg.get("robots", "carter_ros2"), {"seed": 0}))
    sim = Episode(task, reg.get("robots", "carter"), env,
                  create_backend(reg.get("robots", "carter"), {"width": 64, "height": 48, "arch": "cpu"}))
    try:
        for _ in range(3):
            assert ros.act("move_next") == sim.act("move_next") == "SUCCESS"
            o_ros, o_sim = ros.observe(), sim.observe()
            assert _structure(o_ros) == _structure(o_sim)
            for frame in ("robot", "camera", "lidar"):
                assert np.allclose(o_ros["poses"][frame]["translation_xyz"], o_sim["poses"][frame]["translation_xyz"],
                                   atol=0.03)
            assert o_ros["image_rgb_info"]["frame_id"] == o_sim["image_rgb_info"]["frame_id"]
            np.testing.assert_allclose(o_ros["image_rgb_info"]["matrix_intrinsics"],
                                       o_sim["image_rgb_info"]["matrix_intrinsics"])
            assert np.mean(np.abs(o_ros["image_depth"] - o_sim["image_depth"]) < 0.1) > 0.9
            # the same beam angles, from -π (a float32 -π on the wire must not become +π)
            np.testing.assert_allclose(o_ros["laser"]["scans"][:, 1], o_sim["laser"]["scans"][:, 1], atol=1e-6)
            assert o_ros["laser"]["range_max"] == o_sim["laser"]["range_max"]
            assert np.all(o_ros["laser"]["scans"][:, 0] <= o_ros["laser"]["range_max"])  # REP 117's +Inf: range_max
            assert np.isfinite(o_ros["image_depth"]).all()  # REP 118's NaN: the API's 0.0
        ros.reset()
        assert np.allclose(ros.backend.base_pose(), sim.start_se2, atol=1e-6)
        assert not ros.dirty and ros.scene_index == 0
    finally:
        ros.backend.close()
        sim.backend.close()


@pytest.mark.slow
def test_same_solution_same_omq_direct_and_through_ros2(tmp_path, domain_id):
    """semslam_geometric on miniroom:4 at 160×120: OMQ with --robot carter and --robot carter_ros2 within 0.02."""
    dom = domain_id + 3
    env = dict(os.environ, ROS_DOMAIN_ID=str(dom), BENCHBOT_ROS2_TIME_SCALE="4", COLUMNS="200")
    bridge = subprocess.Popen([sys.executable, "-m", "benchbot_robot_ros2.sim_bridge", "--env", "miniroom:4",
                               "--camera-size", "160x120", "--time-scale", "4", "--transport", "cyclonedds"],
                              env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    scores = {}
    try:
        for robot in ("carter", "carter_ros2"):
            out = tmp_path / robot
            proc = subprocess.run([sys.executable, "-m", "benchbot.cli", "batch", "--example", "semslam_geometric",
                                   "--envs", "miniroom:4", "--robot", robot, "--camera-size", "160x120", "--arch",
                                   "cpu", "--no-tui", "--output-dir", str(out)],
                                  env=env, capture_output=True, text=True, timeout=600)
            assert proc.returncode == 0, proc.stderr[-3000:]
            run_dir = next(out.iterdir())
            scores[robot] = json.loads((run_dir / "scores.json").read_text())["scores"]["OMQ"]
    finally:
        bridge.terminate()
        bridge.wait(10)
    assert scores["carter"] > 0.0
    assert abs(scores["carter"] - scores["carter_ros2"]) <= 0.02, scores
