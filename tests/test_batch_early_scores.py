"""A batch scores each episode's results as its record arrives (benchbot.core.evaluation.EarlyScores, through
benchbot.batch.episode_results), while the other episodes still run; the evaluation at the end only combines. What
it writes (scores.json, episode_scores.json, the manifest) is byte for byte what scoring everything at the end
writes, with retried episodes, results the evaluation refuses, and a batch interrupted and resumed. No simulator
runs: a stand-in executor writes the results files as run_episode leaves them."""

from __future__ import annotations

import json
import shutil
import zipfile
from pathlib import Path

import pytest

from benchbot.batch import runner
from benchbot.batch.plan import new_record, plan_episodes
from benchbot.core import evaluation
from benchbot.core.errors import ResultsError
from benchbot.core.evaluation import EarlyScores, evaluate, load_results

TASK = "semantic_slam:passive:ground_truth"
ENVS = ["miniroom:1", "miniroom:2", "miniroom:3", "miniroom:4", "miniroom:5"]


def results_of(registry, env: str, *, keep_every: int = 1, shift_m: float = 0.0, named: str | None = None) -> dict:
    """A results file of ``env`` made from its ground truth: every ``keep_every``-th object, centroids moved by
    ``shift_m`` metres along x and softened labels when shifted (an imperfect map), naming ``named`` (another
    environment) when given."""
    gt = registry.ground_truth(env)["ground_truth"]
    classes = gt["class_list"]
    objects = []
    for k, o in enumerate(gt["objects"][::keep_every]):
        probs = [1.0 if c == o["class"] else 0.0 for c in classes]
        if shift_m and k % 2:
            probs = [0.6 * p + 0.4 / len(classes) for p in probs]
        objects.append({"label_probs": probs, "centroid": [o["centroid"][0] + shift_m, *o["centroid"][1:]],
                        "extent": o["extent"]})
    return {"task_details": registry.get("tasks", TASK),
            "environment_details": [registry.get("environments", named or env)],
            "results": {"objects": objects, "class_list": classes}}


def written_files(registry) -> dict[tuple[str, int], list[str | None]]:
    """What each episode (env, repeat) writes on each attempt (None: the attempt fails without results)."""
    invalid = results_of(registry, "miniroom:4")
    del invalid["environment_details"]  # parses: refused by the evaluation, naming the field
    return {
        ("miniroom:1", 0): [json.dumps(results_of(registry, "miniroom:1"))],
        ("miniroom:1", 1): [json.dumps(results_of(registry, "miniroom:1", keep_every=2, shift_m=0.15))],
        ("miniroom:2", 0): [json.dumps(results_of(registry, "miniroom:2", named="miniroom:3"))],  # another env's
        ("miniroom:2", 1): [json.dumps(results_of(registry, "miniroom:2", keep_every=3, shift_m=0.3))],
        ("miniroom:3", 0): [None, json.dumps(results_of(registry, "miniroom:3", keep_every=2, shift_m=0.1))],
        ("miniroom:3", 1): [json.dumps(results_of(registry, "miniroom:3"))],
        ("miniroom:4", 0): [json.dumps(invalid)],
        ("miniroom:4", 1): [json.dumps(results_of(registry, "miniroom:4", shift_m=0.05))],
        ("miniroom:5", 0): ["{not json", json.dumps(results_of(registry, "miniroom:5", keep_every=2))],
        ("miniroom:5", 1): [json.dumps(results_of(registry, "miniroom:5", shift_m=0.2))],
    }


