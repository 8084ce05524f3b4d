"""The camera model (camera_model.py): the default is the renderer's image as it always was; exposure, the filmic
tone curve and vignetting in the fast kernel agree with the NumPy model; the robot spec's camera fields reach the
renderer."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from benchbot_sim_taichi.render.camera_model import CameraModel, aces_filmic, tone_table

W, H = 64, 48


def test_the_default_table_is_the_renderers_old_gamma_table():
    s = np.linspace(0.0, 1.0, 4096)
    assert np.array_equal(tone_table(CameraModel()), np.floor(np.power(s * s, 1.0 / 2.2) * 255.0 + 0.5))
    assert CameraModel().radiance_max == 1.0 and list(CameraModel().frame_constants()) == [1.0, 0.0]


def test_numpy_model():
    K = np.array([[32.0, 0, 31.5], [0, 32.0, 23.5], [0, 0, 1]])
    lin = np.full((H, W, 3), 0.25)
    assert np.all(CameraModel().encode(lin, K) == round(255 * 0.25 ** (1 / 2.2)))
    assert np.all(CameraModel(exposure_ev=2).encode(lin, K) == 255)  # 4 × 0.25 = 1: white, clipped
    filmic = CameraModel(tone_curve="filmic").encode(np.full((H, W, 3), 4.0), K)
    assert np.all(filmic < 255) and np.all(filmic > 240)  # a highlight rolls off instead of clipping
    assert aces_filmic(np.array([0.0]))[0] == 0.0 and np.all(np.diff(aces_filmic(np.linspace(0, 16, 100))) >= 0)
    vignetted = CameraModel(vignetting=1.0).encode(lin, K)
    assert vignetted[H // 2, W // 2, 0] >= vignetted[0, 0, 0] + 20  # the corners darker (cos^4 of ~48°)
    with pytest.raises(ValueError, match="tone_curve"):
        CameraModel(tone_curve="linear")


@pytest.fixture(scope="module")
def default_and_scene(bear_envs):
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene
    from benchbot.core.geometry import se2_to_matrix
    from benchbot_sim_taichi.backend import R_BODY_OPTICAL

    scene = build_scene(bear_envs["miniroom:1"])
    mount = np.eye(4)
    mount[:3, :3], mount[:3, 3] = R_BODY_OPTICAL, (0.0, 0.0, 0.8)
    K, T = intrinsics(W, H, 90.0), se2_to_matrix(*scene.trajectory_se2[2]) @ mount
    r = Renderer("cpu")
    r.set_scene(scene)
    return r, K, T, r.render(K, T, W, H)["rgb"]


@pytest.mark.parametrize("camera", [CameraModel(exposure_ev=1.0), CameraModel(exposure_ev=-0.5, tone_curve="filmic"),
                                    CameraModel(vignetting=0.8), CameraModel(0.7, "filmic", 0.5)],
                         ids=["ev+1", "filmic-0.5", "vignetting", "all"])
def test_the_kernel_applies_the_model_as_numpy_does(default_and_scene, camera):
    r, K, T, default = default_and_scene
    r.camera = camera
    try:
        got = r.render(K, T, W, H)["rgb"].astype(int)
    finally:
        r.camera = CameraModel()
    lit = (default > 8) & (default < 250)  # the default image's radiance is known there to within its 8-bit step
    expected = camera.encode((default / 255.0) ** 2.2, K).astype(int)
    err = np.abs(got - expected)[lit]
    assert lit.sum() > 1000 and np.percentile(err, 99) <= 3 and err.max() <= 6, (np.percentile(err, 99), err.max())
    assert not np.array_equal(got, default)


def test_the_robot_specs_camera_fields_reach_the_renderer(carter_spec):
    from benchbot_sim_taichi.backend import TaichiSimBackend

    spec = copy.deepcopy(carter_spec)
    spec.setdefault("sensors", {}).setdefault("camera", {}).update(
        {"exposure_ev": 0.5, "tone_curve": "filmic", "vignetting": 0.3, "auto_exposure": False})
    backend = TaichiSimBackend(spec, {"arch": "cpu", "width": W, "height": H})
    try:
        backend.load_scene({"name": "miniroom", "variant": 1, **_env_file("miniroom_1.json")})
        assert backend._renderer.camera == CameraModel(0.5, "filmic", 0.3, auto_exposure=False)
    finally:
        backend.close()


def _env_file(name: str) -> dict:
    from benchbot_worlds import bear

    env = next(e for e in bear.environment_specs() if e["map_path"].endswith(name))
    return {k: v for k, v in env.items() if k not in ("name", "variant")}


def test_auto_exposure_meters_the_log_average_luminance_to_the_key():
    """Reinhard et al. 2002's meter: a uniform grey radiance L gets the gain 0.18 / (1e-4 + L), clamped to ±8 stops;
    a camera without auto-exposure keeps 1; encoding meters the image itself, and exposure_ev still biases it."""
    from benchbot_sim_taichi.render.camera_model import METER_DELTA, METER_KEY

    auto = CameraModel(tone_curve="filmic", auto_exposure=True)
    for level in (0.01, 0.18, 3.0):
        grey = np.full((48, 64, 3), level, np.float32)
        assert auto.metered_gain(auto.meter_sample(grey)) == pytest.approx(METER_KEY / (METER_DELTA + level))
        assert CameraModel().metered_gain(auto.meter_sample(grey)) == 1.0
    assert auto.metered_gain(np.zeros((6, 8, 3))) == 2.0 ** 8  # a black frame: the longest exposure, not infinity
    assert auto.meter_sample(np.zeros((48, 64, 3))).shape == (*auto.meter_shape(48, 64), 3) == (6, 8, 3)
    assert auto.meter_shape(4, 640) == (0, 80)  # too small to meter: the gain stays 1
    K = np.array([[32.0, 0, 31.5], [0, 32.0, 23.5], [0, 0, 1]])
    dim, bright = np.full((48, 64, 3), 0.02), np.full((48, 64, 3), 2.0)
    assert np.array_equal(auto.encode(dim, K), auto.encode(bright, K))  # metered to the same key
    assert not np.array_equal(CameraModel(tone_curve="filmic").encode(dim, K), auto.encode(dim, K))
    brighter = CameraModel(exposure_ev=1.0, tone_curve="filmic", auto_exposure=True).encode(dim, K)
    assert brighter.mean() > auto.encode(dim, K).mean()
    assert np.array_equal(auto.encode(dim, K, gain=1.0), CameraModel(tone_curve="filmic").encode(dim, K))


@pytest.mark.slow
def test_quality_mode_frames_of_a_dim_and_a_bright_room_are_exposed_alike(bear_envs):
    """Quality mode's light is physical: a furnished room in its base light (miniroom:1: the sun through its windows
    and its lamps) and one under its brightest lamps at night (miniroom:5, ``night_extra``) differ severalfold in
    radiance, and a fixed exposure draws the second far brighter. The robot's default camera meters each frame, so
    both come out with mid-tones. (The room lit by day alone, miniroom:2, was the dim one until its windows lit it:
    docs/realism.md, *What paid*.)"""
    from benchbot.core.geometry import se2_to_matrix
    from benchbot_sim_taichi.backend import camera_model, camera_mount
    from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
    from benchbot_worlds.scene.build import build_scene

    camera = camera_model()
    assert camera.auto_exposure
    fixed_camera = CameraModel(camera.exposure_ev, camera.tone_curve, camera.vignetting)
    K = intrinsics(80, 60, 90.0)
    radiance, metered, fixed = {}, {}, {}
    for env in ("miniroom:1", "miniroom:5"):
        scene = build_scene({**bear_envs[env], "style": "furnished"})
        r = Renderer("cpu", camera=camera)
        r.set_scene(scene)
        out = r.render(K, se2_to_matrix(*scene.trajectory_se2[8]) @ camera_mount(), 80, 60, mode="quality", spp=2)
        radiance[scene.lighting] = float(out["radiance"].mean())
        metered[scene.lighting] = out["rgb"].astype(float).mean()
        fixed[scene.lighting] = fixed_camera.encode(out["radiance"], K).astype(float).mean()
    assert radiance["night_extra"] > 2.0 * radiance["base"], radiance
    assert fixed["night_extra"] - fixed["base"] > 40.0, fixed
    assert all(70.0 < v < 190.0 for v in metered.values()) and abs(metered["base"] - metered["night_extra"]) < 25.0, \
        metered
