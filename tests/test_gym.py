"""benchbot.gym: a gymnasium.Env over the backend, in-process and over HTTP; registered ids, Gymnasium's checker, the
terminated/truncated contract and a vector environment (docs/gym.md)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")
from gymnasium.utils.env_checker import check_env  # noqa: E402

from benchbot.core.errors import SpecError  # noqa: E402
from benchbot.gym import BenchBotEnv  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SMALL = {"width": 64, "height": 48}


def test_active_env_passes_the_checker_in_process(make_service):
    env = BenchBotEnv(backend=make_service("semantic_slam:active:ground_truth", "miniroom:1"), max_steps=3)
    assert env.action_space.n == 4
    check_env(env, skip_render_check=True)
    obs, info = env.reset(seed=1)
    assert obs["image_rgb"].shape == (48, 64, 3) and obs["pose"].shape == (3,) and info["scene_number"] == 0
    truncated = terminated = False
    steps = 0
    while not (terminated or truncated):
        obs, reward, terminated, truncated, info = env.step(2)  # turn left: never collides
        steps += 1
    assert truncated and steps == 3 and reward == 0.0
    env.close()


def test_passive_env_over_http_terminates_when_finished(served):
    _, server = served("semantic_slam:passive:ground_truth", "miniroom:4")
    env = BenchBotEnv(address=server.address, max_steps=1000)
    assert env.action_space.n == 1
    obs, _ = env.reset()
    steps, terminated = 0, False
    while not terminated:
        obs, _, terminated, truncated, info = env.step(0)
        steps += 1
    assert steps == 33 and info["result"] == "FINISHED" and env.observation_space.contains(obs)
    obs, _ = env.reset()
    assert np.all(obs["laser"] >= 0)
    env.close()


def test_gym_make_builds_an_in_process_simulator_and_passes_the_checker():
    """``import benchbot`` (after gymnasium) registers the ids; ``gym.make`` takes task, env, robot, seed, options;
    the built environment passes Gymnasium's checker, render included, and owns its simulator."""
    import benchbot  # noqa: F401

    assert {"BenchBot-v0", "BenchBotRemote-v0"} <= set(gymnasium.registry)
    env = gymnasium.make("BenchBot-v0", task="semantic_slam:passive:ground_truth", env="miniroom:4", robot="carter",
                         options=SMALL, render_mode="rgb_array", max_steps=5)
    inner = env.unwrapped
    assert isinstance(inner, BenchBotEnv) and inner.action_space.n == 1 and inner._owned is not None
    assert inner.bot.config["environments"][0]["name"] == "miniroom"
    check_env(inner)
    obs, _ = env.reset(seed=2)
    assert env.observation_space.contains(obs) and env.render().shape == (48, 64, 3)
    owned = inner._owned
    env.close()
    assert owned._closed


def test_reset_seed_reseeds_the_simulator():
    env = BenchBotEnv(task="semantic_slam:active:ground_truth", env="miniroom:1", options=SMALL)
    first, _ = env.reset(seed=5)
    again, _ = env.reset(seed=5)
    other, _ = env.reset(seed=6)
    kept, _ = env.reset()  # no seed: the simulator keeps seed 6
    assert np.array_equal(first["image_rgb"], again["image_rgb"])
    assert not np.array_equal(first["image_rgb"], other["image_rgb"])  # object colours vary with the seed
    assert np.array_equal(first["image_depth"], other["image_depth"])  # geometry does not
    assert np.array_equal(kept["image_rgb"], other["image_rgb"])
    env.close()


def test_a_collision_terminates_and_stepping_on_warns_instead_of_raising():
    env = BenchBotEnv(task="semantic_slam:active:ground_truth", env="miniroom:1", options=SMALL, step_m=1.0,
                      max_steps=100)
    env.reset()
    terminated, steps, info = False, 0, {}
    while not terminated:  # straight ahead until a wall or an object stops the robot
        obs, reward, terminated, truncated, info = env.step(0)
        steps += 1
        assert steps < 20 and not truncated
    assert info["result"] == "COLLISION"
    with pytest.warns(UserWarning, match="after terminated=True"):
        again, reward, terminated, truncated, info_again = env.step(2)
    assert terminated and not truncated and reward == 0.0
    assert info_again["result"] == "COLLISION" and info_again["after_terminal"]
    assert all(np.array_equal(again[k], obs[k]) for k in obs)
    obs, info = env.reset()
    obs, _, terminated, _, info = env.step(2)  # usable again after a reset
    assert not terminated and info["result"] == "SUCCESS"
    env.close()


def test_bad_arguments_are_one_line_errors(make_service):
    with pytest.raises(ValueError, match="not both"):
        BenchBotEnv(backend=make_service("semantic_slam:active:ground_truth", "miniroom:1"), task="semantic_slam:active:ground_truth")
    with pytest.raises(ValueError, match="in-process simulator"):
        BenchBotEnv(address="http://127.0.0.1:1/", seed=3)
    with pytest.raises(ValueError, match="render_mode"):
        BenchBotEnv(task="semantic_slam:active:ground_truth", render_mode="human")
    with pytest.raises(ValueError, match="max_steps"):
        BenchBotEnv(task="semantic_slam:active:ground_truth", max_steps=0)
    with pytest.raises(SpecError) as e:
        gymnasium.make("BenchBot-v0", env="miniroom:9", options=SMALL)
    assert "miniroom:9" in e.value.message and "\n" not in e.value.message
    env = BenchBotEnv(task="semantic_slam:active:ground_truth", options=SMALL)
    with pytest.raises(ValueError, match="not in Discrete"):
        env.step(7)
    env.close()


@pytest.mark.slow
def test_the_vector_env_example_runs(tmp_path):
    """examples/gym_vector_env.py (docs/gym.md): two robots stepped together by gym.make_vec, batched and as two
    simulators, run as a user would."""
    for mode in ("batched", "sync"):
        proc = subprocess.run([sys.executable, str(ROOT / "examples" / "gym_vector_env.py"), "--num-envs", "2",
                               "--steps", "3", "--width", "32", "--height", "24", "--mode", mode],
                              capture_output=True, text=True, timeout=600, cwd=tmp_path)
        assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
        assert f"2 environments ({mode}), 3 steps" in proc.stdout, proc.stdout
        assert "image_rgb (2, 24, 32, 3)" in proc.stdout, proc.stdout
