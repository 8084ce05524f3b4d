"""The BEAR environments and ground truths of benchbot_worlds (data/bear/, credited in data/bear/ATTRIBUTION.md):
their specs as registered, and a hook module that imports no simulator."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path


def test_plugin_imports_no_simulator_and_no_mesh_library():
    code = ("import sys, benchbot_worlds.plugin as p; p.benchbot_environments(); p.benchbot_ground_truths(); "
            "assert not {'taichi', 'trimesh', 'benchbot_sim_taichi'} & set(sys.modules)")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_environment_specs(bear_envs):
    from benchbot_worlds import plugin

    envs = plugin.benchbot_environments()
    assert len(envs) == 10
    assert sorted(bear_envs) == sorted(f"{n}:{v}" for n in ("miniroom", "house") for v in range(1, 6))
    lights = {"1": "base", "2": "day", "3": "night", "4": "day_extra", "5": "night_extra"}
    for key, e in bear_envs.items():
        assert e["type"] == "world" and e["robots"] == ["carter"]
        assert Path(e["map_path"]).is_absolute() and Path(e["map_path"]).is_file()
        assert len(e["start_pose"]) == 7 and all(len(p) == 7 for p in e["trajectory_poses"])
        assert len(e["trajectory_poses"]) > 0 and len(e["object_labels"]) == 30
        assert e["lighting"] == lights[key.split(":")[1]]
        assert "arXiv" in e["source"] and e["description"]
    attribution = Path(envs[0]["map_path"]).parent / "ATTRIBUTION.md"
    assert "ground_truths_isaac_develop" in attribution.read_text()


def test_ground_truth_specs():
    from benchbot_worlds import bear
    from benchbot_worlds import plugin

    gts = plugin.benchbot_ground_truths()
    assert len(gts) == 10
    assert sum(len(g["ground_truth"]["objects"]) for g in gts) == 369
    for g in gts:
        assert set(g) == {"environment", "format", "ground_truth"}
        assert "_file_path" not in g["environment"]
        assert g["ground_truth"]["class_list"][-1] == "background"
    # the cached originals are not mutated
    assert "_file_path" in bear._load("miniroom_1.json")["environment"]
