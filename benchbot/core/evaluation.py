"""Loading, validating and scoring results files with an evaluation method (docs/cli.md).

A results file is ``{task_details: {name, results_format, ...}, environment_details: [{name, variant, ...}, ...],
results: <an instance of the results format>}``; a ``.zip`` archive holds such JSON files (``submission.json``
members are skipped, as in the original). Ground truths are found by each scene's ``name:variant``.
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from benchbot.core.errors import BenchbotError, ResultsError, SpecError, UsageError
from benchbot.core.registry import Registry
from benchbot.core.specs import json_path, validator
from benchbot.core.limits import MAX_RESULTS_BYTES
from benchbot.core.safe_load import is_zip_archive, parse_json, path_kind, read_capped, zip_members


@dataclass
class LoadedResult:
    """One results file (or archive member): ``source`` names it, ``data`` is its parsed JSON."""

    source: str
    data: dict

    @property
    def env_string(self) -> str:
        """``name:v1[:v2...]`` of its scenes (docs/plugin-guide.md)."""
        envs = self.data["environment_details"]
        return f"{envs[0]['name']}:" + ":".join(str(e["variant"]) for e in envs)


def _parse(source: str, text: bytes | str) -> dict:
    data = parse_json(source, text, ResultsError)
    if not isinstance(data, dict):
        raise ResultsError(f"{source}: expected a JSON object at the top level", "")
    return data


def load_results(path: Path | str) -> list[LoadedResult]:
    """The results in a JSON file or a ``.zip`` archive of JSON files.

    Raises:
        ResultsError: the file is missing or unreadable, or a member is not valid JSON.
    """
    results, errors = load_all([path])
    if errors:
        raise errors[0][1]
    return results


def validate_result(result: LoadedResult, registry: Registry) -> None:
    """Check a result's envelope (schema ``results``) and its format instance (the format's ``validate``).

    Raises:
        ResultsError: naming the source and the JSON path of the first problem; also when the format's
            ``validate`` fails with anything but a :class:`BenchbotError` (its own bug: one line naming the file),
            so that one bad file never stops the others being validated and scored.
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
        except BenchbotError as exc:
            raise type(exc)(f"{result.source}: {exc.message}", exc.hint) from None
        except Exception as exc:  # the format's own bug (OverflowError, KeyError, ...): this file fails alone
            raise ResultsError(f"{result.source}: results: format '{fmt}' could not validate it: "
                               f"{_one_line(exc)}", "report this as a bug in the format") from exc


def _one_line(exc: BaseException, limit: int = 200) -> str:
    """``repr(exc)`` on one line, at most ``limit`` characters (an exception's text may be long or multi-line)."""
    text = " ".join(repr(exc).split())
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _check_exist(paths: list[Path | str]) -> None:
    """Raise ResultsError for the first path that is not a regular file, saying what it is (checked before
    anything is read, without opening anything: a FIFO is never waited on)."""
    for path in paths:
        kind = path_kind(Path(path))
        if kind == "missing":
            raise ResultsError(f"{path}: no such results file", "check the path")
        if kind == "a folder":
            raise ResultsError(f"{path}: a folder, not a results file",
                               f"give the results files in it (e.g. {Path(path) / '*.json'}) or a .zip of them")
        if kind != "a regular file":
            raise ResultsError(f"{path}: {kind}, not a results file",
                               "give a results JSON file or a .zip archive of them")


PerFileError = tuple[str, BenchbotError]
"""``(source, error)`` of a results file (or archive member) that could not be loaded, validated or scored."""


def _is_submission(member: str) -> bool:
    """Folders and ``submission.json`` members of an archive are not results (as in the original)."""
    return member.endswith("/") or Path(member).name == "submission.json"


