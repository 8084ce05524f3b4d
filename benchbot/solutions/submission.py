"""Running a submission (a native command or an installed example) against a backend (a containerised one:
:mod:`benchbot.solutions.containers`).

The submission is a child process; it finds the backend through ``BENCHBOT_SUPERVISOR_ADDRESS`` and writes its
results to ``BENCHBOT_RESULT_LOCATION`` (both read by :mod:`benchbot.api`), so user code needs no edits.
"""

from __future__ import annotations

import os
import re
import shlex
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from benchbot.core.errors import SpecError, UsageError
from benchbot.solutions.process_group import ChildOutcome, run_child
from benchbot.core.registry import Registry


@dataclass
class Submission:
    """A command to run: ``argv`` in folder ``cwd``; ``label`` names it in messages; ``reads_ground_truth``: an
    example that reads the ground truth on purpose (its spec says so), which only runs unsandboxed."""

    argv: list[str]
    cwd: Path
    label: str
    reads_ground_truth: bool = False


def _python_first(argv: list[str]) -> list[str]:
    if argv and argv[0] in ("python", "python3"):
        return [sys.executable, *argv[1:]]
    return argv


def native_submission(command: list[str], args: str = "") -> Submission:
    """A native command (run in the current folder). A single word with spaces is split like a shell would;
    ``args`` are appended (docs/cli.md); a leading ``python`` is the current interpreter.

    Raises:
        UsageError: the command is empty.
    """
    argv = shlex.split(command[0]) if len(command) == 1 else list(command)
    argv += shlex.split(args)
    if not argv:
        raise UsageError("--native needs a command", "e.g. --native python my_solution.py")
    return Submission(_python_first(argv), Path.cwd(), " ".join(argv))


_PYTHON_NAME = re.compile(r"python(\d+(\.\d+)?)?")
_PYTHON_VALUE_FLAGS = ("-W", "-X", "--check-hash-based-pycs")  # interpreter flags that take the next word


def check_native_files(command: str, cwd: Path) -> None:
    """Refuse a ``--native`` command whose script is not there, before any backend starts: for ``python
    [FLAGS] SCRIPT ...`` (``python``, ``python3``, ``python3.11`` or a path ending in one), the first word after the
    interpreter's flags, when it looks like a path (ends in ``.py`` or holds a ``/``), must be a file relative to
    ``cwd``, the folder the solution runs in (the sandbox shows it at the same path). ``-m``/``-c`` commands and
    other programs are not checked.

    Raises:
        UsageError: naming the missing file and the fix.
    """
    try:
        argv = shlex.split(command)
    except ValueError as exc:  # "No closing quotation"
        raise UsageError(f"--native '{command}': {exc}", "balance its quotes, e.g. --native 'python my solution.py'") \
            from None
    if not argv or not _PYTHON_NAME.fullmatch(Path(argv[0]).name):
        return
    words = iter(argv[1:])
    for word in words:
        if word in ("-m", "-c", "-"):
            return
        if word in _PYTHON_VALUE_FLAGS:
            next(words, None)
            continue
        if word.startswith("-"):
            continue
        if not (word.endswith(".py") or "/" in word):
            return
        path = Path(word) if Path(word).is_absolute() else cwd / word
        if not path.is_file():
            what = "is a folder, not a file" if path.is_dir() else "does not exist"
            raise UsageError(f"--native '{command}': {path} {what} (the solution runs in {cwd})",
                             f"run benchbot from the folder that holds {word}, or give its path, e.g. "
                             f"--native 'python path/to/{Path(word).name}'")
        return


def example_submission(registry: Registry, name: str, args: str = "") -> Submission:
    """The installed example ``name``: its ``native_command`` run from its spec's folder.

    Raises:
        SpecError: unknown example, or an example given as a dict without a folder.
    """
    entry = registry.entry("examples", name)
    if entry.path is None:
        raise SpecError(f"example '{name}' has no spec file to run from", "plugins must give examples as files")
    argv = _python_first(shlex.split(entry.spec["native_command"]) + shlex.split(args))
    return Submission(argv, entry.path.parent, f"example {name}", bool(entry.spec.get("reads_ground_truth")))


