"""Tests of the task_semslam plugin: task/format specs, create/validate round trips, and every validation error."""

from __future__ import annotations

import copy
import importlib
import json
import math
from pathlib import Path

import pytest
import yaml

from benchbot.core.errors import ResultsError
from benchbot.core.specs import expand_spec_folders
from benchbot_task_semslam import formats, plugin

#: Unmodified ground-truth files of the original's ``ground_truths_isaac_develop`` add-on (tests/data: MANIFEST.json).
ORIGINAL_GT_DIR = (Path(__file__).resolve().parents[3] / "tests" / "data" / "original_addons"
                   / "ground_truths_isaac_develop" / "ground_truths")
OBSERVATIONS = ["image_depth", "image_depth_info", "image_rgb", "image_rgb_info", "laser", "poses"]


def resolve(ref: str):
    module, attr = ref.split(":")
    return getattr(importlib.import_module(module), attr)


# ---------------------------------------------------------------------------------------------------------------------
# specs
# ---------------------------------------------------------------------------------------------------------------------
def test_tasks():
    paths = expand_spec_folders(plugin.benchbot_tasks())
    assert all(isinstance(p, Path) and p.is_file() and ":" not in p.name for p in paths)
    tasks = {t["name"]: t for t in (yaml.safe_load(p.read_text()) for p in paths)}
    assert set(tasks) == {
        f"{k}:{c}" for k in ("semantic_slam", "scd")
        for c in ("passive:ground_truth", "active:ground_truth", "active:dead_reckoning")
    }  # fmt: skip
    for name, t in tasks.items():
        kind, control, loc = name.split(":")
        assert t["type"] == kind
        assert t["observations"] == OBSERVATIONS
        assert t["actions"] == (["move_next"] if control == "passive" else ["move_angle", "move_distance"])
        assert t["localisation"] == ("noisy" if loc == "dead_reckoning" else "ground_truth")
        assert t["results_format"] == ("object_map" if kind == "semantic_slam" else "object_map_with_states")
        assert t["scene_count"] == (1 if kind == "semantic_slam" else 2)
        assert isinstance(t["description"], str) and t["description"]


def test_formats_specs_resolve():
    specs = {f["name"]: f for f in (yaml.safe_load(p.read_text()) for p in expand_spec_folders(plugin.benchbot_formats()))}
    assert set(specs) == {"object_map", "object_map_with_states", "object_map_ground_truth"}
    for spec in specs.values():
        assert spec["description"]
        assert set(spec["functions"]) == {"create", "create_object", "validate"}
        for ref in spec["functions"].values():
            assert callable(resolve(ref))


# ---------------------------------------------------------------------------------------------------------------------
# create / validate round trips
# ---------------------------------------------------------------------------------------------------------------------
def test_object_map_round_trip():
    inst = formats.create_object_map()
    assert inst == {"objects": [], "class_list": list(formats.DEFAULT_CLASS_LIST)}
    assert len(inst["class_list"]) == 31 and inst["class_list"][-1] == "background"
    formats.validate_object_map(inst)
    obj = formats.create_object_map_object()
    assert obj == {"label_probs": [0.0] * 31, "centroid": [0.0] * 3, "extent": [0.0] * 3}
    obj["label_probs"][3] = 0.7
    obj["centroid"] = [1.0, -2, 0.5]
    obj["extent"] = [0.2, 0.3, 0.4]
    inst["objects"].append(obj)
    formats.validate_object_map(json.loads(json.dumps(inst)))
    small = formats.create_object_map(["a", "b"])
    small["objects"].append(formats.create_object_map_object(2))
    formats.validate_object_map(small)


def test_object_map_with_states_round_trip():
    inst = formats.create_object_map_with_states()
    assert inst["state_list"] == ["added", "removed", "unchanged"]
    obj = formats.create_object_map_with_states_object()
    assert obj["state_probs"] == [0.0] * 3 and len(obj["label_probs"]) == 31
    inst["objects"].append(obj)
    formats.validate_object_map_with_states(inst)
    custom = formats.create_object_map_with_states(["x"], ["changed", "same"])
    custom["objects"].append(formats.create_object_map_with_states_object(1, 2))
    formats.validate_object_map_with_states(custom)