def load_all(paths: list[Path | str]) -> tuple[list[LoadedResult], list[PerFileError]]:
    """Load every results file and archive member, collecting per-file errors instead of stopping at the first.

    Every file is read within the limits of :mod:`benchbot.core.limits`: a results file or a member (after
    decompression, counted while reading) at most ``MAX_RESULTS_BYTES`` (``$BENCHBOT_MAX_RESULTS_BYTES``, 64 MiB),
    an archive at most ``MAX_ZIP_BYTES`` on disk and decompressed in all and ``MAX_ZIP_MEMBERS`` entries, nesting at
    most ``MAX_NESTING_DEPTH`` levels, integers within Python's digit limit. A file's size is checked before it is
    read, and members are read and parsed one at a time, so memory stays bounded by one member.

    Returns:
        ``(results, errors)``: the parsed results in input order, and ``(source, ResultsError)`` for each file or
        archive member that cannot be read, is beyond a limit, is not valid JSON or not a JSON object (``source``
        is ``path`` or ``path:member``; a whole archive is refused when it breaks an archive limit, is damaged,
        or is named ``.zip`` without being a zip archive).

    Raises:
        ResultsError: a path does not exist or is not a regular file (a folder, a FIFO, a device: said which;
            checked for every path before anything is read, as the original's pre-checks).
        UsageError: a limit's environment variable is not a positive number.
    """
    _check_exist(paths)
    results: list[LoadedResult] = []
    errors: list[PerFileError] = []
    for path in map(Path, paths):
        file_results: list[LoadedResult] = []
        file_errors: list[PerFileError] = []
        try:
            if is_zip_archive(path, ResultsError):
                for member, data in zip_members(path, ResultsError, skip=_is_submission):
                    source = f"{path}:{member}"
                    try:
                        file_results.append(LoadedResult(source, _parse(source, data)))
                    except ResultsError as exc:
                        file_errors.append((source, exc))
            else:
                data = read_capped(path, MAX_RESULTS_BYTES, ResultsError, "the results file")
                file_results.append(LoadedResult(str(path), _parse(str(path), data)))
        except ResultsError as exc:  # the whole file or archive is refused
            file_results, file_errors = [], [(str(path), exc)]
        results += file_results
        errors += file_errors
    return results, errors


def validate_all(
    paths: list[Path | str], registry: Registry
) -> tuple[list[LoadedResult], list[PerFileError]]:
    """:func:`load_all`, then :func:`validate_result` on each: ``(valid results, per-file errors)``.

    Raises:
        ResultsError: a path does not exist.
    """
    _check_exist(paths)
    valid: list[LoadedResult] = []
    errors: list[PerFileError] = []
    for path in paths:
        loaded, load_errors = load_all([path])
        errors += load_errors
        for result in loaded:
            try:
                validate_result(result, registry)
                valid.append(result)
            except BenchbotError as exc:
                errors.append((result.source, exc))
    return valid, errors


@dataclass
class Evaluation:
    """Scores of a set of results.

    Attributes:
        method: the evaluation method's name.
        per_result: ``[(source, scores dict)]`` in input order (``scores`` as returned by the method).
        combined: the method's ``combine`` over the results, padded for missing required environments, or
            ``None`` when the method has no ``combine``.
        skipped: ``[(source, reason)]`` of results left out (another task, not a required environment).
        missing: required environments without a (valid) result.
        errors: ``[(source, error)]`` of files that could not be loaded, validated or scored (only filled with
            ``keep_going=True``; otherwise the first one is raised).
        combine_mode: ``"mean"`` or ``"pooled"``.
        score_set: what the method's scores are (:class:`ScoreSet`): its declaration, else guessed from the scores
            it returned (:func:`observed_scores`); None before anything was scored.
    """

    method: str
    per_result: list[tuple[str, dict]] = field(default_factory=list)
    combined: dict | None = None
    skipped: list[tuple[str, str]] = field(default_factory=list)
    missing: list[str] = field(default_factory=list)
    errors: list[PerFileError] = field(default_factory=list)
    combine_mode: str = "mean"
    score_set: "ScoreSet | None" = None

    def to_json(self) -> dict | list:
        """What the original wrote to ``scores.json``: the combined dict, or the list of per-result dicts."""
        return self.combined if self.combined is not None else [s for _, s in self.per_result]


COMBINE_MODES = ("mean", "pooled")


