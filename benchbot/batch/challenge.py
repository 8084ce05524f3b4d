"""Hosting an evaluation (``benchbot challenge init`` / ``benchbot challenge evaluate``; docs/challenge.md).

A challenge is a folder on the scoring host::

    DIR/conditions.json      public: task, robot, split, count, environments, limits, the host key's fingerprint
    DIR/host_key.pub.pem     public: the host's Ed25519 public key (participants and leaderboards trust it)
    DIR/host_key.pem         secret (mode 0600): the host's private key, which signs results
    DIR/runs/challenge-…     one run directory per evaluated submission, each with its signature.json

The held-out ``test`` split's key stays where ``benchbot worlds key`` keeps it (``BENCHBOT_WORLDS_KEY_FILE``, else
the data directory); only its public id is in ``conditions.json``.

:func:`evaluate_submission` runs a submission with ``benchbot batch --native`` (the batch machinery as it is: the
sandbox, the executors, the evaluation, the manifest) on the challenge's environments, checks the run matches the
conditions, copies ``conditions.json`` into the run and signs it (:func:`benchbot.batch.signing.sign_run`).
"""

from __future__ import annotations

import json
import os
import shlex
import subprocess
import sys
from datetime import datetime, timezone
from pathlib import Path

from benchbot.batch import signing
from benchbot.core import atomic
from benchbot.core.errors import UsageError

FORMAT = "benchbot-challenge/1"
"""``conditions.json``'s ``format``."""

CONDITIONS_FILE = "conditions.json"
RUNS = "runs"
SPLITS = ("train", "val", "test")
GENERATOR = "procedural"
WORLDS_HINT = "install it (uv pip install benchbot-worlds, or pip install benchbot-worlds) on the scoring host"


def ensure_test_key() -> str:
    """Make sure this host has the held-out test split's key (``benchbot worlds key``: made when missing, kept
    when there), and return its public id.

    Raises:
        UsageError: benchbot-worlds is not installed (one line), or the key file is unreadable (its fix).
    """
    try:
        from benchbot_worlds.procedural import splits
    except ImportError:
        raise UsageError("the held-out test split needs benchbot-worlds, which is not installed", WORLDS_HINT) from None
    if not splits.key_path().exists():
        splits.make_key()
    return splits.key_id(splits.read_key())


def split_environments(split: str, count: int) -> list[str]:
    """Variant 1 of the first ``count`` procedural homes of ``split`` (``procedural_test_0:1`` …)."""
    return [f"{GENERATOR}_{split}_{i}:1" for i in range(count)]


#: A challenge's solution limits: ``--limit`` name → (the manifest's key, the limit whose variable the batch gets).
SOLUTION_LIMITS = {"memory": ("memory_bytes", "SANDBOX_MEMORY_BYTES"), "processes": ("processes", "SANDBOX_PROCESSES"),
                   "file": ("file_bytes", "SANDBOX_FILE_BYTES"), "cpu": ("cpu_s", "SANDBOX_CPU_S"),
                   "tmp": ("tmp_bytes", "SANDBOX_TMP_BYTES"), "outputs": ("outputs_bytes", "SANDBOX_OUTPUTS_BYTES")}


def solution_limits(given: list[str] | None = None) -> dict[str, int]:
    """A challenge's limits on each solution, ``{memory_bytes, processes, file_bytes, cpu_s, tmp_bytes,
    outputs_bytes}``: this
    host's (its sandbox limits' variables, else their defaults; docs/security.md) with ``given`` on top.

    Args:
        given: ``NAME=VALUE`` strings, NAME one of :data:`SOLUTION_LIMITS` (``memory=4G``, ``cpu=600``), VALUE as
            the limit's variable takes it (bytes may end in ``K``/``M``/``G``).

    Raises:
        UsageError: an unknown name, a missing ``=``, or a value the limit does not take (one line naming it).
    """
    from benchbot.core import limits as all_limits
    from benchbot.solutions.sandbox_limits import SandboxLimits

    current = SandboxLimits.current()
    values = {key: int(getattr(current, key)) for key, _ in SOLUTION_LIMITS.values()}
    for item in given or []:
        name, sep, raw = item.partition("=")
        if not sep or name.strip() not in SOLUTION_LIMITS:
            raise UsageError(f"--limit {item!r} is not NAME=VALUE with NAME one of {', '.join(SOLUTION_LIMITS)}",
                             "e.g. --limit memory=4G --limit cpu=600")
        key, limit_name = SOLUTION_LIMITS[name.strip()]
        limit = getattr(all_limits, limit_name)
        values[key] = int(limit.parse(raw, f"--limit {name.strip()}",
                                      f"e.g. --limit {name.strip()}={limit.example(limit.default)}"))
    return values


def batch_environment(conditions: dict) -> dict[str, str]:
    """The environment a challenge's batch runs in: this process's, with the challenge's solution limits as the
    variables the sandbox reads (a challenge made before limits were recorded: unchanged)."""
    from benchbot.core import limits as all_limits

    env = dict(os.environ)
    given = (conditions.get("limits") or {}).get("solution") or {}
    for key, limit_name in SOLUTION_LIMITS.values():
        if isinstance(given.get(key), int):
            env[getattr(all_limits, limit_name).env] = str(given[key])
    return env


