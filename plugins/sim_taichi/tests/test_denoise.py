"""Quality mode's denoiser: Intel Open Image Denoise (pyoidn) with the path tracer's albedo and normal guides, on the
real renderer (CPU): it brings a 4-sample image closer to a 64-sample one, is deterministic, and leaves a clean
image as it is. The module ``denoiser`` (CPU here; CUDA only where a GPU is) gives pyoidn's own result, reuses its
filter across calls, and says in one line why a device it cannot create is missing."""

from __future__ import annotations

import numpy as np
import pytest

W, H = 64, 48


@pytest.fixture(scope="module")
def view(bear_envs):
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene
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
    from benchbot_sim_taichi.render.denoiser import denoise_radiance

    y, x = np.mgrid[0:H, 0:W].astype(np.float32)
    radiance = np.stack([0.2 + 0.5 * x / W, 0.3 + 0.2 * y / H, np.full_like(x, 0.4)], axis=-1)
    albedo = np.clip(radiance, 0, 1)
    normal = np.zeros_like(radiance)
    normal[..., 2] = 1.0
    out = denoise_radiance(radiance, albedo, normal)
    error = np.abs(out - radiance)
    assert out.shape == radiance.shape and out.dtype == np.float32
    assert error.mean() < 0.005 and np.percentile(error, 99) < 0.05, (error.mean(), np.percentile(error, 99))


def _noisy_frame(h: int = H, w: int = W, seed: int = 0):
    rng = np.random.default_rng(seed)
    radiance = rng.random((h, w, 3), dtype=np.float32) * 2.0
    albedo = rng.random((h, w, 3), dtype=np.float32)
    normal = rng.random((h, w, 3), dtype=np.float32) * 2.0 - 1.0
    return radiance, albedo, normal


def test_the_denoiser_module_gives_pyoidns_own_result_on_the_cpu():
    import pyoidn
    from benchbot_sim_taichi.render.denoiser import denoise_radiance

    radiance, albedo, normal = _noisy_frame()
    expected = pyoidn.denoise(radiance, albedo, normal, hdr=True, quality="high")  # the renderer's call before
    out = denoise_radiance(radiance, albedo, normal, device="cpu")
    assert out.shape == (H, W, 3) and out.dtype == np.float32 and out.min() >= 0.0
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-5)


def test_a_cached_denoiser_is_reused_and_rewrites_its_inputs():
    from benchbot_sim_taichi.render.denoiser import cached_denoiser, denoise_radiance

    a, b = _noisy_frame(seed=1), _noisy_frame(seed=2)
    first = denoise_radiance(*a)
    denoiser = cached_denoiser("cpu", H, W, "high")
    other = denoise_radiance(*b)
    again = denoise_radiance(*a)
    assert cached_denoiser("cpu", H, W, "high") is denoiser
    assert np.array_equal(again, first) and not np.array_equal(other, first)
    assert denoise_radiance(*_noisy_frame(24, 32)).shape == (24, 32, 3)  # another size: its own denoiser


def test_a_shared_image_denoiser_reads_and_writes_memory_in_place_and_gives_the_same_image():
    """``denoise_shared`` (the GPU path of quality mode: OIDN reads the path tracer's memory) on the CPU device with
    host memory: the same image as ``denoise_radiance``, with the guides interleaved as the path tracer writes them;
    moved images are followed (the filter is committed again), and a closed filter refuses in one line."""
    from benchbot_sim_taichi.render.denoiser import SharedImageDenoiser, cached_denoiser, denoise_radiance, denoise_shared

    for seed in (3, 4):
        radiance, albedo, normal = _noisy_frame(seed=seed)
        guides = np.ascontiguousarray(np.concatenate([albedo, normal], axis=-1))  # (H, W, 6): albedo, then normal
        output = np.full((H, W, 3), -1.0, np.float32)
        denoise_shared(radiance.ctypes.data, guides.ctypes.data, output.ctypes.data, H, W, device="cpu")
        assert np.array_equal(output, denoise_radiance(radiance, albedo, normal, device="cpu")), seed
    shared = cached_denoiser("cpu", H, W, "high", shared=True)
    assert isinstance(shared, SharedImageDenoiser) and shared is cached_denoiser("cpu", H, W, "high", shared=True)
    closed = SharedImageDenoiser("cpu", H, W)
    closed.close()
    closed.close()  # idempotent
    with pytest.raises(RuntimeError, match="closed"):
        closed(radiance.ctypes.data, guides.ctypes.data, output.ctypes.data)
    with pytest.raises(ValueError, match="quality"):
        SharedImageDenoiser("cpu", H, W, quality="best")


def test_bad_arguments_are_refused():
    from benchbot_sim_taichi.render.denoiser import denoise_radiance

    radiance, albedo, normal = _noisy_frame()
    with pytest.raises(ValueError, match="albedo"):
        denoise_radiance(radiance, albedo[:-1], normal)
    with pytest.raises(ValueError, match="device"):
        denoise_radiance(radiance, albedo, normal, device="metal")
    with pytest.raises(ValueError, match="quality"):
        denoise_radiance(radiance, albedo, normal, quality="best")


def test_a_missing_cuda_device_is_a_one_line_runtime_error():
    import pyoidn
    from benchbot_sim_taichi.render.denoiser import denoise_radiance

    if pyoidn.Device.is_cuda_available(0):
        pytest.skip("this machine has a CUDA GPU that OIDN can use")
    with pytest.raises(RuntimeError) as e:
        denoise_radiance(*_noisy_frame(), device="cuda")
    message = str(e.value)
    assert "'cuda' cannot be created" in message and "\n" not in message, message


def test_a_gpu_denoiser_the_renderer_chose_falls_back_to_the_cpu_once():
    """Rendering on CUDA picks the GPU denoiser; where Open Image Denoise cannot start there, quality mode still
    denoises (on the CPU) and says so once; a device asked for by name is not replaced."""
    import pyoidn
    from benchbot_sim_taichi.render.renderer import Renderer

    if pyoidn.Device.is_cuda_available(0):
        pytest.skip("this machine has a CUDA GPU that OIDN can use")
    radiance, albedo, normal = _noisy_frame(12, 16)
    r = Renderer("cpu")
    r.denoise_device, r._denoise_device_chosen = "cuda", True  # as the renderer chooses when rendering on CUDA
    with pytest.warns(RuntimeWarning, match="denoising on the CPU instead"):
        out = r._denoise(radiance, albedo, normal)
    assert out.shape == radiance.shape and r.denoise_device == "cpu"
    explicit = Renderer("cpu", denoise_device="cuda")
    with pytest.raises(RuntimeError, match="cannot be created"):
        explicit._denoise(radiance, albedo, normal)
