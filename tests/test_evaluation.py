"""benchbot.core.evaluation: results files, archives, required environments and tasks, clear errors."""

from __future__ import annotations

import json
import zipfile

import pytest

from benchbot.core.errors import ResultsError, SpecError, UsageError
from benchbot.core.evaluation import evaluate, load_results


def perfect_results(registry, env: str, task: str = "semantic_slam:passive:ground_truth") -> dict:
    """The ground truth of ``env`` as a results file (one-hot labels)."""
    gt = registry.ground_truth(env)
    class_list = gt["ground_truth"]["class_list"]
    objects = []
    for obj in gt["ground_truth"]["objects"]:
        probs = [0.0] * len(class_list)
        probs[class_list.index(obj["class"])] = 1.0
        objects.append({"label_probs": probs, "centroid": obj["centroid"], "extent": obj["extent"]})
    return {
        "task_details": registry.get("tasks", task),
        "environment_details": [registry.get("environments", env)],
        "results": {"objects": objects, "class_list": class_list},
    }


def write(path, data):
    path.write_text(json.dumps(data))
    return path


def test_perfect_results_score_one(registry, tmp_path):
    path = write(tmp_path / "r.json", perfect_results(registry, "house:1"))
    evaluation = evaluate([path], "omq", registry)
    assert evaluation.per_result[0][1]["scores"]["OMQ"] == 1.0
    assert evaluation.combined["scores"]["OMQ"] == 1.0


def test_zip_archives_and_missing_required_envs_count_zero(registry, tmp_path):
    archive = tmp_path / "batch.zip"
    with zipfile.ZipFile(archive, "w") as z:
        z.writestr("batch_0.json", json.dumps(perfect_results(registry, "miniroom:1")))
        z.writestr("submission.json", "{}")  # skipped, as in the original
    assert [r.source.split(":")[-1] for r in load_results(archive)] == ["batch_0.json"]
    evaluation = evaluate([archive], "omq", registry, required_envs=["miniroom:1", "miniroom:2"])
    assert evaluation.missing == ["miniroom:2"]
    assert evaluation.combined["scores"]["OMQ"] == pytest.approx(0.5)


def test_other_tasks_and_envs_are_skipped(registry, tmp_path):
    path = write(tmp_path / "r.json", perfect_results(registry, "miniroom:1"))
    evaluation = evaluate([path], "omq", registry, required_envs=["house:1"])
    assert evaluation.skipped and evaluation.per_result == []
    with pytest.raises(SpecError, match="no task named"):
        evaluate([path], "omq", registry, required_task="semantic_slam:flying")


def test_malformed_files_name_the_file_and_field(registry, tmp_path):
    broken = tmp_path / "broken.json"
    broken.write_text("{\"task_details\": ")
    with pytest.raises(ResultsError, match="broken.json: not valid JSON"):
        evaluate([broken], "omq", registry)
    data = perfect_results(registry, "miniroom:1")
    data["results"]["objects"][3]["extent"] = [1, 2]
    bad = write(tmp_path / "bad.json", data)
    with pytest.raises(ResultsError) as info:
        evaluate([bad], "omq", registry)
    assert "bad.json" in info.value.message and "objects[3].extent" in info.value.message
    del data["environment_details"]
    with pytest.raises(ResultsError, match=r"\$: 'environment_details' is a required property"):
        evaluate([write(tmp_path / "env.json", data)], "omq", registry)
    with pytest.raises(ResultsError, match="no such results file"):
        evaluate([tmp_path / "nope.json"], "omq", registry)


# ---------------------------------------------------------------------------------------------------------------------
# original files, SCD, combine modes, options, keep-going
# ---------------------------------------------------------------------------------------------------------------------
ORIGINAL_CLASSES = [
    "bottle", "cup", "knife", "bowl", "wine glass", "fork", "spoon", "banana", "apple", "orange", "cake",
    "potted plant", "mouse", "keyboard", "laptop", "cell phone", "book", "clock", "chair", "table", "couch", "bed",
    "toilet", "tv", "microwave", "toaster", "refrigerator", "oven", "sink", "person", "background",
]  # fmt: skip