def run_submission(
    submission: Submission,
    *,
    address: str,
    result_location: Path,
    log: IO[str] | None = None,
    timeout_s: float | None = None,
    stdin: str = "none",
) -> ChildOutcome:
    """Run the submission to completion in its own process group (:func:`benchbot.solutions.process_group.run_child`):
    when it ends, for any reason, every process it started is stopped too, and a watchdog stops them if this process
    dies first.

    Args:
        address: the backend's ``http://127.0.0.1:PORT/``.
        result_location: where the API makes the agent save its results.
        log: a file for the child's stdout and stderr, capped at ``BENCHBOT_MAX_LOG_BYTES`` (inherited when None).
        timeout_s: stop the child's group after this many seconds (``timed_out`` in the outcome).
        stdin: ``"inherit"`` (``benchbot submit``: the terminal is passed through) or ``"none"`` (batches: an empty
            pipe; a read of it is said once and gets end-of-file).

    Returns:
        The :class:`~benchbot.solutions.process_group.ChildOutcome`: ``returncode``, ``timed_out``, ``output_bytes``,
        ``log_truncated``.

    Raises:
        UsageError: the command cannot be started (not found, not executable), or a bad ``BENCHBOT_MAX_LOG_BYTES``
            / ``BENCHBOT_STOP_GRACE_S``.
    """
    env = dict(os.environ, BENCHBOT_SUPERVISOR_ADDRESS=address, BENCHBOT_RESULT_LOCATION=str(result_location))
    env["PYTHONUNBUFFERED"] = "1"
    try:
        return run_child(submission.argv, cwd=submission.cwd, env=env, log=log, timeout_s=timeout_s, stdin=stdin)
    except OSError as exc:
        raise UsageError(f"cannot start {submission.label}: {exc.strerror}: {submission.argv[0]}", "check the command") from None


# ------------------------------------------------------------------------------------------------- tarballs
def package_versions() -> dict[str, str]:
    """Versions of the installed ``benchbot*`` distributions and of the key libraries."""
    from importlib import metadata

    versions = {}
    for dist in metadata.distributions():
        name = (dist.metadata.get("Name") or "").lower()
        if name.startswith("benchbot") or name in ("numpy", "taichi", "scipy", "jsonpickle"):
            versions[name] = dist.version
    return dict(sorted(versions.items()))


def make_submission_archive(directory: Path, output: Path, *, manifest: dict) -> tuple[Path, Path]:
    """``tar -czf output .`` of ``directory`` (contents at the archive's root, as the original) plus
    ``<output>.manifest.json``: ``{files: {relative path: sha256}, packages, ...manifest}``.

    Raises:
        UsageError: ``directory`` is not a folder, or ``output`` lies inside it.
    """
    import hashlib
    import json
    import tarfile

    directory = directory.resolve()
    if not directory.is_dir():
        raise UsageError(f"--submission: {directory} is not a folder", "give the folder holding your solution")
    output = output.resolve()
    if directory in output.parents:
        raise UsageError(f"--submission: the archive {output} would be inside {directory}", "write it elsewhere (--args PATH)")
    files = {}
    for path in sorted(p for p in directory.rglob("*") if p.is_file()):
        files[path.relative_to(directory).as_posix()] = hashlib.sha256(path.read_bytes()).hexdigest()
    output.parent.mkdir(parents=True, exist_ok=True)
    with tarfile.open(output, "w:gz") as tar:
        for rel in files:
            tar.add(directory / rel, arcname=f"./{rel}")
    manifest_path = output.with_name(output.name + ".manifest.json")
    data = {**manifest, "archive": output.name, "archive_sha256": hashlib.sha256(output.read_bytes()).hexdigest(),
            "files": files, "packages": package_versions()}
    manifest_path.write_text(json.dumps(data, indent=2))
    return output, manifest_path
