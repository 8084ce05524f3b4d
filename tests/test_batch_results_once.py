"""A batch reads each episode's results file once (benchbot.batch.episode_results): the batch process reads it as the
episode's record arrives, a file that does not parse fails its own episode (run again with --retries), and the
evaluation scores what was read without reading the file again. No simulator runs: a stand-in executor writes the
results files as run_episode leaves them."""

from __future__ import annotations

import json
from pathlib import Path

from benchbot.batch import runner
from benchbot.batch.episode_results import EpisodeResults
from benchbot.batch.plan import new_record, plan_episodes
from benchbot.core import evaluation
from benchbot.core.registry import get_registry

TASK = "semantic_slam:passive:ground_truth"


def perfect_results(registry, env: str) -> dict:
    """The ground truth of ``env`` as a results file (one-hot labels): OMQ 1."""
    gt = registry.ground_truth(env)["ground_truth"]
    classes = gt["class_list"]
    objects = [{"label_probs": [1.0 if c == o["class"] else 0.0 for c in classes], "centroid": o["centroid"],
                "extent": o["extent"]} for o in gt["objects"]]
    return {"task_details": registry.get("tasks", TASK), "environment_details": [registry.get("environments", env)],
            "results": {"objects": objects, "class_list": classes}}


def test_each_results_file_is_read_once_and_a_bad_one_fails_only_its_episode(tmp_path, monkeypatch):
    registry = get_registry()
    specs = plan_episodes(task=TASK, robots=["carter"], envs=["miniroom:1", "miniroom:2", "miniroom:3"], repeat=1,
                          seed=0, argv=["x"], cwd=str(tmp_path), options={}, timeout_s=None)
    batch = runner.prepare_batch(registry, run_dir=tmp_path, specs=specs, evaluate_with="omq", prefix="batch",
                                 zip_results=False)
    invalid = perfect_results(registry, "miniroom:3")
    del invalid["environment_details"]  # parses: refused by the evaluation, naming the field
    written = {"miniroom:1": json.dumps(perfect_results(registry, "miniroom:1")), "miniroom:2": "{not json",
               "miniroom:3": json.dumps(invalid)}

    def run_local(episodes, run_dir, *, on_record, **_):  # what run_episode leaves: the file, an ok record
        for spec, _run in episodes:
            (Path(run_dir) / spec.results).parent.mkdir(exist_ok=True)
            (Path(run_dir) / spec.results).write_text(written[spec.env])
            record = new_record(spec)
            record.status = "ok"
            on_record(record)

    reads: list[str] = []
    read_capped = evaluation.read_capped
    monkeypatch.setattr(evaluation, "read_capped",
                        lambda path, *args, **kwargs: reads.append(str(path)) or read_capped(path, *args, **kwargs))
    monkeypatch.setattr(runner, "run_local", run_local)
    outcome = runner.run_batch(registry, batch, retries=1)
    paths = [str(batch.run_dir / spec.results) for spec in specs]
    # read once per attempt, as each record arrives, and never again to be scored; the one that does not parse is
    # found then, so it runs again; the one the evaluation refuses is found after the episodes, as before
    assert sorted(reads) == sorted([paths[0], paths[1], paths[1], paths[2]])
    assert [(e.status, e.attempts) for e in outcome.episodes] == [("ok", 1), ("bad_results", 2), ("bad_results", 1)]
    assert outcome.episodes[1].error.startswith(f"{paths[1]}: not valid JSON")
    assert outcome.episodes[2].error == f"{paths[2]}: $: 'environment_details' is a required property"
    assert [(source, scores["scores"]["OMQ"]) for source, scores in outcome.evaluation.per_result] == [(paths[0], 1.0)]
    scored = json.loads((batch.run_dir / "episode_scores.json").read_text())
    assert [e["env"] for e in scored] == ["miniroom:1"]


def test_results_checked_without_an_evaluation_are_not_kept(tmp_path):
    ok, bad = tmp_path / "results" / "a.json", tmp_path / "results" / "b.json"
    ok.parent.mkdir()
    ok.write_text(json.dumps({"task_details": {}}))
    bad.write_text("[1, 2]")
    records = []
    for name in ("a", "b", "c"):
        record = new_record(plan_episodes(task=TASK, robots=["carter"], envs=["miniroom:1"], repeat=1, seed=0,
                                          argv=["x"], cwd=".", options={}, timeout_s=None)[0])
        record.results, record.status = f"results/{name}.json", "ok"
        records.append(record)
    records[2].status = "failed"  # not ok: not read, left as it is
    checked = EpisodeResults(tmp_path, keep=False)
    for record in records:
        checked.check(record)
    assert [r.status for r in records] == ["ok", "bad_results", "failed"]
    assert records[1].error == f"{bad}: expected a JSON object at the top level" and checked.loaded == {}
    kept = EpisodeResults(tmp_path, keep=True)
    kept.check(records[0])
    assert [r.source for r in kept.loaded[str(ok)]] == [str(ok)]
