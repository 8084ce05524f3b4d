"""Run directories for the report, predictivity and leaderboard tests, made from files as ``benchbot batch`` writes
them: a manifest, a config, results files built from an environment's ground truth (each object found with a given
quality, some missed, some false positives) and episode scores from the real OMQ evaluator. No simulator runs."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from benchbot.batch.plan import new_record, plan_episodes, to_json
from benchbot.core.evaluation import evaluate
from benchbot.core.registry import get_registry

TASK = "semantic_slam:passive:ground_truth"


def plan(root: Path, counts: dict[str, int], seed: int, robot: str = "carter", options: dict | None = None,
         noise: str = "none") -> list:
    """Episode specs as ``benchbot batch`` plans them: ``counts[env]`` repetitions of each environment, episode i
    with seed ``seed + i``."""
    specs = []
    for env, n in counts.items():
        for spec in plan_episodes(task=TASK, robots=[robot], envs=[env], repeat=n, seed=seed, argv=["python", "x.py"],
                                  cwd=str(root), options=dict(options or {}), timeout_s=None, noise=noise):
            i = len(specs)
            name = f"{i:03d}_{env.replace(':', '_')}_r{spec.repeat}"
            specs.append(dataclasses.replace(spec, index=i, seed=seed + i, results=f"results/{name}.json",
                                             log=f"logs/{name}.log"))
    return specs


def results_file(env: str, quality: float, seed: int) -> dict:
    """A results file for ``env``: every ground-truth object but every fifth found (shifted by ``1 - quality`` of
    its extent along x, labelled with probability ``quality``), plus two false positives; ``seed`` jitters it."""
    reg = get_registry()
    gt = reg.ground_truth(env)["ground_truth"]
    classes = list(gt["class_list"])
    rng = np.random.default_rng(seed)
    objects = []
    for k, o in enumerate(gt["objects"]):
        if k % 5 == 4:
            continue  # missed
        probs = [0.0] * len(classes)
        q = float(np.clip(quality + rng.normal(0, 0.03), 0.05, 1.0))
        probs[classes.index(o["class"])] = q
        shift = (1.0 - q) * o["extent"][0]
        objects.append({"label_probs": probs, "centroid": [o["centroid"][0] + shift, *o["centroid"][1:]],
                        "extent": list(o["extent"])})
    for k in range(2):
        probs = [0.0] * len(classes)
        probs[k] = 0.6
        c = gt["objects"][k]["centroid"]
        objects.append({"label_probs": probs, "centroid": [c[0] + 3.0, c[1] + 3.0, c[2]], "extent": [0.3, 0.3, 0.3]})
    name, variant = env.split(":")
    return {"task_details": dict(reg.get("tasks", TASK), name=TASK),
            "environment_details": [{"name": name, "variant": int(variant)}],
            "results": {"objects": objects, "class_list": classes}}


BACKEND = {"type": "sim_taichi", "plugin": "sim_taichi", "distribution": "benchbot-sim-taichi", "version": "0.1.0",
           "style": "primitives", "arch": "x64", "device": "Test CPU"}
"""A record's ``backend`` as a batch on the test machine writes it."""


def driven(spec, registry, offset: float = 0.25) -> dict:
    """A trajectory log for ``spec``: its environment's planned poses, each shifted ``offset`` metres along +y (the
    robot drove beside its plan)."""
    from benchbot.core.geometry import pose7_to_se2

    scene = registry.scenes(spec.env)[0]
    start = [float(v) for v in pose7_to_se2(scene["start_pose"])]
    poses = [[float(p[4]), float(p[5]) + offset, 0.0] for p in scene["trajectory_poses"]]
    return {"frame": "map", "scenes": [{"scene": 0, "environment": spec.env, "start": start, "poses": poses}]}


