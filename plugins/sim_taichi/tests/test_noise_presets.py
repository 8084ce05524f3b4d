"""Noise presets in the simulator (option ``noise``, docs/noise.md): applied to the observations served, seeded per
scene and frame, never to segmentation or poses."""

from __future__ import annotations

import numpy as np
import pytest

from benchbot.core import noise
from benchbot.core.errors import BackendError
from benchbot.core.geometry import pose7_to_se2

W, H = 160, 120


def observe(make_backend, env, seed, preset, pose_index=3):
    b = make_backend(W, H, **({} if preset is None else {"noise": preset}))
    try:
        b.load_scene(env, seed=seed)
        b.move_to(pose7_to_se2(env["trajectory_poses"][pose_index]))
        obs = b.observe(["image_rgb", "image_depth", "laser", "image_segment"])
        return obs, b.frame_transforms()
    finally:
        b.close()


@pytest.fixture(scope="module")
def clean(bear_envs, carter_spec):
    from benchbot_sim_taichi.backend import TaichiSimBackend

    b = TaichiSimBackend(carter_spec, {"arch": "cpu", "width": W, "height": H})
    env = bear_envs["miniroom:1"]
    b.load_scene(env, seed=5)
    b.move_to(pose7_to_se2(env["trajectory_poses"][3]))
    obs = b.observe(["image_rgb", "image_depth", "laser", "image_segment"])
    tf = b.frame_transforms()
    b.close()
    return obs, tf


def test_same_seed_same_observations_other_seed_other_noise(bear_envs, make_backend):
    env = bear_envs["miniroom:1"]
    a, _ = observe(make_backend, env, 5, "realistic")
    b, _ = observe(make_backend, env, 5, "realistic")
    c, _ = observe(make_backend, env, 6, "realistic")
    for key in ("image_rgb", "image_depth"):
        assert np.array_equal(a[key], b[key]) and not np.array_equal(a[key], c[key])
    assert np.array_equal(a["laser"]["scans"], b["laser"]["scans"])
    assert not np.array_equal(a["laser"]["scans"], c["laser"]["scans"])


def test_none_changes_nothing_and_ground_truth_never_gets_noise(bear_envs, make_backend, clean):
    env = bear_envs["miniroom:1"]
    clean_obs, clean_tf = clean
    none, _ = observe(make_backend, env, 5, "none")
    for key in ("image_rgb", "image_depth"):
        assert np.array_equal(none[key], clean_obs[key])
    noisy, tf = observe(make_backend, env, 5, "high")
    assert not np.array_equal(noisy["image_rgb"], clean_obs["image_rgb"])
    for key in ("class_segment_img", "instance_segment_img"):
        assert np.array_equal(noisy["image_segment"][key], clean_obs["image_segment"][key])
    for frame in clean_tf:
        assert np.array_equal(tf[frame], clean_tf[frame])
    assert noisy["image_depth"].dtype == np.float32 and noisy["image_rgb"].dtype == np.uint8


def test_depth_and_laser_errors_have_the_preset_spread(bear_envs, make_backend, clean):
    """On a real render: normalised depth residuals (noisy − clean) / σ(clean z) over the kept pixels have mean ≈ 0
    and standard deviation ≈ 1; the laser's residuals over beams that returned have σ ≈ the preset's."""
    clean_obs, _ = clean
    preset = noise.get_preset("realistic")
    noisy, _ = observe(make_backend, bear_envs["miniroom:1"], 5, "realistic")
    z, zn = clean_obs["image_depth"].astype(np.float64), noisy["image_depth"].astype(np.float64)
    kept = (z > 0) & (zn > 0)
    r = (zn[kept] - z[kept]) / noise.depth_sigma(z[kept], preset["depth"])
    n = r.size
    assert n > 0.8 * (z > 0).sum()
    assert abs(r.mean()) < 5 / np.sqrt(n) + 0.01  # float32 storage adds ~1e-7 m
    assert abs(r.std() - 1.0) < 5 * np.sqrt(0.5 / n) + 0.01
    ranges, noisy_ranges = clean_obs["laser"]["scans"][:, 0], noisy["laser"]["scans"][:, 0]
    hit = ranges < clean_obs["laser"]["range_max"]
    dr = noisy_ranges[hit] - ranges[hit]
    assert abs(dr.std() / preset["laser"]["sigma_m"] - 1.0) < 5 * np.sqrt(0.5 / hit.sum())
    assert np.array_equal(noisy["laser"]["scans"][:, 1], clean_obs["laser"]["scans"][:, 1])


def test_unknown_preset_is_a_backend_error(carter_spec):
    from benchbot_sim_taichi.backend import TaichiSimBackend

    with pytest.raises(BackendError) as e:
        TaichiSimBackend(carter_spec, {"arch": "cpu", "noise": "extreme"})
    assert "options.noise 'extreme' is not a noise preset" in e.value.message