# --------------------------------------------------------------------------------------------------------------------
# What a method's scores are: its declaration (the evaluator spec's ``scores``), read by every view
# --------------------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ScoreInfo:
    """One score an evaluation method returns under ``scores`` (docs/evaluation.md, "Declaring scores").

    Attributes:
        name: its key in the method's ``scores`` dict.
        direction: ``"higher"`` or ``"lower"`` is better.
        range: ``(low, high)`` of its values; None where unbounded or unknown.
        kind: ``"score"`` (a real number) or ``"count"`` (an integer count, printed without decimals).
        short: a short heading for narrow tables ("" : the name).
        description: what it measures, in a sentence.
        primary: the score that ranks, compares and summarises (one per method).
    """

    name: str
    direction: str = "higher"
    range: tuple[float | None, float | None] = (None, None)
    kind: str = "score"
    short: str = ""
    description: str = ""
    primary: bool = False

    @property
    def heading(self) -> str:
        """The short heading, else the name."""
        return self.short or self.name

    def to_json(self) -> dict:
        """As the spec writes it."""
        return {"name": self.name, "direction": self.direction, "range": list(self.range), "kind": self.kind,
                "short": self.short, "description": self.description, "primary": self.primary}


@dataclass(frozen=True)
class ScoreSet:
    """The scores of an evaluation method, in the order views show them, with the primary one first-class.

    Attributes:
        method: the method's name ("" when unknown).
        items: one :class:`ScoreInfo` per score, the primary one among them.
        declared: whether the method declared them (False: guessed from scores seen, see :func:`observed_scores`).
    """

    method: str
    items: tuple[ScoreInfo, ...]
    declared: bool = True

    @property
    def primary(self) -> ScoreInfo:
        """The primary score (the first item when none is marked)."""
        return next((s for s in self.items if s.primary), self.items[0])

    @property
    def names(self) -> list[str]:
        """Every score's name, in order (counts included)."""
        return [s.name for s in self.items]

    @property
    def scores(self) -> list[str]:
        """The names of the real-valued scores (not counts), primary first."""
        rest = [s.name for s in self.items if s.kind == "score" and not s.primary]
        return [self.primary.name] + rest if self.primary.kind == "score" else rest

    @property
    def counts(self) -> list[str]:
        """The names of the integer counts."""
        return [s.name for s in self.items if s.kind == "count"]

    def get(self, name: str) -> ScoreInfo | None:
        """The :class:`ScoreInfo` of ``name``, or None."""
        return next((s for s in self.items if s.name == name), None)

    def sign(self, name: str | None = None) -> int:
        """+1 when higher values of ``name`` (default: the primary score) are better, −1 when lower are."""
        info = self.get(name) if name else self.primary
        return -1 if info is not None and info.direction == "lower" else 1

    def to_json(self) -> dict:
        """``{"method", "declared", "scores": [ScoreInfo dicts]}``: what a batch's manifest records."""
        return {"method": self.method, "declared": self.declared, "scores": [s.to_json() for s in self.items]}

    @classmethod
    def from_json(cls, data: dict) -> "ScoreSet":
        """The inverse of :meth:`to_json` (also takes an evaluator spec: ``{"name", "scores": [...]}``).

        Raises:
            ValueError: ``data`` has no non-empty ``scores`` list of entries with a ``name``, or an entry's
                ``range`` is not ``[low, high]`` (numbers or null).
        """
        entries = data.get("scores") if isinstance(data, dict) else None
        if not isinstance(entries, list) or not entries or not all(isinstance(e, dict) and e.get("name")
                                                                   for e in entries):
            raise ValueError("no 'scores' list of {name, ...} entries")
        items = []
        for e in entries:
            try:
                low, high = (list(e.get("range") or [None, None]) + [None, None])[:2]
                bounds = (None if low is None else float(low), None if high is None else float(high))
            except (TypeError, ValueError):
                raise ValueError(f"score '{e['name']}': range {e.get('range')!r} is not [low, high]") from None
            items.append(ScoreInfo(str(e["name"]), str(e.get("direction", "higher")), bounds,
                                   str(e.get("kind", "score")), str(e.get("short", "")), str(e.get("description", "")),
                                   bool(e.get("primary", False))))
        return cls(str(data.get("method", data.get("name", ""))), tuple(items), bool(data.get("declared", True)))


