"""A batch's plan: one :class:`EpisodeSpec` per (robot, environment, repetition), with its seed, and the run
directory's manifest that records every episode's state (written atomically after each change, so a batch killed at
any moment can be resumed).
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import asdict, dataclass, field
from pathlib import Path

from benchbot.core import atomic
from benchbot.core.errors import UsageError
from benchbot.core.limits import MAX_BATCH_EPISODES
from benchbot.core.specs import json_path, validator

MANIFEST = "manifest.json"


@dataclass
class EpisodeSpec:
    """Everything a worker needs to run one episode (JSON-serialisable).

    Attributes:
        index: position in the batch (0-based; files are numbered by it).
        task, robot, env: names (``env`` is an environment string such as ``miniroom:1`` or ``house:1:2``).
        repeat: repetition number (0-based). seed: the episode's seed (``base seed + index``): its sensor, odometry
            and actuation noise.
        world_seed: the batch's ``--seed``, the same for every episode: with the environment's name and variant it
            fixes the scene (:func:`benchbot.core.seeding.world_seed`), so an environment's world does not depend on
            its position in ``--envs``. None in plans written before it (they then use ``seed``).
        argv, cwd: the submission's command and folder.
        options: robot-backend options (``arch``, ``width``, ``height``).
        timeout_s: stop the submission (its whole process group) after this many seconds (None: never); a new
            batch fills it from the task (:func:`benchbot.batch.runner.default_timeout_s`) unless given.
        results, log: paths relative to the run directory.
        record: also record the episode as MCAP to ``recordings/NNN_<env>.mcap`` (:attr:`recording`).
        container: for containerised solutions, ``{engine, dockerfile, context, args}`` (``argv`` is then unused).
        noise: the sensor and motion noise preset of the episode (:mod:`benchbot.core.noise`; ``none``: no noise
            beyond the robot's and the task's own).
        sandbox: how the solution is isolated (:data:`benchbot.solutions.sandbox.ISOLATION_LEVELS`): ``bwrap`` (its
            outputs folder is ``outputs/NNN_<env>/``, :attr:`outputs`), ``container`` or ``none``. Plans written
            before isolation levels existed read as ``none``, as they ran.
    """

    index: int
    task: str
    robot: str
    env: str
    repeat: int
    seed: int
    argv: list[str]
    cwd: str
    options: dict = field(default_factory=dict)
    timeout_s: float | None = None
    results: str = ""
    log: str = ""
    record: bool = False
    container: dict | None = None
    noise: str = "none"
    sandbox: str = "none"
    world_seed: int | None = None

    @property
    def recording(self) -> str:
        """The recording's path relative to the run directory (named like the results file)."""
        return f"recordings/{Path(self.results).stem}.mcap"

    @property
    def trajectory(self) -> str:
        """The episode's trajectory log relative to the run directory (named like the results file): the poses the
        robot drove, written by the batch (:func:`benchbot.batch.episode_runner.run_episode`)."""
        return f"trajectories/{Path(self.results).stem}.json"

    @property
    def outputs(self) -> str:
        """A sandboxed solution's outputs folder relative to the run directory (everything it wrote but its
        results file, which is moved to :attr:`results`)."""
        return f"outputs/{Path(self.results).stem}"


@dataclass
class EpisodeRecord:
    """The outcome of one episode.

    Attributes:
        status: ``pending``, ``running``, ``ok`` (results written), ``failed`` (the submission exited non-zero or
            was killed), ``timeout`` (stopped after ``timeout_s``), ``no_results`` (it exited 0 without results),
            ``bad_results`` (its results file cannot be read or scored: why in ``error``; it is left out of the
            scores), ``resource_limit`` (a sandboxed solution went past a resource limit: memory, processes, file
            size or CPU time; the one-line reason, naming the limit and its variable, in ``error``) or ``error``
            (the backend failed: message in ``error``).
        attempts: how many times it was run. steps: actions performed. collided: the robot collided.
        wall_s: seconds of the last attempt. returncode: the submission's exit status.
        backend: what the episode's backend was (:func:`benchbot.batch.provenance.backend_facts`: simulator plugin
            and version, scene style, Taichi arch and device, the plugin's settings); ``{}`` before it ran.
        executor: what ran its last attempt, ``local`` or ``ray`` (``""`` before it ran).
        node: where its last attempt ran: ``{}`` for ``local`` (``{"hostname"}`` with ``BENCHBOT_MANIFEST_LOCAL=1``);
            ``{"id"}`` (the Ray node's id; its IP ``address`` too with ``BENCHBOT_MANIFEST_LOCAL=1``) for ``ray``.
        lost: the attempts lost with their Ray node or worker process (``[{"node", "error"}]``, oldest first),
            each run again on another node (:data:`benchbot.batch.executors.RAY_LOST_RETRIES`); they count in
            ``attempts``.
    """

    index: int
    env: str
    robot: str
    repeat: int
    seed: int
    status: str = "pending"
    attempts: int = 0
    steps: int = 0
    collided: bool = False
    wall_s: float = 0.0
    returncode: int | None = None
    error: str = ""
    results: str = ""
    log: str = ""
    backend: dict = field(default_factory=dict)
    executor: str = ""
    node: dict = field(default_factory=dict)
    lost: list = field(default_factory=list)


