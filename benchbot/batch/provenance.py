"""Where a batch's numbers came from: git revisions and the machine, recorded in the manifest's ``provenance``.

``benchbot batch`` calls :func:`collect` once when it writes the manifest; ``benchbot report`` and
``benchbot leaderboard`` print what it recorded next to the scores. Nothing here
fails a batch: a missing ``git``, a folder outside any repository or an unreadable ``/proc`` gives ``None`` for that
entry.

The host name is deliberately not recorded: manifests are published with leaderboards, and the CPU model, core
count and memory say what a reader needs to compare wall times.
"""

from __future__ import annotations

import os
import platform
import subprocess
from pathlib import Path

GIT_TIMEOUT_S = 5.0
"""Seconds a ``git`` query may take before its entry is recorded as ``None``."""


def git_revision(folder: Path | str) -> str | None:
    """The commit checked out in the git work tree containing ``folder``, with ``+dirty`` when tracked files
    differ from it (``"5746a71…+dirty"``); ``None`` when ``folder`` is not in a work tree or ``git`` is missing."""

    def git(*args: str) -> str | None:
        try:
            proc = subprocess.run(["git", "-C", str(folder), *args], capture_output=True, text=True,
                                  timeout=GIT_TIMEOUT_S, check=False)
        except (OSError, subprocess.TimeoutExpired):
            return None
        return proc.stdout.strip() if proc.returncode == 0 else None

    head = git("rev-parse", "HEAD")
    if not head:
        return None
    status = git("status", "--porcelain", "--untracked-files=no")
    return head + ("+dirty" if status else "")


def _cpu_model() -> str | None:
    try:
        for line in Path("/proc/cpuinfo").read_text(errors="replace").splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or None


def _memory_gib() -> float | None:
    try:
        return round(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30, 1)
    except (ValueError, OSError, AttributeError):
        return None


def machine() -> dict:
    """``{system, architecture, cpu, cpus, memory_gib}`` of this machine (memory in GiB; ``None`` where unknown)."""
    return {"system": platform.platform(), "architecture": platform.machine() or None, "cpu": _cpu_model(),
            "cpus": os.cpu_count(), "memory_gib": _memory_gib()}


def collect(solution_dirs: list[str]) -> dict:
    """The manifest's ``provenance``: ``{benchbot_git, solution_git: {folder: revision}, machine}``.

    Args:
        solution_dirs: the folders the solutions run in (each plan entry's ``cwd``); each distinct one is asked
            for its git revision.
    """
    source = Path(__file__).resolve().parents[2]
    return {"benchbot_git": git_revision(source),
            "solution_git": {d: git_revision(d) for d in dict.fromkeys(solution_dirs)},
            "machine": machine()}
