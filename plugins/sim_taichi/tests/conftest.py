"""Fixtures of the sim_taichi tests (real Taichi on the CPU, small images)."""

from __future__ import annotations

import json
import os

import pytest

os.environ.setdefault("BENCHBOT_TAICHI_ARCH", "cpu")

CLASS_LIST = ["chair", "table", "background"]


@pytest.fixture(autouse=True)
def taichi_on_a_live_thread():
    """Taichi builds fields only on the thread that initialised it: when an earlier test of the run initialised it on
    the process's backend thread (a served episode of tests/), reset it so that this test's renders initialise it
    here, on the main thread. (The tests of this folder use Taichi on the main thread only.)"""
    import sys

    renderer = sys.modules.get("benchbot_sim_taichi.render.renderer")
    if renderer is not None and renderer.initialised_on_another_thread():
        renderer.release_taichi()
    yield


@pytest.fixture(scope="session")
def bear_envs():
    """The plugin's ten environment specs, keyed 'name:variant'."""
    from benchbot_worlds import bear
    from benchbot_sim_taichi import plugin

    return {f"{e['name']}:{e['variant']}": e for e in bear.environment_specs()}


@pytest.fixture(scope="session")
def carter_spec():
    """The carter robot spec (YAML)."""
    import yaml

    from benchbot_worlds import bear
    from benchbot_sim_taichi import plugin

    with open(plugin.ROBOTS_DIR / "carter.yaml", encoding="utf-8") as f:
        return yaml.safe_load(f)


@pytest.fixture
def make_backend(carter_spec):
    """make_backend(width=64, height=48, **options) → TaichiSimBackend."""
    from benchbot_sim_taichi.backend import TaichiSimBackend

    def make(width=64, height=48, **options):
        return TaichiSimBackend(carter_spec, {"arch": "cpu", "width": width, "height": height, **options})

    return make


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
        return {"name": name, "variant": 1, "type": "sim_taichi", "map_path": str(path),
                "start_pose": list(start_pose), "trajectory_poses": [list(p) for p in trajectory],
                "object_labels": CLASS_LIST[:-1], "lighting": lighting}

    return make