def observed_scores(method: str, entries: list[dict]) -> ScoreSet:
    """A :class:`ScoreSet` for a method that declares none (an older third-party evaluator), from the scores it
    returned: every numeric key of ``entries`` (each a method's ``scores`` dict) in first-seen order, integers seen
    only as whole numbers counted as counts, the first real-valued one primary, every one "higher is better"
    (``declared`` False, so views can say the direction is assumed).

    Raises:
        ValueError: no entry has a numeric score.
    """
    seen: dict[str, bool] = {}  # name -> every value an integer
    for entry in entries:
        for k, v in (entry or {}).items():
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                seen[k] = seen.get(k, True) and isinstance(v, int)
    if not seen:
        raise ValueError(f"no numeric scores from method '{method}'")
    kinds = {k: "count" if whole else "score" for k, whole in seen.items()}
    primary = next((k for k, kind in kinds.items() if kind == "score"), next(iter(kinds)))
    return ScoreSet(method, tuple(ScoreInfo(k, kind=kinds[k], primary=k == primary) for k in kinds), declared=False)


def method_scores(registry: Registry, method: str) -> ScoreSet | None:
    """The :class:`ScoreSet` the evaluation method ``method`` declares in its spec's ``scores``; None when it
    declares none (then :func:`observed_scores` stands in).

    Raises:
        SpecError: no method of that name.
    """
    spec = registry.get("evaluators", method)
    if not spec.get("scores"):
        return None
    return ScoreSet.from_json({"method": method, "scores": spec["scores"]})


def _accepts(fn: Callable, name: str) -> bool:
    """Whether ``fn`` takes a keyword argument ``name`` (by name, or through ``**kwargs``)."""
    try:
        params = inspect.signature(fn).parameters
    except (TypeError, ValueError):
        return False
    return name in params or any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())


@dataclass
class _Scoring:
    """An evaluation method ready to score results: its spec and functions, the keyword arguments its ``evaluate``
    is given, the set of ground truths asked for (None: each environment's default) and how results combine."""

    method: str
    registry: Registry
    spec: dict
    functions: dict
    kwargs: dict
    ground_truth_set: str | None
    combine: str

    @classmethod
    def of(cls, method: str, registry: Registry, combine: str, options: dict[str, Any] | None,
           ground_truth_set: str | None) -> "_Scoring":
        """Check the method, its options and the combine mode (:func:`evaluate`'s arguments).

        Raises:
            UsageError: unknown combine mode, or the method does not support an option or that combine mode.
            SpecError: no method of that name, or one without an ``evaluate`` function.
        """
        if combine not in COMBINE_MODES:
            raise UsageError(f"unknown combine mode '{combine}'", f"use one of: {', '.join(COMBINE_MODES)}")
        spec = registry.get("evaluators", method)
        functions = registry.functions("evaluators", method)
        if "evaluate" not in functions:
            raise SpecError(f"evaluator '{method}': has no 'evaluate' function", "check its spec's functions")
        kwargs = {k: v for k, v in (options or {}).items() if v}
        for name in kwargs:
            if not _accepts(functions["evaluate"], name):
                raise UsageError(f"evaluation method '{method}' does not support the option '{name}'", "")
        if combine != "mean" and "combine" in functions and not _accepts(functions["combine"], "mode"):
            raise UsageError(f"evaluation method '{method}' has no '{combine}' combine mode", "use --combine mean")
        return cls(method, registry, spec, functions, kwargs, ground_truth_set, combine)

    def score(self, result: LoadedResult, own_env: str | None) -> dict:
        """The method's scores of one valid result, against the ground truth of ``own_env`` (the environment the
        results are of, when known) else of the scenes its ``environment_details`` name; a dict of scores says the
        set of ground truths it was scored against (``ground_truth_set``).

        Raises:
            ResultsError: the results are not of ``own_env``, of a format the method cannot score, or the method
                fails on them (one line naming the file).
            SpecError: a scene has no ground truth (in the set asked for).
        """
        task = result.data["task_details"]
        if own_env is not None and result.env_string != own_env:
            raise ResultsError(
                f"{result.source}: environment_details name {result.env_string}, but these are the results of "
                f"an episode on {own_env}", "a solution writes the results of the environment it ran in")
        scenes = result.data["environment_details"] if own_env is None else self.registry.scenes(own_env)
        if task["results_format"] not in self.spec["valid_result_formats"]:
            raise ResultsError(
                f"{result.source}: method '{self.method}' cannot score results of format '{task['results_format']}'",
                f"it scores: {', '.join(self.spec['valid_result_formats'])}",
            )
        ground_truths, used_set = _ground_truths(result.source, scenes, self.spec, self.registry,
                                                 self.ground_truth_set)
        try:
            scores = self.functions["evaluate"](result.data, ground_truths, **self.kwargs)
        except BenchbotError as exc:
            raise type(exc)(f"{result.source}: {exc.message}", exc.hint) from None
        except Exception as exc:  # the method's own bug: name the file, keep a one-line message
            raise ResultsError(
                f"{result.source}: {self.method} failed: {_one_line(exc)}", "report this as a bug in the method"
            ) from exc
        return {**scores, "ground_truth_set": used_set} if isinstance(scores, dict) else scores


