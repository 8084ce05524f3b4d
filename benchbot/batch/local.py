"""Sequential batches on this machine: one episode per environment string, each with its own backend server on a
free loopback port, the submission as a child process, then evaluation (reference §8, without Docker).

A run directory holds::

    config.json        the resolved task, robot and environments
    manifest.json      versions, seed, command, timings and the status of every episode
    results/NN_<env>.json   the submission's results per episode
    logs/NN_<env>.log       the submission's output per episode
    scores.json        the evaluation (the original's format: the combined scores)

Every file is written atomically.
"""

from __future__ import annotations

import importlib.metadata as md
import platform
import re
import sys
import time
from dataclasses import asdict, dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import Callable

from benchbot.core import atomic
from benchbot.core.errors import UsageError
from benchbot.core.evaluation import Evaluation, evaluate
from benchbot.core.registry import Registry
from benchbot.core.server import ServerThread, build_app
from benchbot.core.session import RunSpec, resolve_run, start_service
from benchbot.core.submission import Submission, run_submission


@dataclass
class EpisodeRecord:
    """One episode of a batch.

    Attributes:
        index: its position (0-based, as the original numbered its files).
        env: the environment string. status: ``ok``, ``failed`` or ``no_results``.
        steps: actions performed. collided: the robot collided. wall_s: seconds.
        returncode: the submission's exit status. results, log: paths relative to the run directory.
    """

    index: int
    env: str
    status: str = "pending"
    steps: int = 0
    collided: bool = False
    wall_s: float = 0.0
    returncode: int | None = None
    results: str = ""
    log: str = ""


@dataclass
class BatchOutcome:
    """What a batch produced: its run directory, episodes and evaluation (None when not evaluated)."""

    run_dir: Path
    episodes: list[EpisodeRecord] = field(default_factory=list)
    evaluation: Evaluation | None = None

    @property
    def ok(self) -> bool:
        """Every episode produced results."""
        return all(e.status == "ok" for e in self.episodes)


def default_evaluator(registry: Registry, run: RunSpec) -> str | None:
    """The evaluation method used when none is named: the first one (by name) scoring the task's results format,
    provided every scene has a ground truth; otherwise None."""
    fmt = run.task.get("results_format")
    if not fmt:
        return None
    if any(f"{e['name']}:{e['variant']}" not in registry.entries["ground_truths"] for e in run.environments):
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


def _slug(env: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", env)


def _versions(registry: Registry) -> dict:
    out = {"python": platform.python_version(), "platform": platform.platform()}
    for dist in ["benchbot"] + sorted({p.distribution for p in registry.plugins if p.distribution}):
        try:
            out[dist] = md.version(dist)
        except md.PackageNotFoundError:
            pass
    return out


def run_batch(
    registry: Registry,
    *,
    task: str,
    robot: str,
    envs: list[str],
    submission: Submission,
    run_dir: Path,
    evaluate_with: str | None = "auto",
    seed: int = 0,
    options: dict | None = None,
    on_episode_start: Callable[[EpisodeRecord, RunSpec], None] | None = None,
    on_step: Callable[[dict], None] | None = None,
    on_episode_end: Callable[[EpisodeRecord], None] | None = None,
    episode_timeout_s: float | None = None,
) -> BatchOutcome:
    """Run ``submission`` on every environment string in ``envs``, then evaluate.

    Args:
        evaluate_with: a method name, ``"auto"`` (see :func:`default_evaluator`) or None (no evaluation).
        options: robot-backend options (e.g. ``{'arch': 'cpu'}``).
        on_episode_start / on_step / on_episode_end: progress callbacks.

    Raises:
        SpecError: a combination is invalid (checked for every environment before anything runs), or the named
            method does not exist.
    """
    runs = [resolve_run(registry, task, robot, env) for env in envs]
    if evaluate_with == "auto":
        evaluate_with = default_evaluator(registry, runs[0]) if runs else None
    elif evaluate_with is not None:
        registry.get("evaluators", evaluate_with)
    run_dir = run_dir.resolve()  # the submission runs in its own folder
    outcome = BatchOutcome(run_dir)
    atomic.write_json(run_dir / "config.json", {
        "task": runs[0].task, "robot": runs[0].robot,
        "environments": {r.env_string: r.environments for r in runs},
    })
    started = time.time()
    manifest = {
        "command": sys.argv, "task": task, "robot": robot, "environments": envs, "seed": seed,
        "submission": {"argv": submission.argv, "cwd": str(submission.cwd)}, "evaluate_with": evaluate_with,
        "versions": _versions(registry), "started": datetime.now(timezone.utc).isoformat(),
    }
    for index, run in enumerate(runs):
        record = EpisodeRecord(index, run.env_string)
        record.results = f"results/{index:02d}_{_slug(run.env_string)}.json"
        record.log = f"logs/{index:02d}_{_slug(run.env_string)}.log"
        outcome.episodes.append(record)
        if on_episode_start is not None:
            on_episode_start(record, run)
        t0 = time.monotonic()
        service = start_service(registry, run, seed=seed + index, options=options, on_step=on_step)
        server = ServerThread(build_app(service)).start()
        try:
            (run_dir / "logs").mkdir(exist_ok=True)
            (run_dir / "results").mkdir(exist_ok=True)
            with open(run_dir / record.log, "w") as log:
                record.returncode = run_submission(
                    submission, address=server.address, result_location=run_dir / record.results,
                    log=log, timeout_s=episode_timeout_s,
                )
            state = service.call(service.episode.state)
            record.steps, record.collided = state["step"], state["is_collided"]
        finally:
            server.stop()
            service.close()
        record.wall_s = round(time.monotonic() - t0, 3)
        if record.returncode != 0:
            record.status = "failed"
        elif not (run_dir / record.results).is_file():
            record.status = "no_results"
        else:
            record.status = "ok"
        manifest["episodes"] = [asdict(e) for e in outcome.episodes]
        atomic.write_json(run_dir / "manifest.json", manifest)
        if on_episode_end is not None:
            on_episode_end(record)
    if evaluate_with is not None:
        done = [run_dir / e.results for e in outcome.episodes if e.status == "ok"]
        if done:
            outcome.evaluation = evaluate(done, evaluate_with, registry, required_envs=envs, required_task=task)
            atomic.write_json(run_dir / "scores.json", outcome.evaluation.to_json())
    manifest["episodes"] = [asdict(e) for e in outcome.episodes]
    manifest["wall_s"] = round(time.time() - started, 3)
    atomic.write_json(run_dir / "manifest.json", manifest)
    return outcome


def parse_env_list(envs: str | None, envs_batch: str | None, registry: Registry) -> list[str]:
    """The environment strings of ``--envs a,b`` xor ``--envs-batch NAME``.

    Raises:
        UsageError: both or neither given. SpecError: an unknown batch.
    """
    if bool(envs) == bool(envs_batch):
        raise UsageError("give exactly one of --envs and --envs-batch", "e.g. --envs miniroom:1,house:1")
    if envs_batch:
        return list(registry.get("batches", envs_batch)["environments"])
    return [e.strip() for e in envs.split(",") if e.strip()]
