"""sim_taichi against the core's contract checks (benchbot.plugins.testing): content and the robot backend."""

from __future__ import annotations

from benchbot.plugins import testing


def test_plugin_content_contract():
    from benchbot_sim_taichi import plugin

    from benchbot_worlds import plugin as worlds

    registers = testing.check_content_plugin(plugin)
    assert registers["robot_backends"] == ["sim_taichi"] and registers["robots"] == ["carter"]
    assert "miniroom:1" in testing.check_content_plugin(worlds)["environments"]


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


def test_observation_differences_are_located_through_dicts_and_lists():
    import numpy as np

    same = {"a": [np.zeros(2), {"b": 1.0}], "c": "x"}
    assert testing._first_difference(same, {"a": [np.zeros(2), {"b": 1.0}], "c": "x"}) is None
    assert testing._first_difference(same, {"a": [np.ones(2), {"b": 1.0}], "c": "x"}) == "['a'][0]"
    assert testing._first_difference(same, {"a": [np.zeros(2), {"b": 2.0}], "c": "x"}) == "['a'][1]['b']"
    assert testing._first_difference(same, {"a": [np.zeros(2)], "c": "x"}) == "['a'] (lengths 2 and 1)"
    assert testing._first_difference(same, {"a": []}) == "the top level (keys ['c'])"