def evaluate(
    paths: list[Path | str],
    method: str,
    registry: Registry,
    *,
    required_envs: list[str] | None = None,
    required_task: str | None = None,
    combine: str = "mean",
    options: dict[str, Any] | None = None,
    keep_going: bool = False,
    environments: dict[str, str] | None = None,
    ground_truth_set: str | None = None,
    loaded: dict[str, list[LoadedResult]] | None = None,
    early: "EarlyScores | None" = None,
) -> Evaluation:
    """Validate and score results files (docs/cli.md).

    Args:
        paths: JSON files and/or zip archives.
        method: evaluation-method name (e.g. ``omq``).
        required_envs: environment strings that must be covered; a missing one counts as an empty result in
            ``combine`` (``{}`` for ``mean``, as the original; for ``pooled``, the method's evaluation of an
            empty map, so that the environment's ground-truth objects count as FN).
        required_task: results of any other task are skipped.
        combine: ``"mean"`` (the original: mean of each score over the results) or ``"pooled"`` (the method's
            ``combine(..., mode="pooled")``: counts and sums pooled over the results before dividing).
        options: extra keyword arguments for the method's ``evaluate`` (e.g. ``{"per_class": True,
            "oriented": True}`` for OMQ); false values are not passed.
        keep_going: collect per-file problems (bad JSON, validation errors, no ground truth, the method refusing
            a file) in ``Evaluation.errors`` and score the other files, instead of raising the first one.
        environments: ``{str(path): environment string}``: the environment each file's results are *of* (a batch's
            episode, from its plan). Such a file is scored against that environment's ground truth whatever its
            ``environment_details`` say, and results naming another environment are an error naming both.
        ground_truth_set: score against this set of ground truths (``bear_develop``:
            :meth:`~benchbot.core.registry.Registry.ground_truth_sets`) instead of each environment's default. Every
            per-result score dict says the set it was scored against (``ground_truth_set``), and so does the combined
            one (the sets used, comma-separated).
        loaded: ``{str(path): its results}`` for paths already read with :func:`load_results` (a batch reads each
            episode's results file once, when the episode ends): they are validated and scored without being read
            again; every other path is read here.
        early: results of ``loaded`` already validated and scored (:class:`EarlyScores`: a batch scores each
            episode's results as its record arrives): their outcomes are taken as they are (the same scores, the
            same errors, in the same order) and only the others are validated and scored here. Ignored unless it
            scores as this call does (same method, registry, options and set of ground truths).

    Raises:
        UsageError: unknown combine mode, or the method does not support an option or pooled combining.
        SpecError: unknown method, task or environment; (without ``keep_going``) no ground truth for a scene.
        ResultsError: a results file does not exist; results name several tasks (without ``required_task``: with
            it, results of other tasks are skipped); (without ``keep_going``) a results file is malformed (naming
            it and the field), is not of its environment in ``environments``, or the method cannot score it.
    """
    scoring = _Scoring.of(method, registry, combine, options, ground_truth_set)
    if required_task is not None:
        registry.get("tasks", required_task)
    for env in required_envs or []:
        registry.scenes(env)
    evaluation = Evaluation(method, combine_mode=combine)

    def fail(source: str, exc: BenchbotError) -> None:
        if not keep_going:
            raise exc
        evaluation.errors.append((source, exc))

    results, order = _read_in_order(paths, loaded or {}, fail)
    if early is not None and not early.scores_as(scoring):
        early = None
    valid = _validated(results, early.validate if early else lambda r: validate_result(r, registry), fail)
    own_env = {r.source: environments.get(str(paths[order[r.source]])) for r in valid} if environments else {}
    covered, task_details = _score_each(valid, early.score if early else scoring.score, evaluation, fail,
                                        required_task, required_envs, own_env)
    evaluation.errors.sort(key=lambda e: order.get(e[0], len(paths)))
    evaluation.score_set = ScoreSet.from_json({"method": method, "scores": scoring.spec["scores"]}) \
        if scoring.spec.get("scores") else _observed_or_none(method, [s.get("scores") or {}
                                                                      for _, s in evaluation.per_result])
    evaluation.missing = [e for e in (required_envs or []) if e not in covered]
    if "combine" in scoring.functions:
        if task_details is None and required_task is not None and combine != "mean":
            task_details = registry.get("tasks", required_task)
        evaluation.combined = _combined(evaluation, scoring, task_details)
    if isinstance(evaluation.combined, dict):
        used = sorted({s.get("ground_truth_set") for _, s in evaluation.per_result if isinstance(s, dict)} - {None})
        evaluation.combined["ground_truth_set"] = ", ".join(used) if used else None
    return evaluation


