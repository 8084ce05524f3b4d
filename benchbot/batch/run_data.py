"""Run directories as data (``benchbot report``, ``benchbot leaderboard``): :func:`load_run` reads one into a
:class:`RunData` (its manifest, configuration and one row per scored episode), refusing an unfinished or failed
batch in one line that says how to finish it (:class:`UnfinishedRun`, :class:`FailedRun`); :func:`assign_labels`
names the runs a report compares.

Scores are what the run's evaluation method declares (:func:`resolve_score_set`,
:class:`benchbot.core.evaluation.ScoreSet`); nothing here knows a method's score names.
"""

from __future__ import annotations

import json
import shlex
from dataclasses import dataclass, field
from pathlib import Path

from benchbot.batch.plan import read_manifest
from benchbot.batch.run_conditions import solution
from benchbot.core.errors import BenchbotError, UsageError
from benchbot.core.evaluation import ScoreSet, method_scores, observed_scores

ROW_FIELDS = ("index", "env", "robot", "repeat", "seed", "noise", "lighting", "results", "ground_truth_set")
"""The fields of an episode's row besides its scores (a score of one of these names is not read)."""


@dataclass
class RunData:
    """One run directory's episodes with their scores.

    Attributes:
        run_dir: the folder. manifest, config: its ``manifest.json`` and ``config.json``.
        rows: one dict per scored episode: ``index``, ``env``, ``robot``, ``repeat``, ``seed``, ``noise``
            (``"none"`` when not recorded), ``lighting`` (or ``""``), ``results`` (path relative to the run
            directory, or ``""``), ``ground_truth_set`` (the set of ground truths its scores used:
            :func:`episode_ground_truth_set`; ``""`` when not recorded) and every numeric score the method returned
            for it.
        score_set: what the scores are (:func:`resolve_score_set`).
        label: the name the report gives the run (``--label``, else :func:`default_label`).
        objects: per episode index, the re-scored evaluation with ``per_class`` and ``matches`` (after
            :func:`score_objects`).
        per_class: the run's per-class totals and scores pooled over its episodes, or None.
        objects_note: why there are no per-class or per-object views, or what re-scoring found; "" when all is well.
    """

    run_dir: Path
    manifest: dict
    config: dict
    rows: list[dict]
    score_set: ScoreSet
    label: str = ""
    objects: dict[int, dict] = field(default_factory=dict)
    per_class: dict | None = None
    objects_note: str = ""

    @property
    def name(self) -> str:
        """The run's label, or its folder's name."""
        return self.label or self.run_dir.name

    @property
    def primary(self) -> str:
        """The name of its method's primary score."""
        return self.score_set.primary.name


class UnfinishedRun(UsageError):
    """A run directory whose batch did not finish (it was interrupted): nothing to report until it is resumed."""


class FailedRun(UsageError):
    """A run directory whose batch finished with every episode failed: nothing was scored (``leaderboard`` skips it
    as it skips an :class:`UnfinishedRun`)."""


def _read_json(path: Path, what: str):
    """``path`` parsed as JSON.

    Raises:
        UsageError: it cannot be read or is not JSON (naming it as ``what``).
    """
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise UsageError(f"{path}: {what} is unreadable or not JSON ({exc.__class__.__name__})",
                         "it is written by `benchbot batch`; was it edited or cut short?") from None


def resolve_score_set(manifest: dict, entries: list, registry=None) -> ScoreSet:
    """What a run's scores are: the declaration its manifest recorded (``scores``), else the one its evaluation
    method declares now (with ``registry``), else what its episodes' scores show (:func:`observed_scores`).

    Raises:
        UsageError: none of these gives a score (no numeric score in any episode).
    """
    recorded = manifest.get("scores")
    if isinstance(recorded, dict):
        try:
            return ScoreSet.from_json(recorded)
        except ValueError:
            pass
    method = str(manifest.get("evaluate_with") or "")
    if registry is not None and method:
        try:
            declared = method_scores(registry, method)
        except BenchbotError:
            declared = None
        if declared is not None:
            return declared
    try:
        return observed_scores(method, [e.get("scores") if isinstance(e, dict) and isinstance(e.get("scores"), dict)
                                        else {} for e in entries])
    except ValueError:
        raise UsageError(f"the episode scores of the run (method '{method or 'unknown'}') hold no numeric score",
                         "it is written by `benchbot batch`; was it edited?") from None


def unfinished(manifest: dict) -> str:
    """Why a run directory's batch is unfinished, in words ("3 of 10 episodes not run"), or "" when it finished
    (its manifest has ``finished``: :func:`benchbot.batch.runner.run_batch` writes it last)."""
    if manifest.get("finished"):
        return ""
    records = [e for e in manifest.get("episodes", []) if isinstance(e, dict)]
    left = sum(e.get("status") in ("pending", "running") for e in records)
    return f"{left} of {len(records)} episodes not run" if left else "it was stopped before its evaluation"