class StandIn:
    """A stand-in for the local executor: writes each episode's results file for its attempt and hands an ``ok``
    record (``failed`` where the attempt writes nothing) to ``on_record``; with ``stop_after`` records it raises
    KeyboardInterrupt (Ctrl-C) instead of running the next episode. Counts the scorings during and after it."""

    def __init__(self, files: dict, stop_after: int | None = None) -> None:
        self.files, self.stop_after = files, stop_after
        self.attempts: dict[int, int] = {}
        self.running, self.handed = False, 0
        self.scored_while_running: list[str] = []
        self.scored_after: list[str] = []

    def __call__(self, episodes, run_dir, *, on_record, **_) -> None:
        self.running = True
        try:
            for spec, _run in episodes:
                if self.stop_after is not None and self.handed >= self.stop_after:
                    raise KeyboardInterrupt
                attempt = self.attempts.get(spec.index, 0)
                self.attempts[spec.index] = attempt + 1
                text = self.files[(spec.env, spec.repeat)][attempt]
                record = new_record(spec)
                record.status = "failed" if text is None else "ok"
                if text is not None:
                    (Path(run_dir) / spec.results).parent.mkdir(exist_ok=True)
                    (Path(run_dir) / spec.results).write_text(text)
                self.handed += 1
                on_record(record)
        finally:
            self.running = False

    def watch(self, monkeypatch) -> None:
        """Count every result the method scores, as while the episodes run or after."""
        score = evaluation._Scoring.score

        def counted(scoring, result, own_env):
            (self.scored_while_running if self.running else self.scored_after).append(result.source)
            return score(scoring, result, own_env)

        monkeypatch.setattr(evaluation._Scoring, "score", counted)


def new_batch(registry, run_dir: Path):
    specs = plan_episodes(task=TASK, robots=["carter"], envs=ENVS, repeat=2, seed=0, argv=["x"], cwd=str(run_dir),
                          options={}, timeout_s=None)
    return runner.prepare_batch(registry, run_dir=run_dir, specs=specs, evaluate_with="omq", prefix="batch",
                                zip_results=False)


def outputs(run_dir: Path) -> dict[str, bytes]:
    """The files a batch's evaluation writes, the manifest without its clock readings (start, end, wall time)."""
    manifest = json.loads((run_dir / "manifest.json").read_text())
    for key in ("started", "finished", "wall_s"):
        manifest.pop(key)
    return {"scores.json": (run_dir / "scores.json").read_bytes(),
            "episode_scores.json": (run_dir / "episode_scores.json").read_bytes(),
            "manifest": json.dumps(manifest, sort_keys=True).encode()}


def at_the_end(registry, run_dir: Path, monkeypatch) -> dict[str, bytes]:
    """The outputs of the batch with every result scored after the episodes (no early scores: as before)."""
    with monkeypatch.context() as m:
        m.setattr(runner, "early_scores", lambda *_: None)
        stand_in = StandIn(written_files(registry))
        stand_in.watch(m)
        m.setattr(runner, "run_local", stand_in)
        runner.run_batch(registry, new_batch(registry, run_dir), retries=1)
    assert stand_in.scored_while_running == [] and len(stand_in.scored_after) == 9  # miniroom:4 r0 never scored
    return outputs(run_dir)


def test_each_episode_is_scored_as_it_ends_and_the_files_are_byte_identical(registry, tmp_path, monkeypatch):
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    stand_in = StandIn(written_files(registry))
    stand_in.watch(monkeypatch)
    monkeypatch.setattr(runner, "run_local", stand_in)
    outcome = runner.run_batch(registry, new_batch(registry, run_dir), retries=1)
    early = outputs(run_dir)
    # every results file that validates scored once, as its record arrived; nothing left for the end. The retried
    # episodes (miniroom:3 r0 failed, miniroom:5 r0 did not parse) are scored once, their second attempt
    paths = {(e.env, e.repeat): str(run_dir / e.results) for e in outcome.episodes}
    assert sorted(stand_in.scored_while_running) == sorted(p for k, p in paths.items() if k != ("miniroom:4", 0))
    assert stand_in.scored_after == []
    statuses = {(e.env, e.repeat): (e.status, e.attempts) for e in outcome.episodes}
    assert statuses[("miniroom:3", 0)] == ("ok", 2) and statuses[("miniroom:5", 0)] == ("ok", 2)
    assert statuses[("miniroom:2", 0)][0] == statuses[("miniroom:4", 0)][0] == "bad_results"  # found at the end
    omq = [s["scores"]["OMQ"] for _, s in outcome.evaluation.per_result]
    assert len(omq) == 8 and len(set(omq)) > 3 and max(omq) == 1.0 > min(omq)  # scores that tell files apart

    shutil.rmtree(run_dir)
    run_dir.mkdir()
    assert at_the_end(registry, run_dir, monkeypatch) == early


