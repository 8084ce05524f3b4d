"""Scene change detection on a variant pair scores object changes only: a real ``benchbot batch`` of the task
``scd:passive:ground_truth`` on ``miniroom:1:2`` in the furnished style (the default; the test suite's conftest picks
the primitives style, unset here). The changes it is scored against (``benchbot_eval_omq.omq.scd_ground_truth``: the
objects of one variant's ground-truth file that the other has not, by ID_name, class, centroid and extent) are
exactly the objects that differ between ``miniroom_1.json`` and ``miniroom_2.json``, all of the task's object
classes: the walls, doors, windows and lamps of the home are in neither file, and the simulator draws them the same
in both scenes (plugins/worlds/tests/test_one_home.py: one plan, one set of furniture, and depth images that
differ only at the changed objects)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from benchbot_eval_omq.omq import SCD_STATE_LIST, evaluate
from benchbot_worlds.bear import DATA_DIR

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]


def _objects(v: int) -> dict:
    data = json.loads((DATA_DIR / f"miniroom_{v}.json").read_text())
    return {(o["ID_name"], o["class"], tuple(o["centroid"]), tuple(o["extent"])): o
            for o in data["ground_truth"]["objects"]}


@pytest.mark.slow
def test_an_scd_batch_on_a_variant_pair_is_scored_against_the_object_changes_only(tmp_path, registry):
    env = {k: v for k, v in os.environ.items() if k != "BENCHBOT_SIM_STYLE"}
    proc = subprocess.run([*BENCHBOT, "batch", "--example", "hello_passive", "--task", "scd:passive:ground_truth",
                           "--envs", "miniroom:1:2", "--camera-size", "64x48", "--output-dir", str(tmp_path),
                           "--json"], capture_output=True, text=True, timeout=900, env=env)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    run_dir = Path(json.loads(proc.stdout)["run_dir"])
    manifest = json.loads((run_dir / "manifest.json").read_text())
    assert [e["status"] for e in manifest["episodes"]] == ["ok"] and not manifest["episodes"][0]["collided"]
    results = json.loads((run_dir / manifest["plan"][0]["results"]).read_text())
    assert [(e["name"], e["variant"]) for e in results["environment_details"]] == [("miniroom", 1), ("miniroom", 2)]

    a, b = _objects(1), _objects(2)
    removed, added = set(a) - set(b), set(b) - set(a)
    assert len(removed) == 4 and len(added) == 5  # BEAR's miniroom:2 against miniroom:1
    scored = evaluate(results, [registry.ground_truth("miniroom:1"), registry.ground_truth("miniroom:2")],
                      matches=True)
    changes = scored["matches"]["ground_truth"]
    got = {(c["state"], c["ID_name"], c["class"]) for c in changes}
    want = {("removed", k[0], k[1]) for k in removed} | {("added", k[0], k[1]) for k in added}
    assert got == want and len(changes) == len(want)
    task_classes = set(registry.get("environments", "miniroom:1")["object_labels"])
    assert {c["class"] for c in changes} <= task_classes  # no wall, door, window or lamp: only objects change
    assert {c["state"] for c in changes} <= set(SCD_STATE_LIST)
    # the batch's own scores: the empty map of hello_passive misses every change, and nothing else
    batch_scores = json.loads((run_dir / "scores.json").read_text())["scores"]
    assert batch_scores["FN"] == len(want) and batch_scores["FP"] == 0 and batch_scores["TP"] == 0