def load_run(run_dir: Path, label: str | None = None, registry=None) -> RunData:
    """Read a run directory.

    Args:
        registry: to read what the scores are from the installed evaluation method when the manifest did not
            record it (:func:`resolve_score_set`); None: from the manifest or the scores themselves.

    Raises:
        UnfinishedRun: the batch was interrupted (the hint names ``benchbot batch --resume``).
        FailedRun: the batch finished with every episode failed (the first one's reason and log named).
        UsageError: not a run directory, no scores (not evaluated), or a file is malformed (naming it and the
            field).
    """
    run_dir = Path(run_dir)
    manifest = read_manifest(run_dir)
    path = run_dir / "episode_scores.json"
    why = unfinished(manifest)
    if why and (not path.is_file() or "not run" in why):
        raise UnfinishedRun(f"{run_dir}: the batch did not finish ({why})",
                                f"finish it: benchbot batch --resume {shlex.quote(str(run_dir))}")
    records = [e for e in manifest.get("episodes", []) if isinstance(e, dict)]
    if records and not path.is_file() and not any(e.get("status") == "ok" for e in records):
        first = records[0]
        reason = first.get("error") or (f"exit status {first['returncode']}" if first.get("returncode") else
                                        first.get("status", "failed"))
        log = f" (first: {first.get('env', '?')}: {reason}; log {run_dir / first['log']})" if first.get("log") else ""
        raise FailedRun(f"{run_dir}: every episode failed, {len(records)} of {len(records)}{log}",
                        f"fix the cause, then benchbot batch --resume {shlex.quote(str(run_dir))} runs them again")
    if not path.is_file():
        if manifest.get("evaluation_error"):
            raise UsageError(f"{run_dir} has no episode_scores.json: its evaluation failed "
                             f"({manifest['evaluation_error']})", "fix the cause, then benchbot batch --resume "
                             f"{shlex.quote(str(run_dir))} evaluates it again")
        raise UsageError(f"{run_dir} has no episode_scores.json (the batch was not evaluated: --no-evaluate, no ground "
                         "truth, or no episode produced results)", "run a batch with an evaluation method "
                         "(--evaluate-with METHOD, `benchbot list evaluators`)")
    config = _read_json(run_dir / "config.json", "config.json") if (run_dir / "config.json").is_file() else {}
    entries = _read_json(path, "episode_scores.json")
    plan = {p.get("index"): p for p in manifest.get("plan", []) if isinstance(p, dict)}
    records = {e.get("index"): e for e in manifest.get("episodes", []) if isinstance(e, dict)}
    try:
        lighting = {env: "+".join(str(s.get("lighting", "")) for s in scenes)
                    for env, scenes in (config.get("environments") or {}).items()}
        if not isinstance(entries, list):
            raise TypeError("expected a list of episodes")
        rows = []
        for k, entry in enumerate(entries):
            missing = [f for f in ("index", "env", "robot", "repeat", "seed") if f not in entry]
            if missing:
                raise KeyError(f"[{k}].{missing[0]}")
            row = {f: entry[f] for f in ("index", "env", "robot", "repeat", "seed")}
            spec = plan.get(entry["index"], {})
            row["noise"] = str(entry.get("noise") or spec.get("noise") or "none")
            options = spec.get("options") or {}
            row["lighting"] = str(options.get("lighting") or lighting.get(entry["env"], ""))
            row["results"] = str((records.get(entry["index"]) or spec).get("results", ""))
            row["ground_truth_set"] = episode_ground_truth_set(manifest, entry)
            row.update({s: float(v) for s, v in (entry.get("scores") or {}).items()
                        if s not in ROW_FIELDS and isinstance(v, (int, float)) and not isinstance(v, bool)})
            rows.append(row)
    except (KeyError, TypeError, AttributeError, ValueError) as exc:
        detail = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        raise UsageError(f"{path}: malformed ({detail})", "it is written by `benchbot batch`; was it edited?") from None
    if not rows:
        raise UsageError(f"{run_dir} has no scored episodes", "every episode failed, or the batch ran with --no-evaluate")
    return RunData(run_dir, manifest, config, rows, resolve_score_set(manifest, entries, registry), label or "")


def episode_ground_truth_set(manifest: dict, entry: dict) -> str:
    """The set of ground truths an episode's scores used (``isaac_develop``, ``bear_develop``...): what its entry
    of ``episode_scores.json`` says (the evaluation writes ``ground_truth_set``), else the manifest's
    ``ground_truth_sets`` for its environment, else the manifest's ``ground_truth_set`` (``--ground-truths``); ""
    for a batch from before BenchBot recorded it."""
    for value in (entry.get("ground_truth_set"), (manifest.get("ground_truth_sets") or {}).get(entry.get("env")),
                  manifest.get("ground_truth_set")):
        if isinstance(value, str) and value:
            return value.removeprefix("ground_truths_")
    return ""


def default_label(manifest: dict, run_dir: Path) -> str:
    """A short name for a run: the example's name, a native command's script (``my_solution.py``) or program, a
    container folder's name; the folder's name when the manifest does not say."""
    kind, what = solution(manifest)
    if kind == "example":
        return what
    if kind == "container":
        return Path(what.rstrip("/")).name or what
    if kind == "native" and what:
        words = what.split()
        script = next((w for w in words if w.endswith((".py", ".sh", ".jl", ".R"))), words[0])
        return Path(script).name
    return run_dir.name


def assign_labels(runs: list[RunData], labels: list[str] | None) -> None:
    """Give every run its label: ``labels`` in order (``--label``), else :func:`default_label`; a label two runs
    share gets each run's folder name added (``semslam_geometric (batch-20261122-103519)``).

    Raises:
        UsageError: ``labels`` given, but not one per run, or empty.
    """
    if labels:
        if len(labels) != len(runs):
            raise UsageError(f"--label: {len(labels)} labels for {len(runs)} run directories",
                             "give one --label per run directory, in the same order")
        if any(not str(label).strip() for label in labels):
            raise UsageError("--label: a label is empty", "give each run a name, e.g. --label baseline")
    for k, run in enumerate(runs):
        run.label = str(labels[k]).strip() if labels else default_label(run.manifest, run.run_dir)
    seen: dict[str, int] = {}
    for run in runs:
        seen[run.label] = seen.get(run.label, 0) + 1
    for run in runs:
        if seen[run.label] > 1:
            run.label = f"{run.label} ({run.run_dir.name})"
    for k, run in enumerate(runs):  # still equal (same folder names): number them
        if sum(r.label == run.label for r in runs) > 1:
            run.label = f"{run.label} #{k + 1}"