def init_challenge(folder: Path, *, task: str, robot: str, split: str | None, count: int,
                   environments: list[str] | None = None, evaluate_with: str = "auto",
                   episode_timeout_s: float | None = None, limits: list[str] | None = None) -> dict:
    """Make a challenge in ``folder``: the host key pair (:func:`benchbot.batch.signing.write_key_pair`), the test
    split's key when ``split`` is ``test`` (:func:`ensure_test_key`) and ``conditions.json``.

    Args:
        split: ``train``, ``val`` or ``test``: the challenge runs variant 1 of its first ``count`` homes; None with
            ``environments`` (a development challenge on named environments, e.g. ``miniroom:1``).
        environments: named environments instead of a split.
        limits: ``NAME=VALUE`` limits on each solution over this host's (:func:`solution_limits`).

    Returns:
        the conditions as written: ``{"format", "task", "robot", "split", "count", "environments", "worlds",
        "evaluate_with", "limits": {"episode_timeout_s", "solution": {memory_bytes, processes, file_bytes, cpu_s,
        tmp_bytes, outputs_bytes}}, "isolation", "public_key", "fingerprint", "test_split_key_id", "created"}``.

    Raises:
        UsageError: the folder already holds a challenge; a bad split, count or limit; neither or both of split
            and environments; benchbot-worlds missing for the test split.
    """
    folder = Path(folder)
    if (folder / CONDITIONS_FILE).exists() or (folder / signing.PRIVATE_KEY_FILE).exists():
        raise UsageError(f"{folder} already holds a challenge ({CONDITIONS_FILE} or {signing.PRIVATE_KEY_FILE})",
                         "give a new folder: its key signs that challenge's results")
    if (split is None) == (not environments):
        raise UsageError("give --split (train, val or test) with --count, or --environments", "e.g. --split test --count 100")
    if split is not None and split not in SPLITS:
        raise UsageError(f"--split '{split}' is not a split", f"use one of {', '.join(SPLITS)}")
    if not 1 <= count <= 10_000:
        raise UsageError(f"--count {count} is outside 1..10000", "e.g. --count 100")
    solution = solution_limits(limits)
    key_id = ensure_test_key() if split == "test" else None
    envs = list(environments) if environments else split_environments(split, count)
    private, public = signing.write_key_pair(folder)
    conditions = {
        "format": FORMAT, "task": task, "robot": robot, "split": split, "count": len(envs), "environments": envs,
        "worlds": signing.worlds_standing(envs), "evaluate_with": evaluate_with,
        "limits": {"episode_timeout_s": episode_timeout_s, "solution": solution}, "isolation": "bwrap",
        "public_key": public.name, "fingerprint": signing.fingerprint(signing.load_public_key(public)),
        "test_split_key_id": key_id, "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }
    atomic.write_json(folder / CONDITIONS_FILE, conditions)
    return conditions


def read_conditions(folder: Path) -> dict:
    """The challenge's ``conditions.json``.

    Raises:
        UsageError: no challenge there, or the file is garbled (naming it).
    """
    path = Path(folder) / CONDITIONS_FILE
    hint = "make one with `benchbot challenge init DIR --task … --robot … --split test --count N`"
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise UsageError(f"{path}: missing, {folder} is not a challenge folder", hint) from None
    except (OSError, ValueError) as exc:
        raise UsageError(f"{path}: unreadable or not JSON ({exc.__class__.__name__})", "restore it, or " + hint) from None
    if not isinstance(data, dict) or data.get("format") != FORMAT or not data.get("environments"):
        raise UsageError(f"{path}: not a challenge's conditions (format {FORMAT} with environments)", "restore it, or " + hint)
    return data


def submission_command(submission: Path, native: str | None) -> str:
    """The solution's command: ``native`` when given, else ``python FILE`` for the one ``.py`` file at the top of
    ``submission``.

    Raises:
        UsageError: not a folder, or no ``native`` and not exactly one top-level ``.py`` file.
    """
    if not submission.is_dir():
        raise UsageError(f"{submission}: not a folder", "a submission is a solution folder (its code and lock file)")
    if native:
        return native
    scripts = sorted(p.name for p in submission.glob("*.py"))
    if len(scripts) != 1:
        raise UsageError(f"{submission}: {len(scripts)} top-level .py files, cannot tell the solution's command",
                         "give it: --native 'python my_solution.py'")
    return f"python {shlex.quote(scripts[0])}"


#: Isolation levels a challenge accepts for its runs: the bubblewrap sandbox (native submissions) or a container.
SANDBOXED = ("bwrap", "container")


def batch_argv(conditions: dict, command: str | None, output_dir: Path, *, workers: int = 1, executor: str = "local",
               dockerfile: Path | None = None) -> list[str]:
    """The ``benchbot batch`` command line that runs a submission under ``conditions``, always isolated: ``--native
    command`` (the bubblewrap sandbox), or ``--containerised dockerfile`` when one is given."""
    solution = ["--containerised", str(dockerfile)] if dockerfile is not None else ["--native", str(command)]
    argv = [sys.executable, "-m", "benchbot.cli", "batch", *solution, "--task", conditions["task"],
            "--robot", conditions["robot"], "--envs", ",".join(conditions["environments"]),
            "--evaluate-with", str(conditions.get("evaluate_with") or "auto"), "--output-dir", str(output_dir),
            "--prefix", "challenge", "--no-tui", "--workers", str(workers), "--executor", executor]
    timeout = (conditions.get("limits") or {}).get("episode_timeout_s")
    if timeout is not None:
        argv += ["--episode-timeout", str(timeout)]
    return argv


def check_matches(run_dir: Path, conditions: dict) -> None:
    """Refuse to sign a run that does not match the challenge: its task, robots, environments, isolation (the
    bubblewrap sandbox or a container: :data:`SANDBOXED`) and the limits its solutions ran under (the manifest's
    ``limits``).

    Raises:
        UsageError: naming the first difference.
    """
    manifest = json.loads((run_dir / "manifest.json").read_text(encoding="utf-8"))
    wanted_limits = (conditions.get("limits") or {}).get("solution")
    ran_limits = {key: (manifest.get("limits") or {}).get(key) for key in wanted_limits} if wanted_limits else None
    isolation = manifest.get("sandbox") if manifest.get("sandbox") in SANDBOXED else " or ".join(SANDBOXED)
    for what, ran, wanted in (("task", manifest.get("task"), conditions["task"]),
                              ("robots", manifest.get("robots"), [conditions["robot"]]),
                              ("environments", manifest.get("environments"), conditions["environments"]),
                              ("isolation", manifest.get("sandbox"), isolation),
                              ("solution limits", ran_limits, wanted_limits)):
        if ran != wanted:
            raise UsageError(f"{run_dir}: its {what} {ran!r} is not the challenge's {wanted!r}; not signed",
                             "evaluate it again with `benchbot challenge evaluate`")


def evaluate_submission(submission: Path, challenge: Path, *, native: str | None = None, workers: int = 1,
                        executor: str = "local", containerised: bool = False) -> tuple[Path, Path | None, int]:
    """Run ``submission`` on the challenge's environments with ``benchbot batch`` (its output goes to this process's
    stdout and stderr) — in the sandbox, or with ``containerised`` as the container its ``Dockerfile`` builds (Podman
    or Docker, docs/containers.md) — check the run, copy ``conditions.json`` into it and sign it.

    Returns:
        (run directory, signature file — or None when the batch scored nothing, the batch's exit status).

    Raises:
        UsageError: no challenge in ``challenge`` or its private key is unreadable; a bad submission folder; the
            batch made no run directory; the run does not match the conditions.
    """
    challenge = Path(challenge).resolve()
    conditions = read_conditions(challenge)
    private = challenge / signing.PRIVATE_KEY_FILE
    signing.load_private_key(private)  # a bad key stops before anything runs
    submission = Path(submission).resolve()
    dockerfile = submission / "Dockerfile" if containerised else None
    if dockerfile is not None and native:
        raise UsageError("give --native or --containerised, not both", "a container runs its Dockerfile's command")
    if dockerfile is not None and not dockerfile.is_file():
        raise UsageError(f"{submission}: no Dockerfile, cannot run it --containerised", "add one, or drop --containerised")
    command = None if dockerfile is not None else submission_command(submission, native)
    if conditions.get("split") == "test":
        ensure_test_key()
    secrets = [challenge]
    try:
        from benchbot_worlds.procedural.splits import key_path

        secrets.append(key_path().expanduser().resolve())
    except ImportError:
        pass
    for secret in secrets:  # the solution's folder is shown to it in the sandbox: no host secret may be in it
        if secret == submission or submission in secret.parents:
            raise UsageError(f"{secret} is inside the submission folder {submission}, which the solution sees",
                             "keep the challenge folder and the worlds key outside every submission")
    runs = challenge / RUNS
    runs.mkdir(exist_ok=True)
    before = set(runs.iterdir())
    status = subprocess.call(batch_argv(conditions, command, runs, workers=workers, executor=executor,
                                        dockerfile=dockerfile), cwd=submission, env=batch_environment(conditions))
    made = sorted(set(runs.iterdir()) - before)
    if not made:
        raise UsageError(f"the batch made no run directory in {runs} (exit status {status}); nothing to sign",
                         "its error is above")
    run_dir = made[-1]
    if not (run_dir / "scores.json").is_file():
        return run_dir, None, status or 1
    check_matches(run_dir, conditions)
    atomic.write_bytes(run_dir / CONDITIONS_FILE, (challenge / CONDITIONS_FILE).read_bytes())
    return run_dir, signing.sign_run(run_dir, private, challenge=conditions), status