class EarlyScores:
    """Results validated and scored ahead of :func:`evaluate`, one file at a time: a batch scores each episode's
    results as its record arrives, while other episodes still run, and its evaluation at the end then only combines
    (``evaluate(..., early=...)``). Each outcome is what :func:`evaluate` would compute for that result (the same
    :func:`validate_result`, the same method, options and set of ground truths, against the same environment), the
    scores or the error alike, so the scores are identical whichever path computed them.

    An outcome belongs to the very :class:`LoadedResult` object it was computed for: a results file read again (an
    episode run again) has new objects, and its old outcomes are never used. A failure that is not a
    :class:`~benchbot.core.errors.BenchbotError` (a bug) is not kept: :func:`evaluate` meets it again and raises it
    as it would have.

    Args:
        method, registry, options, ground_truth_set: as :func:`evaluate`'s (the combine mode plays no part).
        required_task: results of another task are not scored (:func:`evaluate` skips them).

    Raises:
        UsageError, SpecError: as :func:`evaluate` for an unknown method or an option it does not take.
    """

    def __init__(self, method: str, registry: Registry, *, required_task: str | None = None,
                 options: dict[str, Any] | None = None, ground_truth_set: str | None = None) -> None:
        self.scoring = _Scoring.of(method, registry, "mean", options, ground_truth_set)
        self.required_task = required_task
        self._validation: dict[str, tuple[LoadedResult, BenchbotError | None]] = {}  # source -> (result, error)
        self._scores: dict[tuple[str, str | None], tuple[LoadedResult, dict | BenchbotError]] = {}

    def add(self, results: list[LoadedResult], env: str | None) -> int:
        """Validate and score ``results`` (one file's, :func:`load_results`) as the results of environment ``env``
        (None: of the scenes they name). Returns how many were scored (or refused by the method)."""
        scored = 0
        for result in results:
            try:
                validate_result(result, self.scoring.registry)
                self._validation[result.source] = (result, None)
            except BenchbotError as exc:
                self._validation[result.source] = (result, exc)
                continue
            except Exception:  # noqa: BLE001 - a bug: evaluate raises it, as without early scores
                continue
            if self.required_task is not None and result.data["task_details"]["name"] != self.required_task:
                continue
            try:
                self._scores[(result.source, env)] = (result, self.scoring.score(result, env))
            except BenchbotError as exc:
                self._scores[(result.source, env)] = (result, exc)
            except Exception:  # noqa: BLE001 - as above
                continue
            scored += 1
        return scored

    def scores_as(self, scoring: "_Scoring") -> bool:
        """Whether these outcomes are what ``scoring`` computes (same method, registry, options, ground truths)."""
        mine = self.scoring
        return (mine.method, mine.kwargs, mine.ground_truth_set) == (scoring.method, scoring.kwargs,
                                                                     scoring.ground_truth_set) \
            and mine.registry is scoring.registry

    def validate(self, result: LoadedResult) -> None:
        """:func:`validate_result` of ``result``: its outcome kept by :meth:`add`, else validated now.

        Raises:
            BenchbotError: as :func:`validate_result`.
        """
        kept = self._validation.get(result.source)
        if kept is None or kept[0] is not result:
            return validate_result(result, self.scoring.registry)
        if kept[1] is not None:
            raise kept[1]

    def score(self, result: LoadedResult, own_env: str | None) -> dict:
        """The method's scores of ``result`` against ``own_env`` (:meth:`_Scoring.score`): those kept by
        :meth:`add`, else scored now.

        Raises:
            BenchbotError: as :meth:`_Scoring.score`.
        """
        kept = self._scores.get((result.source, own_env))
        if kept is None or kept[0] is not result:
            return self.scoring.score(result, own_env)
        if isinstance(kept[1], BenchbotError):
            raise kept[1]
        return kept[1]