def test_an_interrupted_batch_resumed_scores_the_earlier_episodes_while_the_new_ones_run(registry, tmp_path,
                                                                                         monkeypatch):
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    files = written_files(registry)
    first = StandIn(files, stop_after=4)
    monkeypatch.setattr(runner, "run_local", first)
    with pytest.raises(KeyboardInterrupt):
        runner.run_batch(registry, new_batch(registry, run_dir), retries=1)
    resumed = StandIn(files)
    resumed.attempts = dict(first.attempts)  # the attempts already made stay made
    resumed.watch(monkeypatch)
    monkeypatch.setattr(runner, "run_local", resumed)
    outcome = runner.run_batch(registry, runner.load_batch(registry, run_dir), retries=1)
    assert [e.status for e in outcome.episodes].count("ok") == 8
    # the four finished before the interruption are scored as the new episodes end, one each, and nothing twice
    assert len(resumed.scored_while_running) == len(set(resumed.scored_while_running)) == 9
    assert resumed.scored_after == []
    early = outputs(run_dir)

    shutil.rmtree(run_dir)
    run_dir.mkdir()
    reference = at_the_end(registry, run_dir, monkeypatch)
    assert early["scores.json"] == reference["scores.json"]
    assert early["episode_scores.json"] == reference["episode_scores.json"]


def test_evaluate_takes_early_outcomes_only_for_the_results_they_were_computed_for(registry, tmp_path,
                                                                                    monkeypatch):
    """``evaluate(..., early=...)``: the same scores and errors, in the same order, as scoring everything itself
    (an archive, an invalid file, results of another environment); a file read again (new result objects) is scored
    again; early scores of another set of ground truths or options are not used."""
    good = tmp_path / "good.json"
    good.write_text(json.dumps(results_of(registry, "miniroom:1", keep_every=2, shift_m=0.1)))
    other = tmp_path / "other.json"
    other.write_text(json.dumps(results_of(registry, "miniroom:2", named="miniroom:1")))
    invalid = results_of(registry, "miniroom:3")
    invalid["results"]["objects"][0]["extent"] = [1, 2]
    archive = tmp_path / "a.zip"
    with zipfile.ZipFile(archive, "w") as z:
        z.writestr("x.json", json.dumps(invalid))
        z.writestr("y.json", json.dumps(results_of(registry, "miniroom:3")))
    paths = [good, other, archive]
    envs = {str(good): "miniroom:1", str(other): "miniroom:2", str(archive): "miniroom:3"}
    kwargs = dict(required_envs=ENVS[:4], required_task=TASK, keep_going=True, environments=envs)
    loaded = {str(p): load_results(p) for p in paths}
    plain = evaluate(paths, "omq", registry, loaded=loaded, **kwargs)
    early = EarlyScores("omq", registry, required_task=TASK)
    assert [early.add(loaded[str(p)], envs[str(p)]) for p in paths] == [1, 1, 1]
    calls = []
    score = evaluation._Scoring.score
    monkeypatch.setattr(evaluation._Scoring, "score",
                        lambda self, result, env: calls.append(result.source) or score(self, result, env))
    taken = evaluate(paths, "omq", registry, loaded=loaded, early=early, **kwargs)
    assert calls == []  # everything came from the early outcomes
    assert taken.per_result == plain.per_result and taken.combined == plain.combined
    assert [(s, e.message) for s, e in taken.errors] == [(s, e.message) for s, e in plain.errors]
    assert [s for s, _ in plain.errors] == [str(other), f"{archive}:x.json"]
    again = {**loaded, str(good): load_results(good)}  # read again: new objects, scored again
    assert evaluate(paths, "omq", registry, loaded=again, early=early, **kwargs).per_result == plain.per_result
    assert calls == [str(good)]
    other_options = EarlyScores("omq", registry, required_task=TASK, options={"per_class": True})
    other_options.add(loaded[str(good)], "miniroom:1")
    calls.clear()
    evaluate([good], "omq", registry, loaded=loaded, early=other_options, environments=envs, keep_going=True)
    assert calls == [str(good)]  # computed with another option: scored again
    with pytest.raises(ResultsError, match="environment_details name miniroom:1"):
        evaluate([other], "omq", registry, loaded=loaded, early=early, environments=envs)  # the kept error, raised