def original_results_file(registry, env: str = "miniroom:1") -> dict:
    """A results file exactly as the original BenchBot writes it: task_details / environment_details are full copies
    of the original's YAML-derived dicts (with ``_file_path``, ``type: sim_unreal``, Unreal map paths...),
    label_probs over the original 31 classes in the original order, extra top-level keys."""
    name, variant = env.split(":")
    gt_objects = registry.ground_truth(env)["ground_truth"]["objects"]
    objects = []
    for o in gt_objects:
        probs = [0.0] * 31
        probs[ORIGINAL_CLASSES.index(o["class"])] = 1.0
        objects.append({"label_probs": probs, "centroid": list(o["centroid"]), "extent": list(o["extent"])})
    return {
        "task_details": {
            "_file_path": "/home/benchbot/.local/share/benchbot/addons/benchbot-addons/tasks_ral2021/tasks/"
                          "sslam_pgt.yaml",
            "name": "semantic_slam:passive:ground_truth", "type": "semantic_slam", "scene_count": 1,
            "actions": ["move_next"], "localisation": "ground_truth", "results_format": "object_map",
            "observations": ["image_depth", "image_depth_info", "image_rgb", "image_rgb_info", "laser", "poses"],
            "description": "Passive semantic SLAM with ground-truth localisation",
        },
        "environment_details": [{
            "_file_path": f"/home/benchbot/.local/share/benchbot/addons/benchbot-addons/envs_isaac_develop/"
                          f"environments/{name}_{variant}.yaml",
            "name": name, "variant": int(variant), "type": "sim_unreal", "robots": ["carter"],
            "description": "Develop environment", "map_path": "/Game/AI_vol3_03_base/Maps/AI_vol3_scene_03",
            "object_labels": ORIGINAL_CLASSES[:-1], "start_pose": [0.7, 0, 0, -0.7, 1.2, 1.5, 0.3],
            "trajectory_poses": [[1, 0, 0, 0, 1.2, 1.5, 0.24]],
        }],
        "results": {"objects": objects, "class_list": list(ORIGINAL_CLASSES)},
        "benchbot_version": "2.3.0", "meta": {"author": "someone"},
    }  # fmt: skip


def test_original_results_file_scores_unchanged(registry, tmp_path):
    data = original_results_file(registry)
    evaluation = evaluate([write(tmp_path / "orig.json", data)], "omq", registry)
    assert evaluation.per_result[0][1]["scores"]["OMQ"] == 1.0
    # a shuffled, renamed (synonyms) class list over the same objects scores the same
    perm = list(reversed(range(31)))
    data["results"]["class_list"] = [{"tv": "tvmonitor", "table": "diningtable"}.get(c, c) for c in
                                     (ORIGINAL_CLASSES[i] for i in perm)]  # fmt: skip
    for o in data["results"]["objects"]:
        o["label_probs"] = [o["label_probs"][i] for i in perm]
    evaluation = evaluate([write(tmp_path / "orig2.json", data)], "omq", registry)
    assert evaluation.per_result[0][1]["scores"]["OMQ"] == 1.0


def scd_results(registry, env: str = "miniroom:1:2", state_conf: float = 1.0) -> dict:
    from benchbot_eval_omq.omq import scd_ground_truth

    name, a, b = env.split(":")
    gt_a, gt_b = registry.ground_truth(f"{name}:{a}"), registry.ground_truth(f"{name}:{b}")
    class_list = gt_a["ground_truth"]["class_list"]
    objects = []
    for o, state in scd_ground_truth(gt_a["ground_truth"]["objects"], gt_b["ground_truth"]["objects"]):
        probs = [0.0] * len(class_list)
        probs[class_list.index(o["class"])] = 1.0
        states = [0.0, 0.0, 0.0]
        states[state] = state_conf
        objects.append({"label_probs": probs, "centroid": o["centroid"], "extent": o["extent"], "state_probs": states})
    return {
        "task_details": registry.get("tasks", "scd:passive:ground_truth"),
        "environment_details": registry.scenes(env),
        "results": {"objects": objects, "class_list": class_list, "state_list": ["added", "removed", "unchanged"]},
    }


def test_perfect_scd_on_miniroom_1_2_scores_one(registry, tmp_path):
    evaluation = evaluate([write(tmp_path / "scd.json", scd_results(registry))], "omq", registry)
    scores = evaluation.per_result[0][1]["scores"]
    assert scores["OMQ"] == pytest.approx(1.0) and scores["avg_state_quality"] == pytest.approx(1.0)
    assert scores["TP"] > 0 and scores["FP"] == scores["FN"] == 0
    data = scd_results(registry)
    data["results"]["objects"][0]["state_probs"] = [0.0, 0.0, 1.0]  # wrong state
    worse = evaluate([write(tmp_path / "scd2.json", data)], "omq", registry).per_result[0][1]["scores"]
    assert worse["OMQ"] < 1.0


