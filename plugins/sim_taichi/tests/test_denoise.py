"""Quality mode's denoiser: Intel Open Image Denoise (pyoidn) with the path tracer's albedo and normal guides, on the
real renderer (CPU): it brings a 4-sample image closer to a 64-sample one, is deterministic, and leaves a clean
image as it is."""

from __future__ import annotations

import numpy as np
import pytest

W, H = 64, 48


@pytest.fixture(scope="module")
def view(bear_envs):
    from benchbot_sim_taichi.renderer import Renderer, intrinsics
    from benchbot_sim_taichi.scene import build_scene
    from benchbot.core.geometry import se2_to_matrix
    from benchbot_sim_taichi.backend import R_BODY_OPTICAL

    scene = build_scene(bear_envs["miniroom:1"])
    renderer = Renderer("cpu", seed=7)
    renderer.set_scene(scene)
    camera_on_robot = np.eye(4)
    camera_on_robot[:3, :3], camera_on_robot[:3, 3] = R_BODY_OPTICAL, (0.0, 0.0, 0.8)  # optical frame, 0.8 m up
    return renderer, intrinsics(W, H, 90.0), se2_to_matrix(*scene.trajectory_se2[3]) @ camera_on_robot


def _error(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)))


@pytest.mark.slow  # compiling the path tracer's kernel on the CPU takes most of its 25 s
def test_the_denoised_image_is_closer_to_the_converged_one_than_the_noisy_one(view):
    renderer, K, T = view
    converged = renderer.render(K, T, W, H, mode="quality", spp=64, denoise=False)["rgb"]
    noisy = renderer.render(K, T, W, H, mode="quality", spp=4, denoise=False)["rgb"]
    denoised = renderer.render(K, T, W, H, mode="quality", spp=4)["rgb"]
    assert denoised.shape == (H, W, 3) and denoised.dtype == np.uint8
    assert _error(denoised, converged) < 0.8 * _error(noisy, converged), (_error(denoised, converged),
                                                                         _error(noisy, converged))
    again = renderer.render(K, T, W, H, mode="quality", spp=4)["rgb"]
    assert np.array_equal(again, denoised)  # seeded samples, deterministic denoiser


def test_a_clean_image_stays_as_it_is():
    from benchbot_sim_taichi.renderer import denoise_radiance

    y, x = np.mgrid[0:H, 0:W].astype(np.float32)
    radiance = np.stack([0.2 + 0.5 * x / W, 0.3 + 0.2 * y / H, np.full_like(x, 0.4)], axis=-1)
    albedo = np.clip(radiance, 0, 1)
    normal = np.zeros_like(radiance)
    normal[..., 2] = 1.0
    out = denoise_radiance(radiance, albedo, normal)
    error = np.abs(out - radiance)
    assert out.shape == radiance.shape and out.dtype == np.float32
    assert error.mean() < 0.005 and np.percentile(error, 99) < 0.05, (error.mean(), np.percentile(error, 99))
