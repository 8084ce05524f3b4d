"""Noise presets and models (benchbot.core.noise, docs/noise.md): seeded, zero-mean where documented, with the
stated variance. Statistical checks draw 10⁵-10⁶ samples and allow 5 standard errors (a mean) or 5 standard errors
of the sample variance (≈ √(2/n) relative), so they hold whatever the seed; the seeds are fixed all the same."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchbot.core import noise
from benchbot.core.errors import UsageError
from benchbot.core.geometry import pose7_to_se2

N = 1_000_000


def rng(seed=0):
    return np.random.default_rng(seed)


def assert_mean(x, expected, sd):
    se = sd / math.sqrt(len(x))
    assert abs(float(np.mean(x)) - expected) < 5 * se, (float(np.mean(x)), expected, se)


def assert_var(x, expected):
    rel = 5 * math.sqrt(2.0 / (len(x) - 1))
    assert abs(float(np.var(x, ddof=1)) / expected - 1.0) < rel, (float(np.var(x, ddof=1)), expected)


# ------------------------------------------------------------------------------------------------------ presets
def test_presets_none_is_silent_and_the_others_grow():
    none = noise.get_preset("none")
    assert none["rgb"] is None and none["odometry"] is None and none["laser"]["sigma_m"] == 0
    assert all(v == 0 for v in none["actuation"].values())
    assert float(noise.depth_sigma(3.0, none["depth"])) == 0.0
    assert float(noise.depth_dropout_probability(3.0, none["depth"])) == 0.0
    names = noise.preset_names()
    assert names == ["none", "low", "realistic", "high"]
    p = [noise.get_preset(n) for n in names[1:]]

    def grows(values):
        return all(a < b for a, b in zip(values, values[1:]))

    assert grows([float(noise.depth_sigma(2.0, q["depth"])) for q in p])
    assert grows([float(noise.depth_dropout_probability(2.0, q["depth"])) for q in p])
    assert grows([-q["rgb"]["full_well_e"] for q in p]) and grows([q["rgb"]["read_noise_e"] for q in p])
    assert grows([q["laser"]["sigma_m"] for q in p])
    for k in ("alpha1", "alpha2", "alpha3", "alpha4"):
        assert grows([q["actuation"][k] for q in p])
    assert grows([q["odometry"]["sigma_linear"] for q in p])


def test_realistic_depth_follows_the_kinect_model():
    """Khoshelham & Elberink 2012: about 4 cm of random error at the Kinect's 5 m maximum range."""
    d = noise.get_preset("realistic")["depth"]
    assert float(noise.depth_sigma(5.0, d)) == pytest.approx(1.425e-3 * 25)
    assert 0.03 < float(noise.depth_sigma(5.0, d)) < 0.045


def test_unknown_preset_is_one_line_naming_the_flag():
    with pytest.raises(UsageError) as e:
        noise.get_preset("loud", flag="--noise")
    assert e.value.message == "--noise 'loud' is not a noise preset" and "realistic" in e.value.hint
    assert "\n" not in e.value.message + e.value.hint


def test_get_preset_is_a_copy():
    noise.get_preset("low")["laser"]["sigma_m"] = 99
    assert noise.get_preset("low")["laser"]["sigma_m"] == 0.005


# ------------------------------------------------------------------------------------------------------ depth
@pytest.mark.parametrize("z", [1.0, 2.0, 3.0])
def test_depth_noise_is_zero_mean_with_sigma_growing_as_z_squared(z):
    d = noise.get_preset("realistic")["depth"]
    out = noise.add_depth_noise(np.full((1000, 1000), z, np.float32), d, rng(1)).astype(np.float64)
    kept = out[out > 0] - np.float32(z)
    sigma = d["k_per_m"] * z * z
    assert_mean(kept, 0.0, sigma)
    assert_var(kept, sigma ** 2)
    p = d["dropout_p0"]
    assert abs((out == 0).mean() - p) < 5 * math.sqrt(p * (1 - p) / N)


def test_depth_dropout_depends_on_range():
    d = noise.get_preset("realistic")["depth"]  # z_min 0.5, p0 0.01, fading 4 → 5 m
    z = np.array([0.3, 0.49, 0.5, 2.0, 4.0, 4.5, 5.0, 7.0])
    np.testing.assert_allclose(noise.depth_dropout_probability(z, d), [1, 1, 0.01, 0.01, 0.01, 0.505, 1, 1])
    out = noise.add_depth_noise(np.full((1000, 1000), 4.5, np.float32), d, rng(2))
    assert abs((out == 0).mean() - 0.505) < 5 * math.sqrt(0.505 * 0.495 / N)
    for z_all_dropped in (0.3, 6.0):
        assert not noise.add_depth_noise(np.full((10, 10), z_all_dropped, np.float32), d, rng()).any()


