"""benchbot.gym: a gymnasium.Env over the backend, in-process and over HTTP."""

from __future__ import annotations

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")
from gymnasium.utils.env_checker import check_env  # noqa: E402

from benchbot.gym import BenchBotEnv  # noqa: E402


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
