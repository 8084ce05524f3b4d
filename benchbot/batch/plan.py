"""A batch's plan: one :class:`EpisodeSpec` per (robot, environment, repetition), with its seed, and the run
directory's manifest that records every episode's state (written atomically after each change, so a batch killed at
any moment can be resumed).
"""

from __future__ import annotations

import json
import re
from dataclasses import asdict, dataclass, field
from pathlib import Path

from benchbot.core import atomic
from benchbot.core.errors import UsageError

MANIFEST = "manifest.json"


@dataclass
class EpisodeSpec:
    """Everything a worker needs to run one episode (JSON-serialisable).

    Attributes:
        index: position in the batch (0-based; files are numbered by it).
        task, robot, env: names (``env`` is an environment string such as ``miniroom:1`` or ``house:1:2``).
        repeat: repetition number (0-based). seed: the episode's seed (``base seed + index``).
        argv, cwd: the submission's command and folder.
        options: robot-backend options (``arch``, ``width``, ``height``).
        timeout_s: kill the submission after this long (None: never).
        results, log: paths relative to the run directory.
        record: also record the episode as MCAP to ``recordings/NNN_<env>.mcap`` (:attr:`recording`).
        container: for containerised solutions, ``{engine, dockerfile, context, args}`` (``argv`` is then unused).
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

    @property
    def recording(self) -> str:
        """The recording's path relative to the run directory (named like the results file)."""
        return f"recordings/{Path(self.results).stem}.mcap"


@dataclass
class EpisodeRecord:
    """The outcome of one episode.

    Attributes:
        status: ``pending``, ``running``, ``ok`` (results written), ``failed`` (the submission exited non-zero or
            was killed), ``no_results`` (it exited 0 without results) or ``error`` (the backend failed: message in
            ``error``).
        attempts: how many times it was run. steps: actions performed. collided: the robot collided.
        wall_s: seconds of the last attempt. returncode: the submission's exit status.
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


def slug(text: str) -> str:
    """A file-name-safe form of ``text`` (``miniroom:1`` → ``miniroom_1``)."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text)


def plan_episodes(
    *, task: str, robots: list[str], envs: list[str], repeat: int, seed: int, argv: list[str], cwd: str,
    options: dict, timeout_s: float | None, record: bool = False, container: dict | None = None,
) -> list[EpisodeSpec]:
    """Episodes for every robot × environment × repetition (in that nesting order); episode ``i`` gets seed
    ``seed + i``. ``record``: every episode is recorded as MCAP.

    Raises:
        UsageError: ``repeat`` < 1, or no robots or environments.
    """
    if repeat < 1:
        raise UsageError(f"--repeat must be at least 1, got {repeat}", "")
    if not robots or not envs:
        raise UsageError("a batch needs at least one robot and one environment", "")
    specs = []
    for robot in robots:
        for env in envs:
            for r in range(repeat):
                i = len(specs)
                name = f"{i:03d}_{slug(env)}" + (f"_{slug(robot)}" if len(robots) > 1 else "") + (f"_r{r}" if repeat > 1 else "")
                specs.append(EpisodeSpec(
                    index=i, task=task, robot=robot, env=env, repeat=r, seed=seed + i, argv=argv, cwd=cwd,
                    options=options, timeout_s=timeout_s, results=f"results/{name}.json", log=f"logs/{name}.log",
                    record=record, container=container,
                ))
    return specs


def new_record(spec: EpisodeSpec) -> EpisodeRecord:
    """A pending record for ``spec``."""
    return EpisodeRecord(spec.index, spec.env, spec.robot, spec.repeat, spec.seed, results=spec.results, log=spec.log)


def write_manifest(run_dir: Path, manifest: dict) -> None:
    """Write ``manifest.json`` atomically."""
    atomic.write_json(run_dir / MANIFEST, manifest)


def read_manifest(run_dir: Path) -> dict:
    """The manifest of a run directory.

    Raises:
        UsageError: no run directory or no (readable) manifest there.
    """
    path = run_dir / MANIFEST
    if not path.is_file():
        raise UsageError(f"{run_dir} is not a batch run directory (no {MANIFEST})", "give the folder `benchbot batch` named")
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise UsageError(f"{path}: not valid JSON ({exc})", "the manifest is written atomically; was it edited?") from None
    except OSError as exc:
        raise UsageError(f"{path}: cannot read the manifest ({exc.strerror or exc})", "") from None


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
