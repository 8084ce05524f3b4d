"""Running a submission (a native command or an installed example) against a backend.

The submission is a child process; it finds the backend through ``BENCHBOT_SUPERVISOR_ADDRESS`` and writes its
results to ``BENCHBOT_RESULT_LOCATION`` (both read by :mod:`benchbot.api`), so user code needs no edits.
"""

from __future__ import annotations

import os
import shlex
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from benchbot.core.errors import SpecError, UsageError
from benchbot.core.registry import Registry


@dataclass
class Submission:
    """A command to run: ``argv`` in folder ``cwd``; ``label`` names it in messages."""

    argv: list[str]
    cwd: Path
    label: str


def _python_first(argv: list[str]) -> list[str]:
    if argv and argv[0] in ("python", "python3"):
        return [sys.executable, *argv[1:]]
    return argv


def native_submission(command: list[str], args: str = "") -> Submission:
    """A native command (run in the current folder). A single word with spaces is split like a shell would;
    ``args`` are appended (reference §1.3); a leading ``python`` is the current interpreter.

    Raises:
        UsageError: the command is empty.
    """
    argv = shlex.split(command[0]) if len(command) == 1 else list(command)
    argv += shlex.split(args)
    if not argv:
        raise UsageError("--native needs a command", "e.g. --native python my_solution.py")
    return Submission(_python_first(argv), Path.cwd(), " ".join(argv))


def example_submission(registry: Registry, name: str, args: str = "") -> Submission:
    """The installed example ``name``: its ``native_command`` run from its spec's folder.

    Raises:
        SpecError: unknown example, or an example given as a dict without a folder.
    """
    entry = registry.entry("examples", name)
    if entry.path is None:
        raise SpecError(f"example '{name}' has no spec file to run from", "plugins must give examples as files")
    argv = _python_first(shlex.split(entry.spec["native_command"]) + shlex.split(args))
    return Submission(argv, entry.path.parent, f"example {name}")


def run_submission(
    submission: Submission,
    *,
    address: str,
    result_location: Path,
    log: IO[str] | None = None,
    timeout_s: float | None = None,
) -> int:
    """Run the submission to completion and return its exit status.

    Args:
        address: the backend's ``http://127.0.0.1:PORT/``.
        result_location: where the API makes the agent save its results.
        log: a text file for the child's stdout and stderr (inherited when None).
        timeout_s: kill the child after this many seconds (exit status -9).

    Raises:
        UsageError: the command cannot be started (not found, not executable).
    """
    env = dict(os.environ, BENCHBOT_SUPERVISOR_ADDRESS=address, BENCHBOT_RESULT_LOCATION=str(result_location))
    env["PYTHONUNBUFFERED"] = "1"
    try:
        child = subprocess.Popen(
            submission.argv, cwd=submission.cwd, env=env, stdin=subprocess.DEVNULL,
            stdout=log, stderr=subprocess.STDOUT if log is not None else None, text=True,
        )
    except OSError as exc:
        raise UsageError(f"cannot start {submission.label}: {exc.strerror}: {submission.argv[0]}", "check the command") from None
    try:
        return child.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        child.kill()
        child.wait()
        return -9
    except BaseException:
        child.kill()
        child.wait()
        raise
