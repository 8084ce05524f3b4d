"""What ``benchbot batch`` is asked to do, checked and planned before anything runs: a new batch
(:class:`BatchRequest`, :func:`new_batch`: the solution, its isolation, the episodes and a fresh run directory with
its config and manifest) or one to resume (:func:`resume_batch`). Every mistake is a one-line
:class:`~benchbot.core.errors.UsageError` naming the flag, raised before a backend starts; a run directory is left
behind only for a batch that was planned.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from benchbot.batch.plan import plan_episodes
from benchbot.batch.runner import Batch, load_batch, new_run_dir, parse_env_list, prepare_batch
from benchbot.batch.sweep import Sweep, parse_sweep, plan_sweep
from benchbot.core.errors import UsageError
from benchbot.core.noise import get_preset
from benchbot.core.registry import Registry
from benchbot.solutions.container_engine import container_engine, container_files
from benchbot.solutions.sandbox import check_available, check_sandboxable
from benchbot.solutions.submission import (Submission, check_native_files, example_submission,
                                           native_submission)


@dataclass
class BatchRequest:
    """A new batch as ``benchbot batch`` was asked for it (its flags; docs/cli.md).

    Attributes:
        task, robot: ``--task``, ``--robot``. robots: ``--robots`` (a comma list) or None.
        envs, envs_batch: ``--envs`` (a comma list) and ``--envs-batch`` (exactly one of them).
        native, example, containerised: the solution (exactly one of them); example_containerised: the example in
            a container; args: appended to its command.
        repeat, seed, timeout_s, record, noise, sweep: the plan's ``--repeat``, ``--seed``, ``--episode-timeout``,
            ``--record``, ``--noise`` and ``--sweep`` (as typed).
        backend_options: the backends' options (``--arch``, ``--camera-size``), made (and checked) when the
            episodes are planned.
        no_sandbox: native solutions run as plain processes. workers: episodes at once (procedural homes are made
            that many at a time).
        prefix, output_dir, zip_results: the run directory's name prefix and folder, ``--zip``.
        evaluate_with: the evaluation method (``auto``), None for ``--no-evaluate``. ground_truths: the set of
            ground truths, None for each environment's default.
    """

    task: str
    robot: str
    robots: str | None
    envs: str | None
    envs_batch: str | None
    native: str | None
    example: str | None
    containerised: Path | None
    example_containerised: bool
    args: str
    repeat: int
    seed: int
    timeout_s: float | None
    record: bool
    noise: str | None
    sweep: str | None
    backend_options: Callable[[], dict]
    no_sandbox: bool
    workers: int
    prefix: str
    output_dir: Path
    zip_results: bool
    evaluate_with: str | None
    ground_truths: str | None

    @property
    def isolation(self) -> str:
        """How its solutions run: ``container``, ``none`` (``--no-sandbox``) or ``bwrap``."""
        if self.containerised is not None or self.example_containerised:
            return "container"
        return "none" if self.no_sandbox else "bwrap"

    def check(self) -> Sweep | None:
        """Check the flags that need nothing installed; returns the parsed ``--sweep`` (None without).

        Raises:
            UsageError: not exactly one solution; ``--example-containerised`` without ``--example``; a prefix that
                is not a plain name; an unknown noise preset or a malformed sweep; a sweep over what another flag
                sets.
        """
        modes = [m for m, on in (("--native", self.native), ("--example", self.example),
                                 ("--containerised", self.containerised)) if on]
        if len(modes) != 1:
            raise UsageError("give exactly one of --native COMMAND, --example NAME and --containerised DIR",
                             "e.g. --example semslam_geometric")
        if self.example_containerised and not self.example:
            raise UsageError("--example-containerised needs --example NAME", "")
        if not self.prefix or any(c in self.prefix for c in "/\\") or self.prefix in (".", ".."):
            raise UsageError(f"--prefix '{self.prefix}' is not a name", "give a plain name, e.g. --prefix ablation")
        if self.noise is not None:
            get_preset(self.noise, flag="--noise")
        sweep = parse_sweep(self.sweep) if self.sweep is not None else None
        if sweep and sweep.factor == "noise" and self.noise is not None:
            raise UsageError("--noise and --sweep noise=... both set the noise", "give one of them")
        if sweep and sweep.factor == "robot" and self.robots:
            raise UsageError("--robots and --sweep robot=... both set the robots", "give one of them")
        return sweep

    def solution(self, registry: Registry) -> tuple[Submission, dict | None]:
        """``(the submission, the container or None)``: a container's engine, Dockerfile and build context; else
        the example's or the native command, its files there and (sandboxed) runnable in the sandbox.

        Raises:
            UsageError: no container engine or Dockerfile, no such example, a native command's script missing, or a
                solution the sandbox cannot run (one line each, before a backend starts).
        """
        if self.isolation == "container":
            dockerfile, context = container_files(registry, path=self.containerised,
                                                  example=self.example if self.example_containerised else None)
            container = {"engine": container_engine(), "dockerfile": str(dockerfile), "context": str(context),
                         "args": self.args}
            return native_submission(["true"]), container  # the submission is unused: the container runs instead
        if self.native:  # its script must be there before a backend starts (one line, not an episode log)
            check_native_files(self.native, Path.cwd())
        submission = (example_submission(registry, self.example, self.args) if self.example
                      else native_submission([self.native], self.args))
        if self.isolation == "bwrap":
            check_sandboxable(submission, registry)
        return submission, None


def new_batch(registry: Registry, request: BatchRequest, *, say: Callable[[str], None]) -> Batch:
    """Check ``request``, make the procedural homes it names, plan its episodes (every robot × environment ×
    repetition, or a sweep's levels) and prepare a fresh run directory under its output folder
    (:func:`~benchbot.batch.runner.prepare_batch`: config and manifest). ``say`` is told of long work (making
    homes). A run directory is made only once everything else has been checked, and removed when preparing it
    fails.

    Raises:
        UsageError: a flag is wrong (:meth:`BatchRequest.check`, :meth:`BatchRequest.solution`), bubblewrap is
            missing for a sandboxed batch, or the output folder cannot be written.
        SpecError: an unknown task, robot, environment, batch or evaluation method.
    """
    sweep = request.check()
    envs = parse_env_list(request.envs, request.envs_batch, registry)
    registry.make_generated(envs, request.workers, on_start=lambda homes, procs: say(
        f"making {homes} procedural homes ({procs} at a time) …"))
    robots = [r.strip() for r in request.robots.split(",") if r.strip()] if request.robots else [request.robot]
    if request.isolation == "bwrap":
        check_available()  # before anything is planned: one line when bubblewrap is missing
    submission, container = request.solution(registry)
    plan = dict(task=request.task, repeat=request.repeat, seed=request.seed, argv=submission.argv,
                cwd=str(submission.cwd), options=request.backend_options(), timeout_s=request.timeout_s,
                container=container, record=request.record, sandbox=request.isolation)
    sweep_record = None
    if sweep is None:
        specs = plan_episodes(robots=robots, envs=envs, noise=request.noise or "none", **plan)
    else:
        specs, level_of = plan_sweep(sweep, robots=robots, envs=envs, noise=request.noise or "none",
                                     registry=registry, **plan)
        sweep_record = {"factor": sweep.factor, "levels": list(sweep.levels), "level_of": level_of}
    try:
        run_dir = new_run_dir(request.output_dir, request.prefix)
    except OSError as exc:
        raise UsageError(f"--output-dir: cannot write {request.output_dir} ({exc.strerror or exc})",
                         "choose a writable path") from None
    try:
        return prepare_batch(registry, run_dir=run_dir, specs=specs, evaluate_with=request.evaluate_with,
                             prefix=request.prefix, zip_results=request.zip_results, sweep=sweep_record,
                             ground_truth_set=request.ground_truths)
    except BaseException:  # nothing ran: leave no empty run directory behind
        shutil.rmtree(run_dir, ignore_errors=True)
        raise


def resume_batch(registry: Registry, run_dir: Path, no_sandbox: bool) -> Batch:
    """The batch in ``run_dir`` to resume (:func:`~benchbot.batch.runner.load_batch`), run as it started.

    Raises:
        UsageError: ``no_sandbox`` for a batch that ran isolated, bubblewrap missing for a sandboxed one, or not a
            run directory (:func:`~benchbot.batch.runner.load_batch`).
    """
    batch = load_batch(registry, run_dir)
    isolation = batch.specs[0].sandbox
    if no_sandbox and isolation != "none":
        raise UsageError(f"{batch.run_dir} ran its solutions with isolation '{isolation}'; a batch resumes "
                         "as it started", "drop --no-sandbox, or start a new batch")
    if isolation == "bwrap":
        check_available()
    return batch
