"""benchbot.core.evaluation: results files, archives, required environments and tasks, clear errors."""

from __future__ import annotations

import json
import zipfile

import pytest

from benchbot.core.errors import ResultsError, SpecError
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