def test_defaults_are_fresh_copies():
    a = formats.create_object_map()
    a["class_list"].append("zzz")
    assert formats.create_object_map()["class_list"][-1] == "background"


def test_ground_truth_round_trip():
    inst = formats.create_object_map_ground_truth(synonyms={"sofa": "couch"})
    inst["objects"].append(formats.create_object_map_ground_truth_object("chair", "chair_1"))
    inst["objects"].append(formats.create_object_map_ground_truth_object("sofa"))
    formats.validate_object_map_ground_truth(inst)


@pytest.mark.parametrize("path", sorted(ORIGINAL_GT_DIR.glob("*.json")), ids=lambda p: p.stem)
def test_the_original_ground_truth_files_validate(path):
    formats.validate_object_map_ground_truth(json.loads(path.read_text())["ground_truth"])


def test_every_registered_bear_ground_truth_validates():
    from benchbot.core.registry import get_registry

    registry = get_registry()
    names = registry.names("ground_truths")
    assert len(names) >= 10  # miniroom:1..5, house:1..5 (sim_taichi, from BEAR's layouts)
    for name in names:
        formats.validate_object_map_ground_truth(registry.ground_truth(name)["ground_truth"])


def test_numbers_may_be_ints():
    inst = formats.create_object_map(["a", "background"])
    inst["objects"].append({"label_probs": [1, 0], "centroid": [0, 1, 2], "extent": [1, 1, 1]})
    formats.validate_object_map(inst)


# ---------------------------------------------------------------------------------------------------------------------
# validation errors
# ---------------------------------------------------------------------------------------------------------------------
def _valid_map(n_objects: int = 5, states: bool = False) -> dict:
    inst = formats.create_object_map_with_states() if states else formats.create_object_map()
    for _ in range(n_objects):
        o = formats.create_object_map_with_states_object() if states else formats.create_object_map_object()
        o["extent"] = [0.1, 0.2, 0.3]
        inst["objects"].append(o)
    return inst


def _set(path, value):
    def mutate(inst):
        target = inst
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] = value

    return mutate


def _delete(path):
    def mutate(inst):
        target = inst
        for key in path[:-1]:
            target = target[key]
        del target[path[-1]]

    return mutate


OBJECT_MAP_ERRORS = [
    (_delete(["objects"]), "objects: missing"),
    (_set(["objects"], {"a": 1}), "objects: expected a list, got dict"),
    (_set(["objects"], "nope"), "objects: expected a list, got str"),
    (_set(["objects", 1], [1, 2]), "objects[1]: expected an object (dict), got list"),
    (_delete(["class_list"]), "class_list: missing"),
    (_set(["class_list"], []), "class_list: expected a non-empty list of strings, got an empty list"),
    (_set(["class_list"], "cup"), "class_list: expected a non-empty list of strings, got str"),
    (_set(["class_list", 4], 7), "class_list[4]: expected a string, got 7"),
    (_delete(["objects", 2, "label_probs"]), "objects[2].label_probs: missing"),
    (_set(["objects", 2, "label_probs"], [0.0] * 30), "objects[2].label_probs: expected 31 probabilities"),
    (_set(["objects", 2, "label_probs"], 0.5), "objects[2].label_probs: expected a list of 31 probabilities"),
    (_set(["objects", 0, "label_probs", 5], "x"), "objects[0].label_probs[5]: expected a number, got 'x'"),
    (_set(["objects", 0, "label_probs", 5], True), "objects[0].label_probs[5]: expected a number, got True"),
    (_set(["objects", 0, "label_probs", 5], None), "objects[0].label_probs[5]: expected a number, got None"),
    (_set(["objects", 0, "label_probs", 5], math.nan), "objects[0].label_probs[5]: expected a finite number"),
    (_set(["objects", 0, "label_probs", 5], -0.5), "objects[0].label_probs[5]: expected a number >= 0"),
    (_delete(["objects", 3, "centroid"]), "objects[3].centroid: missing"),
    (_delete(["objects", 3, "extent"]), "objects[3].extent: missing"),
    (_set(["objects", 3, "centroid"], [1.0, 2.0]), "objects[3].centroid: expected 3 numbers, got 2"),
    (_set(["objects", 3, "extent"], [1.0, 2.0]), "objects[3].extent: expected 3 numbers, got 2"),
    (_set(["objects", 3, "extent"], {"x": 1}), "objects[3].extent: expected a list of 3 numbers, got dict"),
    (_set(["objects", 3, "centroid", 2], math.inf), "objects[3].centroid[2]: expected a finite number, got inf"),
    (_set(["objects", 3, "extent", 1], -0.1), "objects[3].extent[1]: expected a number >= 0, got -0.1"),
]


