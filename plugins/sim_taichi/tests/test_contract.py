"""sim_taichi against the core's contract checks (benchbot.plugins.testing): content and the robot backend."""

from __future__ import annotations

from benchbot.plugins import testing


def test_plugin_content_contract():
    from benchbot_sim_taichi import plugin

    registers = testing.check_content_plugin(plugin)
    assert registers["robot_backends"] == ["sim_taichi"] and "miniroom:1" in registers["environments"]


def test_robot_backend_contract(carter_spec, bear_envs):
    from benchbot_sim_taichi import plugin

    obs = testing.check_robot_backend(plugin.benchbot_robot_backends()["sim_taichi"], carter_spec, bear_envs["miniroom:1"])
    assert obs["image_rgb"].shape == (48, 64, 3)


def test_robot_backend_contract_catches_borrowed_observations_that_differ(carter_spec, bear_envs):
    import numpy as np
    import pytest

    from benchbot_sim_taichi import plugin

    def factory(robot_spec, options):
        backend = plugin.benchbot_robot_backends()["sim_taichi"](robot_spec, options)
        real = backend.observe_borrowed

        def stale(names):  # a backend lending a buffer it has already overwritten
            obs = real(names)
            obs["image_depth"] = np.zeros_like(obs["image_depth"])
            return obs

        backend.observe_borrowed = stale
        return backend

    with pytest.raises(AssertionError, match=r"observe_borrowed\(\) differs from observe\(\) at \['image_depth'\]"):
        testing.check_robot_backend(factory, carter_spec, bear_envs["miniroom:1"])
