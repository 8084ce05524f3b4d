"""The layout of content packs: the folders of a pack (:data:`FOLDER_KINDS`: the original add-on layout), its spec
files (:func:`spec_files`), where installed packs live (:func:`data_dir`, :func:`packs_dir`) and the error every pack
problem is (:class:`PackError`). :mod:`benchbot.packs.content_packs` (scanning, checking, installing) and
:mod:`benchbot.packs.original_addons` (the original's add-on files) build on it."""

from __future__ import annotations

import os
from pathlib import Path

from benchbot.core import settings
from benchbot.core.errors import BenchbotError, ExitCode
from benchbot.core.specs import SPEC_SUFFIXES

FOLDER_KINDS = {
    "tasks": "tasks",
    "robots": "robots",
    "environments": "environments",
    "formats": "formats",
    "evaluation_methods": "evaluators",
    "evaluators": "evaluators",
    "ground_truths": "ground_truths",
    "examples": "examples",
    "batches": "batches",
}
"""Pack folder name → registry kind (the original's ``evaluation_methods`` is our ``evaluators``)."""

MANIFEST = ".benchbot-pack.json"
"""An installed pack's manifest file, in its folder."""
IGNORED = {".git", "__pycache__", ".venv", ".mypy_cache", ".pytest_cache", MANIFEST}
"""Folders and files of a pack that are never its content."""


class PackError(BenchbotError):
    """A content pack is invalid, unsafe, clashes with installed content, or cannot be installed.

    Attributes:
        details: one line per problem (``<file>: <$.json.path>: <message>``), printed before the message.
    """

    exit_code = ExitCode.SPEC

    def __init__(self, message: str, hint: str = "", details: list[str] | None = None) -> None:
        super().__init__(message, hint)
        self.details = list(details or [])


def data_dir() -> Path:
    """BenchBot's data directory: ``$BENCHBOT_DATA_DIR``, else ``$XDG_DATA_HOME/benchbot``, else
    ``~/.local/share/benchbot`` (not created)."""
    if settings.get("BENCHBOT_DATA_DIR"):
        return Path(settings.get("BENCHBOT_DATA_DIR")).expanduser()
    xdg = settings.get("XDG_DATA_HOME")
    return (Path(xdg).expanduser() if xdg else Path.home() / ".local" / "share") / "benchbot"


def cache_dir() -> Path:
    """BenchBot's cache directory (what can be rebuilt, such as the simulator's built scenes): ``$BENCHBOT_CACHE_DIR``,
    else ``$XDG_CACHE_HOME/benchbot``, else ``~/.cache/benchbot`` (not created). It may hold scene layouts, so the
    sandbox hides it (:func:`benchbot.solutions.sandbox.hidden_folders`)."""
    if settings.get("BENCHBOT_CACHE_DIR"):
        return Path(settings.get("BENCHBOT_CACHE_DIR")).expanduser()
    xdg = settings.get("XDG_CACHE_HOME")
    return (Path(xdg).expanduser() if xdg else Path.home() / ".cache") / "benchbot"


def packs_dir() -> Path:
    """``<data dir>/packs`` (not created)."""
    return data_dir() / "packs"


def spec_files(root: Path) -> list[tuple[str, Path]]:
    """``(kind, path)`` of every spec file directly inside a type folder anywhere under ``root`` (sorted)."""
    found = []
    for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
        dirnames[:] = sorted(d for d in dirnames if d not in IGNORED and not d.startswith("."))
        folder = Path(dirpath)
        kind = FOLDER_KINDS.get(folder.name) if folder != root else None
        if kind is None:
            continue
        for fname in sorted(filenames):
            path = folder / fname
            if path.suffix not in SPEC_SUFFIXES or fname.startswith(".") or not path.is_file():
                continue
            if path.is_symlink() and not path.resolve().is_relative_to(root):
                continue  # reported by _check_tree
            found.append((kind, path))
    return found