def slug(text: str) -> str:
    """A file-name-safe form of ``text`` (``miniroom:1`` → ``miniroom_1``)."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text)


def plan_episodes(
    *, task: str, robots: list[str], envs: list[str], repeat: int, seed: int, argv: list[str], cwd: str,
    options: dict, timeout_s: float | None, record: bool = False, container: dict | None = None,
    noise: str = "none", start: int = 0, tag: str = "", sandbox: str = "bwrap",
) -> list[EpisodeSpec]:
    """Episodes for every robot × environment × repetition (in that nesting order); episode ``i`` gets seed
    ``seed + i`` (its noise) and every episode the world seed ``seed`` (its scenes). ``record``: every episode is
    recorded as MCAP. ``timeout_s``: None leaves the task's default to :func:`benchbot.batch.runner.prepare_batch`, 0
    means no timeout. ``noise``: every episode's noise preset.
    ``sandbox``: how every solution is isolated (``bwrap``, the default; ``container`` or ``none``).

    ``start`` and ``tag`` serve sweeps (:func:`benchbot.batch.sweep.plan_sweep`): the episodes are numbered from
    ``start`` (episode ``start + j`` still gets seed ``seed + j``, so every level of a sweep reuses the same seeds)
    and ``tag`` is added to their file names.

    Raises:
        UsageError: ``repeat`` < 1, no robots or environments, more than
            :data:`~benchbot.core.limits.MAX_BATCH_EPISODES` episodes in all (checked before any is made), or
            ``timeout_s`` negative or not finite.
        ValueError: ``sandbox`` is not an isolation level.
    """
    from benchbot.solutions.sandbox import ISOLATION_LEVELS

    if sandbox not in ISOLATION_LEVELS:
        raise ValueError(f"unknown isolation level {sandbox!r}")
    if repeat < 1:
        raise UsageError(f"--repeat must be at least 1, got {repeat}", "")
    if not robots or not envs:
        raise UsageError("a batch needs at least one robot and one environment", "")
    if start + len(robots) * len(envs) * repeat > MAX_BATCH_EPISODES.value():  # before anything is allocated
        before = f" after the {start} planned already" if start else ""
        raise UsageError(f"a batch of {len(robots)} robot(s) × {len(envs)} environment(s) × {repeat} repetition(s)"
                         f"{before} is more than the limit of {MAX_BATCH_EPISODES.describe()} "
                         f"({MAX_BATCH_EPISODES.raise_hint()})", MAX_BATCH_EPISODES.hint())
    if timeout_s is not None and not (math.isfinite(timeout_s) and timeout_s >= 0):
        raise UsageError(f"--episode-timeout must be a number of seconds ≥ 0, got {timeout_s}",
                         "0 runs without a timeout; leave it out for the task's default")
    specs = []
    for robot in robots:
        for env in envs:
            for r in range(repeat):
                j = len(specs)
                i = start + j
                name = (f"{i:03d}_{slug(env)}" + (f"_{slug(robot)}" if len(robots) > 1 else "")
                        + (f"_{slug(tag)}" if tag else "") + (f"_r{r}" if repeat > 1 else ""))
                specs.append(EpisodeSpec(
                    index=i, task=task, robot=robot, env=env, repeat=r, seed=seed + j, argv=argv, cwd=cwd,
                    options=options, timeout_s=timeout_s, results=f"results/{name}.json", log=f"logs/{name}.log",
                    record=record, container=container, noise=noise, sandbox=sandbox, world_seed=seed,
                ))
    return specs


def trajectory_length(scenes: list[dict]) -> int:
    """The number of poses of the scenes' trajectories (their ``trajectory_poses``, summed; 0 when none has one):
    the steps of a passive episode on them, one ``move_next`` per pose. The one place this is counted: the batch's
    expected steps (:func:`expected_steps`), its default timeouts and its longest-first order use it.

    Args:
        scenes: environment specs (``registry.scenes(env)``, a ``RunSpec``'s ``environments``, or ``config.json``'s).

    Raises:
        AttributeError, TypeError: ``scenes`` is not a list of dicts (each a file's content the caller checks).
    """
    return sum(len(scene.get("trajectory_poses") or []) for scene in scenes)


def expected_steps(task: dict, scenes: list[dict]) -> int | None:
    """The number of steps an episode of ``task`` on ``scenes`` will take, where it is known beforehand: for a
    passive task (its only action is ``move_next``) the :func:`trajectory_length` of the scenes; None for any other
    task (an active one: the solution decides when to stop).

    Args:
        task: a task spec (``registry.get("tasks", name)``, a ``RunSpec``'s ``task``, or ``config.json``'s).
        scenes: the episode's environment specs.

    Raises:
        AttributeError, TypeError: ``task`` is not a dict or ``scenes`` not a list of dicts.
    """
    if task.get("actions") != ["move_next"]:
        return None
    return trajectory_length(scenes)


def new_record(spec: EpisodeSpec) -> EpisodeRecord:
    """A pending record for ``spec``."""
    return EpisodeRecord(spec.index, spec.env, spec.robot, spec.repeat, spec.seed, results=spec.results, log=spec.log)


def write_manifest(run_dir: Path, manifest: dict) -> None:
    """Write ``manifest.json`` atomically."""
    atomic.write_json(run_dir / MANIFEST, manifest)


def read_manifest(run_dir: Path) -> dict:
    """The manifest of a run directory, checked by :func:`check_manifest`.

    Raises:
        UsageError: no run directory or no (readable) manifest there, or a manifest that fails the check.
    """
    path = run_dir / MANIFEST
    if not path.is_file():
        raise UsageError(f"{run_dir} is not a batch run directory (no {MANIFEST})", "give the folder `benchbot batch` named")
    try:
        manifest = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise UsageError(f"{path}: not valid JSON ({exc})", "the manifest is written atomically; was it edited?") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise UsageError(f"{path}: cannot read the manifest ({getattr(exc, 'strerror', None) or exc})", "") from None
    check_manifest(manifest, path, run_dir)
    return manifest


MANIFEST_HINT = "was it edited? fix the field (schemas/batch_manifest.schema.json) or start a new batch"


def check_manifest(manifest: object, source: Path | str, run_dir: Path) -> None:
    """Check a manifest before anything runs from it: against ``schemas/batch_manifest.schema.json``, then that
    ``plan`` and ``episodes`` describe the same episodes in index order (0, 1, ...), that no two episodes share a
    results or log file, and that every results, log and recording path stays inside ``run_dir`` (also through
    symbolic links).

    Raises:
        UsageError: ``"<source>: <$.json.path>: <problem>"`` for the first problem found.
    """
    def fail(where: str, problem: str) -> None:
        problem = " ".join(problem.split())
        if len(problem) > 200:
            problem = problem[:197] + "..."
        raise UsageError(f"{source}: {where}: {problem}", MANIFEST_HINT)

    errors = sorted(validator("batch_manifest").iter_errors(manifest), key=lambda e: list(map(str, e.absolute_path)))
    if errors:
        fail(json_path(errors[0].absolute_path), errors[0].message)
    plan, episodes = manifest["plan"], manifest["episodes"]
    if len(episodes) != len(plan):
        fail("$.episodes", f"{len(episodes)} records for {len(plan)} planned episodes (they must match one to one)")
    root = run_dir.resolve()
    seen: dict[str, str] = {}
    for i, (spec, record) in enumerate(zip(plan, episodes)):
        for where, item in ((f"$.plan[{i}]", spec), (f"$.episodes[{i}]", record)):
            if item["index"] != i:
                fail(f"{where}.index", f"{item['index']}, expected {i} (episodes are listed in index order)")
        for key in ("env", "robot", "repeat", "seed", "results", "log"):
            if key in record and record[key] != spec[key]:
                fail(f"$.episodes[{i}].{key}", f"{record[key]!r} differs from $.plan[{i}].{key} {spec[key]!r}")
        for key in ("results", "log"):
            rel = spec[key]
            if rel in seen:
                fail(f"$.plan[{i}].{key}", f"{rel} is also {seen[rel]}")
            seen[rel] = f"$.plan[{i}].{key}"
            target = (root / rel).resolve()
            if not target.is_relative_to(root):
                fail(f"$.plan[{i}].{key}", f"{rel} resolves to {target}, outside the run directory {root}")
        recording = (root / EpisodeSpec(**spec).recording).resolve()
        if not recording.is_relative_to(root):
            fail(f"$.plan[{i}].results", f"its recording resolves to {recording}, outside the run directory {root}")


def specs_from_manifest(manifest: dict) -> tuple[list[EpisodeSpec], list[EpisodeRecord]]:
    """The plan and records stored in a manifest (for ``--resume``).

    Raises:
        UsageError: the manifest has no valid ``plan`` or ``episodes`` (not written by this version, or edited).
    """
    try:
        specs = [EpisodeSpec(**s) for s in manifest["plan"]]
        records = [EpisodeRecord(**r) for r in manifest["episodes"]]
    except (KeyError, TypeError) as exc:
        raise UsageError(f"the batch manifest has no valid plan or episodes ({exc!r})",
                         "was it edited, or written by another BenchBot version?") from None
    return specs, records


def to_json(items: list) -> list[dict]:
    """Dataclasses → dicts."""
    return [asdict(i) for i in items]