@pytest.mark.parametrize("mutate, message", OBJECT_MAP_ERRORS)
@pytest.mark.parametrize("states", [False, True], ids=["object_map", "object_map_with_states"])
def test_object_map_errors(mutate, message, states):
    inst = _valid_map(states=states)
    mutate(inst)
    validate = formats.validate_object_map_with_states if states else formats.validate_object_map
    with pytest.raises(ResultsError) as info:
        validate(inst)
    assert info.value.message.startswith(message), info.value.message
    assert info.value.hint


def test_instance_must_be_a_dict():
    with pytest.raises(ResultsError, match="JSON object"):
        formats.validate_object_map([])


STATE_ERRORS = [
    (_delete(["state_list"]), "state_list: missing"),
    (_set(["state_list"], []), "state_list: expected a non-empty list of strings, got an empty list"),
    (_set(["state_list", 1], 3), "state_list[1]: expected a string, got 3"),
    (_delete(["objects", 4, "state_probs"]), "objects[4].state_probs: missing"),
    (_set(["objects", 4, "state_probs"], [0.1, 0.2]), "objects[4].state_probs: expected 3 probabilities"),
    (_set(["objects", 4, "state_probs", 0], "a"), "objects[4].state_probs[0]: expected a number, got 'a'"),
    (_set(["objects", 4, "state_probs", 0], math.nan), "objects[4].state_probs[0]: expected a finite number"),
]


@pytest.mark.parametrize("mutate, message", STATE_ERRORS)
def test_object_map_with_states_errors(mutate, message):
    inst = _valid_map(states=True)
    mutate(inst)
    with pytest.raises(ResultsError) as info:
        formats.validate_object_map_with_states(inst)
    assert info.value.message.startswith(message), info.value.message


def test_plain_object_map_ignores_states():
    inst = _valid_map(states=True)
    inst["objects"][0]["state_probs"] = "whatever"
    formats.validate_object_map(inst)


def _valid_gt() -> dict:
    inst = formats.create_object_map_ground_truth(synonyms={"sofa": "couch"})
    for cls in ("chair", "book", "sofa"):
        o = formats.create_object_map_ground_truth_object(cls, f"{cls}_0")
        o["extent"] = [0.5, 0.5, 0.5]
        inst["objects"].append(o)
    return inst


GT_ERRORS = [
    (_set(["synonyms"], ["sofa"]), "synonyms: expected an object mapping alias to class name, got list"),
    (_set(["synonyms", "sofa"], 3), "synonyms['sofa']: expected a string mapped to a string, got 3"),
    (_delete(["objects", 1, "class"]), "objects[1].class: missing"),
    (_set(["objects", 1, "class"], 5), "objects[1].class: expected a string, got 5"),
    (_set(["objects", 1, "class"], "unicorn"), "objects[1].class: 'unicorn' is neither in class_list nor a synonym"),
    (_set(["objects", 1, "ID_name"], 12), "objects[1].ID_name: expected a string, got 12"),
    (_set(["objects", 1, "isgroup"], "yes"), "objects[1].isgroup: expected true or false, got 'yes'"),
    (_set(["objects", 2, "extent"], [1, 1]), "objects[2].extent: expected 3 numbers, got 2"),
    (_set(["objects", 2, "centroid", 0], "a"), "objects[2].centroid[0]: expected a number, got 'a'"),
    (_set(["class_list"], []), "class_list: expected a non-empty list of strings, got an empty list"),
    (_set(["objects"], None), "objects: expected a list, got NoneType"),
]


@pytest.mark.parametrize("mutate, message", GT_ERRORS)
def test_ground_truth_errors(mutate, message):
    inst = _valid_gt()
    formats.validate_object_map_ground_truth(copy.deepcopy(inst))
    mutate(inst)
    with pytest.raises(ResultsError) as info:
        formats.validate_object_map_ground_truth(inst)
    assert info.value.message.startswith(message), info.value.message
