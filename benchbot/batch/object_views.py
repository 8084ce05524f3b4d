"""Per-class and per-object views of a run (``benchbot report``): each episode's results file re-scored with the
run's evaluation method asking for ``per_class`` and ``matches`` (docs/evaluation.md), checked against the run's
own primary score (:func:`score_objects`); the per-class table's rows; and what a top-down map draws: the
episode it shows (:func:`map_episode`), the path the robot drove (:func:`driven_path`: the batch's trajectory log,
else its recording) and the planned one (:func:`trajectory`).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from benchbot.batch.figures import fmt
from benchbot.batch.run_data import RunData
from benchbot.core.errors import BenchbotError, UsageError

RESCORE_TOLERANCE = 1e-9
"""Largest difference between a run's primary score and the re-scored one that is not reported as a change."""


def score_objects(run: RunData, registry) -> None:
    """Re-score the run's results files with its evaluation method asking for ``per_class`` and ``matches``, each
    against the set of ground truths its scores used (the row's ``ground_truth_set``; each environment's default
    where the run did not record one); fills ``run.objects``, ``run.per_class`` (the method's ``combine`` over
    every re-scored episode) and ``run.objects_note`` (why not, or that the re-scored primary score differs from
    the run's, naming the set it was re-scored against). Never raises: what cannot be done is noted."""
    from benchbot.core.evaluation import evaluate

    method = run.manifest.get("evaluate_with")
    if not method:
        run.objects_note = "the batch ran without an evaluation method: no per-class or per-object views"
        return
    by_set: dict[str, dict[str, dict]] = {}
    for row in run.rows:
        path = run.run_dir / row["results"] if row["results"] else None
        if path is not None and path.is_file():
            by_set.setdefault(row.get("ground_truth_set", ""), {})[str(path)] = row
    if not by_set:
        run.objects_note = "the results files are not in the run directory: no per-class or per-object views"
        return
    per_result, errors, combined = [], [], None
    for gt_set, by_path in by_set.items():
        evaluation = None
        for options in ({"per_class": True, "matches": True}, {"per_class": True}):
            try:
                evaluation = evaluate(list(by_path), method, registry, required_task=run.manifest.get("task"),
                                      options=options, keep_going=True, ground_truth_set=gt_set or None)
                break
            except UsageError:
                continue  # the method lacks the option: try with less
            except BenchbotError as exc:
                run.objects_note = f"re-scoring failed: {exc.message}"
                return
        if evaluation is None:
            run.objects_note = f"the evaluation method '{method}' gives no per-class scores"
            return
        per_result += [(source, result, by_path.get(source)) for source, result in evaluation.per_result]
        errors += evaluation.errors
        combined = evaluation.combined if len(by_set) == 1 else None
    if len(by_set) > 1:  # episodes scored against different sets: the method's combine over all of them
        try:
            combine = registry.functions("evaluators", method).get("combine")
            combined = combine([result for _, result, _ in per_result]) if combine else None
        except Exception:  # noqa: BLE001 - a method's own failure: the per-class view is left out, said below
            combined = None
    primary = run.primary
    differences = []
    used = set()
    for _source, result, row in per_result:
        if row is None:
            continue
        run.objects[row["index"]] = result
        used.add(str(result.get("ground_truth_set") or ""))
        new = (result.get("scores") or {}).get(primary)
        if new is not None and primary in row:
            differences.append(abs(float(new) - row[primary]))
    run.per_class = (combined or {}).get("per_class") if isinstance(combined, dict) else None
    notes = []
    if errors:
        notes.append(f"{len(errors)} results file(s) could not be re-scored ({errors[0][1].message})")
    if differences and max(differences) > RESCORE_TOLERANCE:
        sets = ", ".join(sorted(used - {""})) or "each environment's default"
        recorded = all(by_set)
        notes.append(f"re-scored {primary} differs from the run's by up to {fmt(max(differences))}: "
                     + (f"the ground truths of set {sets} or the evaluation method changed since the batch ran"
                        if recorded else
                        f"the run did not record its set of ground truths, and was re-scored against {sets}")
                     + "; per-class and per-object views show today's scoring")
    if not any("matches" in r for r in run.objects.values()):
        notes.append(f"the evaluation method '{method}' gives no per-object matches: no top-down maps")
    run.objects_note = "; ".join(notes)


def per_class_columns(run: RunData) -> tuple[list[str], list[str]]:
    """``(counts, scores)``: the method's declared counts and real-valued scores that its per-class entries hold
    (counts from each class's ``totals`` or ``scores``), in the method's order."""
    entries = list((run.per_class or {}).values())
    have = set()
    for e in entries:
        have |= set((e.get("totals") or {})) | set((e.get("scores") or {}))
    return ([c for c in run.score_set.counts if c in have], [s for s in run.score_set.scores if s in have])


