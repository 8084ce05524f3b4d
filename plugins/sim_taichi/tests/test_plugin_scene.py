"""Hooks, bundled data and scene construction (no Taichi needed)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from benchbot.core.errors import BackendError


def test_plugin_imports_no_taichi():
    code = "import sys, benchbot_sim_taichi.plugin as p; p.benchbot_robots(); assert 'taichi' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


def test_robot_spec(carter_spec):
    from benchbot_sim_taichi import plugin

    from benchbot.core.specs import expand_spec_folders

    assert plugin.benchbot_robots() == [plugin.ROBOTS_DIR]  # the folder: every robot spec in it is registered
    (path,) = expand_spec_folders(plugin.benchbot_robots())
    assert Path(path).is_file() and Path(path).name == "carter.yaml"
    s = carter_spec
    assert s["name"] == "carter" and s["type"] == "sim_taichi"
    assert s["global_frame"] == "map" and s["robot_frame"] == "robot"
    assert s["poses"] == ["camera", "lidar", "robot", "initial_pose"]
    assert set(s["connections"]) == set(s["actions"]) | set(s["observations"])
    for a in s["actions"]:
        assert s["connections"][a] == {"connection": "api_to_ros"}
    for o in s["observations"]:
        assert s["connections"][o] == {"connection": "ros_to_api"}
    cam = s["sensors"]["camera"]
    assert (cam["width"], cam["height"]) == (640, 480)
    assert 0.25 <= s["sensors"]["footprint_radius_m"] <= 0.3
    backends = plugin.benchbot_robot_backends()
    assert set(backends) == {"sim_taichi"} and callable(backends["sim_taichi"])


def test_scene_boxes_equal_ground_truth(bear_envs):
    from benchbot_worlds.scene.build import WALL_MARGIN_M, build_scene

    for key, env in bear_envs.items():
        gt = json.loads(Path(env["map_path"]).read_text())["ground_truth"]
        scene = build_scene(env)
        assert scene.n_boxes == len(gt["objects"])
        for i, o in enumerate(gt["objects"]):
            c, e = np.array(o["centroid"]), np.array(o["extent"])
            np.testing.assert_allclose(scene.box_min[i], c - e / 2, atol=1e-6)
            np.testing.assert_allclose(scene.box_max[i], c + e / 2, atol=1e-6)
            cid = gt["class_list"].index(o["class"])
            assert scene.box_class[i] == cid and scene.box_instance[i] // 1000 == cid
            assert scene.box_instance[i] % 1000 >= 1
        assert len(set(scene.box_instance.tolist())) == scene.n_boxes
        assert scene.background_class == gt["class_list"].index("background")
        # the shell encloses every object and pose with the margin
        assert WALL_MARGIN_M >= 0.4
        lo, hi = scene.room_min[:2] + 0.4 - 1e-5, scene.room_max[:2] - 0.4 + 1e-5
        pts = np.vstack([scene.start_se2[None, :2], scene.trajectory_se2[:, :2]])
        assert np.all(pts >= lo) and np.all(pts <= hi), key
        assert np.all(scene.box_min[:, :2] >= lo) and np.all(scene.box_max[:, :2] <= hi), key
        assert scene.room_min[2] == 0.0 and scene.room_max[2] >= max(2.6, scene.box_max[:, 2].max())


def test_colours_seeded_and_plausible(bear_envs):
    from benchbot_worlds.scene.build import build_scene

    a, b, c = (build_scene(bear_envs["house:1"], seed=s) for s in (0, 0, 1))
    assert np.array_equal(a.box_albedo, b.box_albedo)
    assert not np.array_equal(a.box_albedo, c.box_albedo)
    plants = a.box_albedo[a.box_class == a.class_ids["potted plant"]]
    assert len(plants) and np.all(plants[:, 1] > plants[:, 0]) and np.all(plants[:, 1] > plants[:, 2])


def test_bad_map_path_and_json(tmp_path, synthetic_env):
    from benchbot_worlds.scene.build import build_scene

    env = synthetic_env([])
    missing = dict(env, map_path=str(tmp_path / "nope.json"))
    with pytest.raises(BackendError) as e:
        build_scene(missing)
    assert "nope.json" in e.value.message and e.value.hint
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(BackendError) as e:
        build_scene(dict(env, map_path=str(bad)))
    assert "bad.json" in e.value.message
    bad.write_text(json.dumps({"ground_truth": {"class_list": ["background"], "objects": [{"class": "x"}]}}))
    with pytest.raises(BackendError) as e:
        build_scene(dict(env, map_path=str(bad)))
    assert "bad.json" in e.value.message


def test_lighting_parse():
    from benchbot_worlds.bear import lighting_of_map_path

    assert lighting_of_map_path("/Game/AI_vol3_03_base/Maps/AI_vol3_scene_03") == "base"
    assert lighting_of_map_path("/Game/AIUE_V02_002_night_extra/Maps/AIUE_V02_002") == "night_extra"
    assert lighting_of_map_path("/Game/AIUE_V02_002_day/Maps/AIUE_V02_002") == "day"
    assert lighting_of_map_path("") == "base"


def test_specs_pass_core_schemas():
    from benchbot.core import specs
    from benchbot_worlds import bear
    from benchbot_sim_taichi import plugin

    for e in bear.environment_specs():
        specs.validate(e, "environment", "sim_taichi")
    for g in bear.ground_truth_specs():
        specs.validate(g, "ground_truth", "sim_taichi")
    (path,) = specs.expand_spec_folders(plugin.benchbot_robots())
    specs.validate(specs.load_spec_file(Path(path)), "robot", path)


def test_the_registry_reads_the_robots_folder():
    """``benchbot_robots`` returns ``robots/``: the registry registers each spec file in it (carter), by its path."""
    from benchbot.core.registry import Registry
    from benchbot_sim_taichi import plugin

    entry = Registry().entries["robots"]["carter"]
    assert entry.plugin == "sim_taichi" and entry.path == (plugin.ROBOTS_DIR / "carter.yaml").resolve()
