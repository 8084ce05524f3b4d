"""Loading, validating and scoring results files with an evaluation method (reference §1.4, §7.1).

A results file is ``{task_details: {name, results_format, ...}, environment_details: [{name, variant, ...}, ...],
results: <an instance of the results format>}``; a ``.zip`` archive holds such JSON files (``submission.json``
members are skipped, as in the original). Ground truths are found by each scene's ``name:variant``.
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

from benchbot.core.errors import BenchbotError, ResultsError, SpecError
from benchbot.core.registry import Registry, json_path, validator


@dataclass
class LoadedResult:
    """One results file (or archive member): ``source`` names it, ``data`` is its parsed JSON."""

    source: str
    data: dict

    @property
    def env_string(self) -> str:
        """``name:v1[:v2...]`` of its scenes (reference §2.2)."""
        envs = self.data["environment_details"]
        return f"{envs[0]['name']}:" + ":".join(str(e["variant"]) for e in envs)


def _parse(source: str, text: bytes | str) -> dict:
    try:
        data = json.loads(text)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ResultsError(f"{source}: not valid JSON ({exc})", "fix the file or write it with json.dump") from None
    if not isinstance(data, dict):
        raise ResultsError(f"{source}: expected a JSON object at the top level", "")
    return data


def load_results(path: Path | str) -> list[LoadedResult]:
    """The results in a JSON file or a ``.zip`` archive of JSON files.

    Raises:
        ResultsError: the file is missing or unreadable, or a member is not valid JSON.
    """
    path = Path(path)
    if not path.is_file():
        raise ResultsError(f"{path}: no such results file", "check the path")
    if zipfile.is_zipfile(path):
        out = []
        with zipfile.ZipFile(path) as archive:
            for member in archive.namelist():
                if member.endswith("/") or Path(member).name == "submission.json":
                    continue
                out.append(LoadedResult(f"{path}:{member}", _parse(f"{path}:{member}", archive.read(member))))
        return out
    return [LoadedResult(str(path), _parse(str(path), path.read_bytes()))]


def validate_result(result: LoadedResult, registry: Registry) -> None:
    """Check a result's envelope (schema ``results``) and its format instance (the format's ``validate``).

    Raises:
        ResultsError: naming the source and the JSON path of the first problem.
    """
    errors = sorted(validator("results").iter_errors(result.data), key=lambda e: list(map(str, e.absolute_path)))
    if errors:
        raise ResultsError(f"{result.source}: {json_path(errors[0].absolute_path)}: {errors[0].message}", "")
    names = {e["name"] for e in result.data["environment_details"]}
    if len(names) != 1:
        raise ResultsError(f"{result.source}: environment_details name several environments {sorted(names)}", "")
    fmt = result.data["task_details"]["results_format"]
    try:
        functions = registry.functions("formats", fmt)
    except SpecError as exc:
        raise ResultsError(f"{result.source}: task_details.results_format: {exc.message}", exc.hint) from None
    if "validate" in functions:
        try:
            functions["validate"](result.data["results"])
        except ResultsError as exc:
            raise ResultsError(f"{result.source}: results.{exc.message}", exc.hint) from None


@dataclass
class Evaluation:
    """Scores of a set of results.

    Attributes:
        method: the evaluation method's name.
        per_result: ``[(source, scores dict)]`` in input order (``scores`` as returned by the method).
        combined: the method's ``combine`` over the results, padded with ``{}`` for missing required
            environments, or ``None`` when the method has no ``combine``.
        skipped: ``[(source, reason)]`` of results left out (another task, not a required environment).
        missing: required environments without a result.
    """

    method: str
    per_result: list[tuple[str, dict]] = field(default_factory=list)
    combined: dict | None = None
    skipped: list[tuple[str, str]] = field(default_factory=list)
    missing: list[str] = field(default_factory=list)

    def to_json(self) -> dict | list:
        """What the original wrote to ``scores.json``: the combined dict, or the list of per-result dicts."""
        return self.combined if self.combined is not None else [s for _, s in self.per_result]


def evaluate(
    paths: list[Path | str],
    method: str,
    registry: Registry,
    *,
    required_envs: list[str] | None = None,
    required_task: str | None = None,
) -> Evaluation:
    """Validate and score results files (reference §1.4, §7.1).

    Args:
        paths: JSON files and/or zip archives.
        method: evaluation-method name (e.g. ``omq``).
        required_envs: environment strings that must be covered; a missing one counts as an empty result in
            ``combine``.
        required_task: results of any other task are skipped.

    Raises:
        SpecError: unknown method, task or environment; no ground truth for a scene.
        ResultsError: a results file is malformed (naming it and the field), or results name several tasks, or
            the method cannot score a result.
    """
    spec = registry.get("evaluators", method)
    functions = registry.functions("evaluators", method)
    if required_task is not None:
        registry.get("tasks", required_task)
    for env in required_envs or []:
        registry.scenes(env)
    evaluation = Evaluation(method)
    loaded = [r for p in paths for r in load_results(p)]
    if not loaded:
        raise ResultsError("no results to evaluate", "give results files or zip archives")
    for result in loaded:
        validate_result(result, registry)
    tasks = {r.data["task_details"]["name"] for r in loaded}
    if len(tasks) > 1:
        raise ResultsError(f"results name several tasks: {', '.join(sorted(tasks))}", "evaluate one task at a time")
    covered = set()
    for result in loaded:
        task = result.data["task_details"]
        if required_task is not None and task["name"] != required_task:
            evaluation.skipped.append((result.source, f"task {task['name']} is not {required_task}"))
            continue
        if required_envs is not None and result.env_string not in required_envs:
            evaluation.skipped.append((result.source, f"environment {result.env_string} is not required"))
            continue
        if task["results_format"] not in spec["valid_result_formats"]:
            raise ResultsError(
                f"{result.source}: method '{method}' cannot score results of format '{task['results_format']}'",
                f"it scores: {', '.join(spec['valid_result_formats'])}",
            )
        ground_truths = []
        for env in result.data["environment_details"]:
            gt = registry.ground_truth(f"{env['name']}:{env['variant']}")
            if gt["format"]["name"] not in spec["valid_ground_truth_formats"]:
                raise SpecError(f"ground truth of {env['name']}:{env['variant']} has format {gt['format']['name']}", "")
            ground_truths.append(gt)
        try:
            scores = functions["evaluate"](result.data, ground_truths)
        except BenchbotError:
            raise
        except Exception as exc:  # the method's own bug: name the file, keep a one-line message
            raise ResultsError(f"{result.source}: {method} failed: {exc!r}", "report this as a bug in the method") from exc
        evaluation.per_result.append((result.source, scores))
        covered.add(result.env_string)
    evaluation.missing = [e for e in (required_envs or []) if e not in covered]
    if "combine" in functions:
        scores_list = [s for _, s in evaluation.per_result]
        scores_list += [{} for _ in evaluation.missing]
        evaluation.combined = functions["combine"](scores_list)
    return evaluation