def per_class_rows(run: RunData) -> list[dict]:
    """``[{class, <count>..., <score>...}]`` pooled over the run's episodes (:func:`per_class_columns`), classes by
    their counts' sum (most first); a score is None where the class has no value for it."""
    counts, scores = per_class_columns(run)
    rows = []
    for cls, entry in (run.per_class or {}).items():
        t, s = entry.get("totals") or {}, entry.get("scores") or {}
        row = {"class": cls}
        row.update({c: int(t.get(c, s.get(c, 0)) or 0) for c in counts})
        row.update({k: s.get(k) for k in scores})
        rows.append(row)
    return sorted(rows, key=lambda r: (-sum(r[c] for c in counts), r["class"]))


def trajectory(env: str, registry, fallback: list | None = None) -> np.ndarray | None:
    """The *planned* path: ``(k, 2)`` x, y (metres, map frame) of the environment's start pose then its trajectory
    poses (first scene), from the registry's environment spec, else from ``fallback`` (a results file's
    ``environment_details``); None when neither has poses."""
    scenes = None
    try:
        scenes = registry.scenes(env) if registry is not None else None
    except BenchbotError:
        scenes = None
    scenes = scenes or fallback or []
    if not scenes or not isinstance(scenes[0], dict):
        return None
    scene = scenes[0]
    poses = ([scene["start_pose"]] if scene.get("start_pose") else []) + list(scene.get("trajectory_poses") or [])
    xy = [(float(p[4]), float(p[5])) for p in poses if isinstance(p, (list, tuple)) and len(p) >= 6]
    return np.array(xy) if xy else None


def _stem(run: RunData, row: dict) -> str:
    """The stem of an episode's results file (``003_house_1``), as its plan named it; "" when unknown."""
    plan = next((p for p in run.manifest.get("plan", []) if isinstance(p, dict) and p.get("index") == row["index"]), {})
    return Path(str(plan.get("results") or row.get("results") or "")).stem


def driven_path(run: RunData, row: dict) -> tuple[np.ndarray | None, str]:
    """What the robot drove in an episode's first scene: ``((k, 2) x, y in metres, map frame, from its start, source)``
    from the batch's trajectory log (``trajectories/NNN_<env>.json``, :func:`benchbot.batch.episode_runner.run_episode`
    writes it), else from its recording (``recordings/NNN_<env>.mcap``, the ``/tf`` map → robot transforms of
    ``--record``); ``(None, "")`` when the batch kept neither (batches from before the log, without ``--record``)."""
    stem = _stem(run, row)
    if not stem:
        return None, ""
    log = run.run_dir / "trajectories" / f"{stem}.json"
    if log.is_file():
        try:
            data = json.loads(log.read_text())
            scene = data["scenes"][0]
            xy = [scene["start"][:2]] + [p[:2] for p in scene["poses"]]
            return np.asarray(xy, dtype=float).reshape(-1, 2), "trajectory log"
        except (OSError, ValueError, KeyError, IndexError, TypeError):
            pass
    recording = run.run_dir / "recordings" / f"{stem}.mcap"
    if recording.is_file():
        xy = recorded_path(recording)
        if xy is not None:
            return xy, "recording"
    return None, ""


def recorded_path(path: Path) -> np.ndarray | None:
    """``(k, 2)`` x, y (metres) of the map → robot transforms on ``/tf`` of a ``--record`` MCAP file, in time
    order (the robot's pose at the start and after every action); None when it cannot be read."""
    try:
        from mcap.reader import make_reader
        from mcap_ros2.decoder import DecoderFactory

        xy = []
        with open(path, "rb") as f:
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            for _schema, _channel, _message, msg in reader.iter_decoded_messages(topics=["/tf"], log_time_order=True):
                if msg.transforms:
                    t = msg.transforms[0].transform.translation
                    xy.append((float(t.x), float(t.y)))
        return np.asarray(xy, dtype=float) if xy else None
    except Exception:  # noqa: BLE001 - a damaged or foreign recording: the map shows the plan instead
        return None


def map_episode(run: RunData, env: str) -> tuple[dict, dict, int] | None:
    """The episode of ``env`` a map shows: the one with the median primary score among those with matches (the
    lower one of the middle two) → ``(row, evaluation, how many there were)``; None when none has matches."""
    rows = [r for r in run.rows if r["env"] == env and "matches" in run.objects.get(r["index"], {})]
    if not rows:
        return None
    rows.sort(key=lambda r: (run.score_set.sign() * r.get(run.primary, 0.0), r["index"]))
    row = rows[(len(rows) - 1) // 2]
    return row, run.objects[row["index"]], len(rows)
