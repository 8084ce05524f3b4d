"""`benchbot plugin new`'s templates (package data in ``benchbot/plugins/scaffold_templates/``): for every kind, each
file of the project is filled in completely and is valid for its type (Python compiles, YAML and TOML parse). The
built project is installed and tested end to end in ``test_plugins_e2e.py``."""

import re
import tomllib

import pytest
import yaml

from benchbot.plugins.scaffold import KINDS, TEMPLATES, project_files


@pytest.mark.parametrize("kind", KINDS)
def test_every_file_of_a_project_is_filled_in_and_valid(kind):
    files = project_files(kind, "lidar_noise")
    assert "pyproject.toml" in files and "tests/test_contract.py" in files
    for rel, text in files.items():
        assert not re.search(r"\$\{[a-z_]+\}", text), f"{rel}: a placeholder was left unfilled"
        if rel.endswith(".py"):
            compile(text, rel, "exec")
        elif rel.endswith((".yaml", ".yml")):
            assert isinstance(yaml.safe_load(text), dict), rel
        elif rel.endswith(".toml"):
            tomllib.loads(text)
    assert tomllib.loads(files["pyproject.toml"])["project"]["name"] == f"benchbot-{kind}-lidar-noise"


def test_every_template_file_is_used():
    import benchbot.plugins.scaffold as scaffold

    source = open(scaffold.__file__, encoding="utf-8").read()
    names = [p.name.removesuffix(".tmpl") for p in TEMPLATES.glob("*.tmpl")]
    assert len(names) >= 18 and all(f'"{n}"' in source for n in names)


def test_the_eval_template_declares_the_scores_its_metric_returns(tmp_path, monkeypatch):
    """An evaluator declares its scores (docs/evaluation.md, "Declaring scores"), the scaffold's too: its spec names
    the primary score and every score ``evaluate`` returns, and passes the contract's evaluator check."""
    import importlib

    from benchbot.core.specs import check_evaluator_scores
    from benchbot.plugins.testing import check_evaluator

    files = project_files("eval", "lidar_noise")
    for rel, text in files.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text(text, encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    importlib.invalidate_caches()
    spec_path = tmp_path / "benchbot_eval_lidar_noise/evaluation_methods/lidar_noise.yaml"
    spec = yaml.safe_load(spec_path.read_text(encoding="utf-8"))
    check_evaluator_scores(spec, str(spec_path))
    declared = {s["name"]: s for s in spec["scores"]}
    assert [n for n, s in declared.items() if s.get("primary")] == ["count_score"]
    gt = {"environment": {"name": "room", "variant": 1}, "format": {"name": "object_map_ground_truth"},
          "ground_truth": {"class_list": ["chair"], "objects": [
              {"class": "chair", "centroid": [0, 0, 0.5], "extent": [0.5, 0.5, 1.0]}]}}
    results = {"task_details": {"name": "semantic_slam:passive:ground_truth", "results_format": "object_map"},
               "environment_details": [{"name": "room", "variant": 1}],
               "results": {"class_list": ["chair"], "objects": []}}
    scores = check_evaluator(spec_path, results, [gt], expect={"scores.count_score": 0.0})
    assert set(scores["scores"]) == set(declared)
    assert {n for n, s in declared.items() if s.get("kind") == "count"} == {"proposed", "expected"}
