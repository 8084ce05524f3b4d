"""eval_omq against the core's contract checks (benchbot.plugins.testing): content and the evaluator."""

from __future__ import annotations

import json
from pathlib import Path

from benchbot.plugins import testing

DATA = Path(__file__).parent / "data"


def test_plugin_content_contract():
    from benchbot_eval_omq import plugin

    assert testing.check_content_plugin(plugin) == {"evaluators": ["omq"]}


def test_evaluator_contract_ground_truth_scores_one():
    from benchbot_eval_omq import plugin

    gt = json.loads((DATA / "miniroom_1.json").read_text())
    objects = [{"label_probs": [1.0 if c == o["class"] else 0.0 for c in gt["ground_truth"]["class_list"]],
                "centroid": o["centroid"], "extent": o["extent"]} for o in gt["ground_truth"]["objects"]]
    results = {
        "task_details": {"name": "semantic_slam:passive:ground_truth", "results_format": "object_map"},
        "environment_details": [{"name": "miniroom", "variant": 1}],
        "results": {"class_list": gt["ground_truth"]["class_list"], "objects": objects},
    }
    out = testing.check_evaluator(plugin.EVALUATION_METHODS_DIR / "omq.yaml", results, [gt], expect={"scores.OMQ": 1.0})
    assert out["scores"]["TP"] == len(objects)