def test_depth_without_a_hit_stays_zero_and_is_float32():
    d = noise.get_preset("high")["depth"]
    depth = np.zeros((20, 30), np.float32)
    depth[5:10] = 1.5
    out = noise.add_depth_noise(depth, d, rng())
    assert out.dtype == np.float32 and out.shape == depth.shape
    assert not out[depth == 0].any() and (out >= 0).all()


def test_depth_noise_is_seeded():
    d = noise.get_preset("low")["depth"]
    depth = np.linspace(0.1, 9.0, 2000, dtype=np.float32).reshape(40, 50)
    a, b = noise.add_depth_noise(depth, d, rng(7)), noise.add_depth_noise(depth, d, rng(7))
    assert np.array_equal(a, b)
    assert not np.array_equal(a, noise.add_depth_noise(depth, d, rng(8)))


# ------------------------------------------------------------------------------------------------------ RGB
@pytest.mark.parametrize("level", [0.0, 0.002, 0.02, 0.2, 0.8])  # 0, 10, 100, 1000, 4000 electrons
def test_photon_noise_is_zero_mean_with_poisson_gaussian_variance(level):
    p = noise.get_preset("realistic")["rgb"]
    fw, read = p["full_well_e"], p["read_noise_e"]
    x = noise.photon_noise(np.full(N, level), p, rng(3))
    var = (level * fw + read ** 2) / fw ** 2  # shot noise (signal-dependent) + read noise
    assert_mean(x, level, math.sqrt(var))
    assert_var(x, var)


def test_rgb_noise_keeps_the_mean_level_and_grows_with_the_preset():
    image = np.full((500, 500, 3), 128, np.uint8)
    sds = []
    for name in ("low", "realistic", "high"):
        out = noise.add_rgb_noise(image, noise.get_preset(name)["rgb"], rng(4))
        assert out.dtype == np.uint8 and out.shape == image.shape
        assert abs(out.astype(np.float64).mean() - 128) < 0.1
        sds.append(out.astype(np.float64).std())
    assert sds[0] < sds[1] < sds[2] and sds[1] > 1.0
    assert noise.add_rgb_noise(image, None, rng()) is image


def test_srgb_round_trip():
    levels = np.arange(256, dtype=np.uint8)
    assert np.array_equal(noise.linear_to_srgb8(noise.srgb_to_linear(levels)), levels)


# ------------------------------------------------------------------------------------------------------ laser
def test_laser_noise_is_zero_mean_and_beams_without_return_stay():
    p = noise.get_preset("realistic")["laser"]
    ranges = np.full(N, 3.0)
    ranges[::10] = 20.0  # no return
    out = noise.add_laser_noise(ranges, p, 20.0, rng(5))
    assert np.array_equal(out[::10], ranges[::10])
    err = np.delete(out, np.s_[::10]) - 3.0
    assert_mean(err, 0.0, p["sigma_m"])
    assert_var(err, p["sigma_m"] ** 2)


# ------------------------------------------------------------------------------------------------------ motion
def test_split_and_join_motion_are_inverse():
    for inc in ([0.5, 0.0, 0.0], [0.3, -0.4, 1.0], [0.0, 0.0, -2.0], [-0.2, 0.1, 3.0]):
        np.testing.assert_allclose(noise.join_motion(*noise.split_motion(np.array(inc))), inc, atol=1e-12)


def sample(increment, preset="realistic", n=200_000, seed=6):
    a = noise.get_preset(preset)["actuation"]
    g = rng(seed)
    return a, np.array([noise.sample_actuation(np.array(increment), a, g) for _ in range(n)])


@pytest.mark.slow
def test_actuation_of_a_straight_move_has_the_stated_variances():
    """Commanded (d, 0, 0): δ_rot1 = δ_rot2 = 0, δ_trans = d, so the executed translation is d + N(0, α₃d²) and the
    heading change the sum of two N(0, α₂d²) (Thrun et al. 2005, table 5.6)."""
    d = 0.5
    a, x = sample([d, 0.0, 0.0])
    trans = np.hypot(x[:, 0], x[:, 1])
    assert_mean(trans, d, math.sqrt(a["alpha3"]) * d)
    assert_var(trans, a["alpha3"] * d * d)
    assert_mean(x[:, 2], 0.0, math.sqrt(2 * a["alpha2"]) * d)
    assert_var(x[:, 2], 2 * a["alpha2"] * d * d)