def _read_in_order(paths: list[Path | str], loaded: dict[str, list[LoadedResult]],
                   fail: Callable[[str, BenchbotError], None]) -> tuple[list[LoadedResult], dict[str, int]]:
    """Every path's results, in order: those of ``loaded`` as they are, the others read (:func:`load_all`), each
    file or member that cannot be read given to ``fail``. Returns ``(results, {source: index of its path})``.

    Raises:
        ResultsError: a path does not exist or is not a regular file (checked for all before anything is read), or
            there are no results and nothing failed.
    """
    _check_exist(paths)  # before anything is read
    order: dict[str, int] = {}  # source -> index of its path (errors are reported in input order)
    results: list[LoadedResult] = []
    failed = False
    for index, path in enumerate(paths):
        ready = loaded.get(str(path))
        found, load_errors = (ready, []) if ready is not None else load_all([path])
        order.update({r.source: index for r in found})
        order.update({source: index for source, _ in load_errors})
        for source, exc in load_errors:
            failed = True
            fail(source, exc)
        results += found
    if not results and not failed:
        raise ResultsError("no results to evaluate", "give results files or zip archives")
    return results, order


def _validated(results: list[LoadedResult], validate: Callable[[LoadedResult], None],
               fail: Callable[[str, BenchbotError], None]) -> list[LoadedResult]:
    """The results that pass ``validate`` (:func:`validate_result` or :meth:`EarlyScores.validate`); each one that
    does not is given to ``fail``."""
    valid = []
    for result in results:
        try:
            validate(result)
            valid.append(result)
        except BenchbotError as exc:
            fail(result.source, exc)
    return valid