def test_pooled_combine_counts_missing_env_objects_as_fn(registry, tmp_path):
    path = write(tmp_path / "r.json", perfect_results(registry, "miniroom:1"))
    n1 = len(registry.ground_truth("miniroom:1")["ground_truth"]["objects"])
    n2 = len(registry.ground_truth("house:1")["ground_truth"]["objects"])
    ev = evaluate([path], "omq", registry, required_envs=["miniroom:1", "house:1"], combine="pooled")
    assert ev.combined["combine"] == "pooled"
    assert ev.combined["scores"]["OMQ"] == pytest.approx(n1 / (n1 + n2))
    assert ev.combined["scores"]["FN"] == n2
    mean = evaluate([path], "omq", registry, required_envs=["miniroom:1", "house:1"])
    assert mean.combined["scores"]["OMQ"] == pytest.approx(0.5)
    with pytest.raises(UsageError, match="combine mode"):
        evaluate([path], "omq", registry, combine="median")


def test_method_options_per_class_and_oriented(registry, tmp_path):
    data = perfect_results(registry, "miniroom:1")
    for o in data["results"]["objects"]:
        o["yaw"] = 0.0
    data["results"]["objects"][0]["yaw"] = 0.7  # a rotated box: lower IoU only with --oriented
    path = write(tmp_path / "r.json", data)
    plain = evaluate([path], "omq", registry, options={"per_class": True})
    assert plain.per_result[0][1]["scores"]["OMQ"] == 1.0 and "per_class" in plain.per_result[0][1]
    assert "per_class" in plain.combined
    oriented = evaluate([path], "omq", registry, options={"oriented": True})
    assert oriented.per_result[0][1]["scores"]["OMQ"] < 1.0
    with pytest.raises(UsageError, match="does not support the option 'colour'"):
        evaluate([path], "omq", registry, options={"colour": True})


def test_keep_going_scores_good_files_and_collects_errors(registry, tmp_path):
    good = write(tmp_path / "good.json", perfect_results(registry, "miniroom:1"))
    data = perfect_results(registry, "house:1")
    data["results"]["objects"][3]["extent"] = [1, 2]
    bad = write(tmp_path / "bad.json", data)
    broken = tmp_path / "broken.json"
    broken.write_text("{")
    archive = tmp_path / "a.zip"
    with zipfile.ZipFile(archive, "w") as z:
        z.writestr("x.json", "not json")
    ev = evaluate([good, bad, broken, archive], "omq", registry, required_envs=["miniroom:1", "house:1"],
                  keep_going=True)  # fmt: skip
    assert [s for s, _ in ev.per_result] == [str(good)]
    assert [s for s, _ in ev.errors] == [str(bad), str(broken), f"{archive}:x.json"]
    assert ev.errors[0][1].message == f"{bad}: results.objects[3].extent: expected 3 numbers, got 2"
    assert ev.missing == ["house:1"] and ev.combined["scores"]["OMQ"] == pytest.approx(0.5)
    with pytest.raises(ResultsError, match="bad.json"):
        evaluate([good, bad], "omq", registry)  # without keep_going: the first error is raised


def test_results_of_two_tasks_and_missing_ground_truth(registry, tmp_path):
    a = write(tmp_path / "a.json", perfect_results(registry, "miniroom:1"))
    b = write(tmp_path / "b.json", perfect_results(registry, "miniroom:2", task="semantic_slam:active:ground_truth"))
    with pytest.raises(ResultsError, match="several tasks"):
        evaluate([a, b], "omq", registry, keep_going=True)


def test_results_read_once_are_scored_without_reading_the_file_again(registry, tmp_path):
    """A batch reads each episode's results file once (``loaded``): evaluate validates and scores what it was given
    and never reads that path again; other paths are read as usual, and errors keep their order and messages."""
    given = write(tmp_path / "given.json", perfect_results(registry, "miniroom:1"))
    loaded = {str(given): load_results(given)}
    given.write_text("{ this is no longer JSON")  # read again, it would fail
    data = perfect_results(registry, "house:1")
    data["results"]["objects"][3]["extent"] = [1, 2]
    bad = write(tmp_path / "bad.json", data)
    ev = evaluate([given, bad], "omq", registry, required_envs=["miniroom:1", "house:1"], keep_going=True,
                  loaded=loaded)
    assert [s for s, _ in ev.per_result] == [str(given)]
    assert ev.per_result[0][1]["scores"]["OMQ"] == 1.0
    assert [e.message for _, e in ev.errors] == [f"{bad}: results.objects[3].extent: expected 3 numbers, got 2"]
    invalid = dict(perfect_results(registry, "miniroom:2"))
    del invalid["environment_details"]
    (tmp_path / "invalid.json").write_text(json.dumps(invalid))
    with pytest.raises(ResultsError, match=r"invalid.json: \$: 'environment_details' is a required property"):
        evaluate([tmp_path / "invalid.json"], "omq", registry, loaded={
            str(tmp_path / "invalid.json"): load_results(tmp_path / "invalid.json")})  # given, still validated