def test_actuation_of_a_turn_on_the_spot_has_the_stated_variances():
    """Commanded (0, 0, θ): δ_trans = 0 and δ_rot2 = θ, so the heading change is θ + N(0, α₁θ²) and the robot slips
    forward by N(0, α₄θ²)."""
    theta = math.pi / 2
    a, x = sample([0.0, 0.0, theta], preset="high")
    assert_mean(x[:, 2], theta, math.sqrt(a["alpha1"]) * theta)
    assert_var(x[:, 2], a["alpha1"] * theta ** 2)
    assert_mean(x[:, 0], 0.0, math.sqrt(a["alpha4"]) * theta)
    assert_var(x[:, 0], a["alpha4"] * theta ** 2)
    assert not x[:, 1].any()


def test_actuation_is_seeded_and_none_is_exact():
    _, a = sample([0.4, 0.1, 0.3], n=50, seed=9)
    _, b = sample([0.4, 0.1, 0.3], n=50, seed=9)
    _, c = sample([0.4, 0.1, 0.3], n=50, seed=10)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    _, exact = sample([0.4, 0.1, 0.3], preset="none", n=3)
    np.testing.assert_allclose(exact, [[0.4, 0.1, 0.3]] * 3, atol=1e-12)


def test_odometry_presets_set_the_zero_mean_sigma():
    from benchbot.core.episode import OdometryNoise

    p = noise.get_preset("realistic")["odometry"]
    odo = OdometryNoise(0, **p)
    x = np.array([odo.apply(np.array([1.0, 0.0, 1.0])) for _ in range(100_000)])
    assert_mean(x[:, 0], 1.0, p["sigma_linear"])
    assert_var(x[:, 0], p["sigma_linear"] ** 2)
    assert_var(x[:, 2], p["sigma_angular"] ** 2)


# ------------------------------------------------------------------------------------------------------ episodes
PASSIVE = "semantic_slam:passive:ground_truth"
DEAD_RECKONING = "semantic_slam:active:dead_reckoning"


def trajectory_poses(make_service, seed, preset, steps=12):
    service = make_service(PASSIVE, "miniroom:1", seed=seed, **({} if preset is None else {"noise": preset}))
    ep = service.episode
    out = []
    for _ in range(steps):
        assert service.call(ep.act, "move_next") == "SUCCESS"
        obs = service.call(ep.observe, ["poses"])
        truth = ep.backend.base_pose()
        # ground-truth localisation: the poses served are where the robot really is, noise or not
        np.testing.assert_allclose(obs["poses"]["robot"]["translation_xyz"][:2], truth[:2], atol=1e-9)
        out.append(truth)
    return np.array(out)


def test_actuation_noise_moves_the_robot_off_the_commanded_poses_by_seed(make_service, registry):
    goals = np.array([pose7_to_se2(p) for p in registry.get("environments", "miniroom:1")["trajectory_poses"][:12]])
    exact = trajectory_poses(make_service, 0, None)
    assert np.array_equal(exact, trajectory_poses(make_service, 0, "none"))  # none: bit-identical to no preset
    a = trajectory_poses(make_service, 0, "realistic")
    assert np.array_equal(a, trajectory_poses(make_service, 0, "realistic"))
    assert not np.array_equal(a, trajectory_poses(make_service, 1, "realistic"))
    # the pose controller stops within ~1 cm of a goal; 5 % of steps of up to 0.6 m (median 0.1 m) and 1.1° per
    # metre move the robot by centimetres
    assert np.hypot(*(exact[:, :2] - goals[:, :2]).T).max() < 0.015
    shift = np.hypot(*(a[:, :2] - exact[:, :2]).T)
    assert 0.005 < shift.mean() < 0.1, shift


def test_presets_set_the_dead_reckoning_odometry_sigma(make_service):
    ep = make_service(DEAD_RECKONING, "miniroom:1", noise="high").episode
    assert (ep.noise.sigma_linear, ep.noise.sigma_angular) == (0.1, 0.1)
    ep = make_service(DEAD_RECKONING, "miniroom:1", noise="low").episode
    assert (ep.noise.sigma_linear, ep.noise.sigma_angular) == (0.02, 0.02)
    ep = make_service(DEAD_RECKONING, "miniroom:1").episode  # none: the task's own (the original's 0.1)
    assert (ep.noise.sigma_linear, ep.noise.sigma_angular) == (0.1, 0.1)


def test_a_backend_without_noise_presets_refuses_one(registry):
    from benchbot.core.episode import Episode
    from benchbot.core.errors import BackendError
    from benchbot_sim_taichi.backend import TaichiSimBackend

    class Plain(TaichiSimBackend):
        noise_presets = False

    robot = registry.get("robots", "carter")
    with pytest.raises(BackendError, match="does not apply noise presets"):
        Episode(registry.get("tasks", PASSIVE), robot, registry.scenes("miniroom:1"),
                Plain(robot, {"width": 32, "height": 24, "arch": "cpu"}), noise="low")