def _score_each(valid: list[LoadedResult], score: Callable[[LoadedResult, str | None], dict],
                evaluation: Evaluation, fail: Callable[[str, BenchbotError], None], required_task: str | None,
                required_envs: list[str] | None, own_env: dict[str, str | None]) -> tuple[set[str], dict | None]:
    """Score every valid result of the task (``score``: :meth:`_Scoring.score` or :meth:`EarlyScores.score`) into
    ``evaluation.per_result``; results of
    another task, or (without an environment of their own in ``own_env``) of an environment not required, into
    ``evaluation.skipped``; a result the method cannot score is given to ``fail``. Returns ``(the environments
    covered, the first scored result's task details or None)``.

    Raises:
        ResultsError: the results name several tasks and no ``required_task`` was given.
    """
    tasks = {r.data["task_details"]["name"] for r in valid}
    if len(tasks) > 1 and required_task is None:
        raise ResultsError(f"results name several tasks: {', '.join(sorted(tasks))}", "evaluate one task at a time")
    covered: set[str] = set()
    task_details = None
    for result in valid:
        task = result.data["task_details"]
        env = own_env.get(result.source)
        if required_task is not None and task["name"] != required_task:
            evaluation.skipped.append((result.source, f"task {task['name']} is not {required_task}"))
            continue
        if env is None and required_envs is not None and result.env_string not in required_envs:
            evaluation.skipped.append((result.source, f"environment {result.env_string} is not required"))
            continue
        try:
            scores = score(result, env)
        except BenchbotError as exc:
            fail(result.source, exc)
            continue
        evaluation.per_result.append((result.source, scores))
        covered.add(result.env_string)
        task_details = task_details or task
    return covered, task_details


def _combined(evaluation: Evaluation, scoring: _Scoring, task_details: dict | None):
    """The method's ``combine`` over the scored results, each missing required environment padded (``{}`` for
    ``mean``; for ``pooled``, the method's scores of an empty map of it, :func:`_empty_evaluation`)."""
    combine = scoring.functions["combine"]
    scores_list = [s for _, s in evaluation.per_result]
    if scoring.combine == "mean":
        return combine(scores_list + [{} for _ in evaluation.missing])
    for env in evaluation.missing:
        scores_list.append(_empty_evaluation(env, task_details, scoring.spec, scoring.functions, scoring.registry,
                                             scoring.kwargs))
    return combine(scores_list, mode=scoring.combine)


def _observed_or_none(method: str, entries: list[dict]) -> ScoreSet | None:
    try:
        return observed_scores(method, entries)
    except ValueError:
        return None


def _ground_truths(source: str, environment_details: list[dict], spec: dict, registry: Registry,
                   ground_truth_set: str | None = None) -> tuple[list[dict], str]:
    """The ground truths of a result's scenes (of ``ground_truth_set``, else each one's default) and the name of
    the set(s) they come from (comma-separated when the scenes' defaults differ).

    Raises:
        SpecError: a scene has no ground truth (in that set), or one of a format the method cannot read.
    """
    ground_truths, sets = [], []
    for env in environment_details:
        name = f"{env['name']}:{env['variant']}"
        if not registry.has("ground_truths", name):
            raise SpecError(f"{source}: no ground truth for environment {name}", "see `benchbot list environments`")
        gt = registry.ground_truth(name, ground_truth_set)
        if gt["format"]["name"] not in spec["valid_ground_truth_formats"]:
            raise SpecError(f"{source}: the ground truth of {name} has format {gt['format']['name']}", "")
        ground_truths.append(gt)
        chosen = registry.ground_truth_set(name) if ground_truth_set is None else ground_truth_set
        sets.append(chosen.removeprefix("ground_truths_"))
    return ground_truths, ", ".join(dict.fromkeys(sets))


def _empty_evaluation(
    env: str, task_details: dict | None, spec: dict, functions: dict, registry: Registry, kwargs: dict
) -> dict:
    """The method's scores of an empty map for ``env`` (pooled combine of a missing environment); ``{}`` when it
    cannot be made (no task known, no ground truth)."""
    if task_details is None:
        return {}
    try:
        scenes = registry.scenes(env)
        gts, _ = _ground_truths(env, scenes, spec, registry)
        inner: dict[str, Any] = {"objects": [], "class_list": list(gts[0]["ground_truth"].get("class_list") or [])}
        if task_details.get("results_format") == "object_map_with_states":
            inner["state_list"] = ["added", "removed", "unchanged"]
        empty = {"task_details": task_details, "environment_details": scenes, "results": inner}
        return functions["evaluate"](empty, gts, **kwargs)
    except Exception:  # noqa: BLE001 - padding must never hide the real scores
        return {}