def make_run(root: Path, name: str, quality_by_env: dict[str, list[float]], *, example: str = "semslam_geometric",
             seed: int = 0, robot: str = "carter", plan_options: dict | None = None, sandbox: str = "bwrap",
             method: str = "omq", registry=None, noise: str = "none", backend: dict | None = None,
             trajectories: bool = False, ground_truth_set: str | None = None) -> Path:
    """A scored run directory ``root/name``: per environment, one episode per quality in its list (repetitions).

    ``plan_options`` are stored in every plan entry's ``options`` (e.g. ``{"lighting": "night"}``); ``sandbox`` is
    the manifest's isolation level; ``method`` scores it (with ``registry``, e.g. one holding a test evaluator);
    ``backend`` is every record's (default :data:`BACKEND`); ``trajectories`` writes trajectory logs
    (:func:`driven`); ``ground_truth_set`` scores it against that set of ground truths (``--ground-truths``), the
    manifest recording it as a batch does.
    """
    run = root / name
    (run / "results").mkdir(parents=True)
    envs = list(quality_by_env)
    reg = registry or get_registry()
    specs = plan(root, {e: len(v) for e, v in quality_by_env.items()}, seed, robot, plan_options, noise)
    records = []
    for spec in specs:
        quality = quality_by_env[spec.env][spec.repeat]
        (run / spec.results).write_text(json.dumps(results_file(spec.env, quality, spec.seed)))
        record = new_record(spec)
        record.status = "ok"
        record.backend = dict(BACKEND if backend is None else backend)
        records.append(record)
        if trajectories:
            (run / "trajectories").mkdir(exist_ok=True)
            (run / spec.trajectory).write_text(json.dumps(driven(spec, reg)))
    manifest = {"command": ["benchbot", "batch", "--example", example, "--envs", ",".join(envs)], "task": TASK,
                "robots": [robot], "environments": envs, "evaluate_with": method, "prefix": "batch", "zip": False,
                "versions": {"python": "3.11.7", "platform": "Linux-test", "benchbot": "0.1.0"},
                "provenance": {"benchbot_git": "0123456789abcdef0123456789abcdef01234567",
                               "solution_git": {str(root): None},
                               "machine": {"system": "Linux-test", "architecture": "x86_64", "cpu": "Test CPU",
                                           "cpus": 2, "memory_gib": 8.0}},
                "started": "2026-11-22T10:00:00+00:00", "plan": to_json(specs), "episodes": to_json(records),
                "wall_s": 12.5, "sandbox": sandbox, "ground_truth_set": ground_truth_set,
                "ground_truth_sets": {e: ground_truth_set or reg.ground_truth_set(e) for e in envs}}
    (run / "manifest.json").write_text(json.dumps(manifest))
    (run / "config.json").write_text(json.dumps({"task": TASK, "environments": {e: reg.scenes(e) for e in envs}}))
    by_source = {str(run / s.results): s for s in specs}
    evaluation = evaluate(list(by_source), method, reg, required_envs=envs, required_task=TASK, keep_going=True,
                          ground_truth_set=ground_truth_set)
    assert not evaluation.errors, evaluation.errors
    manifest["scores"] = evaluation.score_set.to_json()
    (run / "manifest.json").write_text(json.dumps(manifest))
    (run / "scores.json").write_text(json.dumps(evaluation.to_json()))
    (run / "episode_scores.json").write_text(json.dumps([
        {"index": by_source[src].index, "env": by_source[src].env, "robot": by_source[src].robot,
         "repeat": by_source[src].repeat, "seed": by_source[src].seed, "noise": noise, **scores}
        for src, scores in evaluation.per_result]))
    return run


def scores_only_run(root: Path, name: str, omq_by_env: dict[str, list[float]], *, seed: int = 0,
                    example: str = "semslam_geometric", sandbox: str = "bwrap", robot: str = "carter",
                    noise: str = "none", backend: dict | None = None, manifest: dict | None = None) -> Path:
    """A run directory with given OMQ values and no results files (fast: nothing is evaluated). ``backend``: every
    record's (default :data:`BACKEND`); ``manifest``: entries to add to (or replace in) the manifest."""
    run = root / name
    run.mkdir(parents=True)
    envs = list(omq_by_env)
    specs = plan(root, {e: len(v) for e, v in omq_by_env.items()}, seed, robot, noise=noise)
    records = []
    for spec in specs:
        record = new_record(spec)
        record.status = "ok"
        record.backend = dict(BACKEND if backend is None else backend)
        records.append(record)
    (run / "manifest.json").write_text(json.dumps({
        "command": ["benchbot", "batch", "--example", example], "task": TASK, "robots": [robot],
        "environments": envs, "evaluate_with": "omq", "plan": to_json(specs), "episodes": to_json(records),
        "sandbox": sandbox, **(manifest or {})}))
    (run / "config.json").write_text(json.dumps({"environments": {e: [{"lighting": "base"}] for e in envs}}))
    rows = [{"index": s.index, "env": s.env, "robot": robot, "repeat": s.repeat, "seed": s.seed, "noise": noise,
             "scores": {"OMQ": omq_by_env[s.env][s.repeat], "avg_label": 0.5}} for s in specs]
    (run / "episode_scores.json").write_text(json.dumps(rows))
    return run
