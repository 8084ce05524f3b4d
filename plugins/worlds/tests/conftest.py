"""Fixtures of the benchbot_worlds tests (no simulator: scenes, plans and furnished homes as NumPy data)."""

from __future__ import annotations

import json

import pytest

CLASS_LIST = ["chair", "table", "background"]


@pytest.fixture(scope="session")
def bear_envs():
    """The plugin's ten environment specs, keyed 'name:variant'."""
    from benchbot_worlds import bear

    return {f"{e['name']}:{e['variant']}": e for e in bear.environment_specs()}


@pytest.fixture(scope="session")
def furnished_bear_scenes(bear_envs) -> dict:
    """{(home, variant): furnished Scene} of the ten BEAR environments, each built with the world seed an episode run
    with ``--seed 0`` gives it (benchbot.core.seeding.environment_world_seed). Built once for the session: the tests
    of one home (test_one_home) and of furnished homes (test_furnished) read the same scenes (ten furnished builds
    took seconds in each)."""
    from benchbot.core.seeding import environment_world_seed
    from benchbot_worlds.scene.build import build_scene

    out = {}
    for key, env in bear_envs.items():
        name, v = key.split(":")
        out[name, int(v)] = build_scene({**env, "style": "furnished"}, seed=environment_world_seed(0, env))
    return out


@pytest.fixture
def synthetic_env(tmp_path):
    """synthetic_env(objects, start=(x, y, yaw_quat_wxyz...), trajectory=[]) → environment spec whose map_path is a
    BEAR-style JSON in tmp_path. objects: list of (class, centroid, extent)."""

    def make(objects, start_pose=(1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0), trajectory=(), lighting="base", name="synth"):
        data = {
            "environment": {"name": name, "variant": 1, "map_path": f"/Game/X_{lighting}/Maps/X",
                            "start_pose": list(start_pose), "trajectory_poses": [list(p) for p in trajectory]},
            "format": {"name": "object_map_ground_truth"},
            "ground_truth": {
                "class_list": CLASS_LIST,
                "objects": [{"class": c, "ID_name": f"{c}_{i}", "centroid": list(ce), "extent": list(ex),
                             "isgroup": False} for i, (c, ce, ex) in enumerate(objects)],
            },
        }
        path = tmp_path / f"{name}.json"
        path.write_text(json.dumps(data))
        return {"name": name, "variant": 1, "type": "world", "map_path": str(path),
                "start_pose": list(start_pose), "trajectory_poses": [list(p) for p in trajectory],
                "object_labels": CLASS_LIST[:-1], "lighting": lighting}

    return make
