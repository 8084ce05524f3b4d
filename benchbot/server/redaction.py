"""Ground truth is never served: the strings that name ground-truth files, and text with them blanked out.

:class:`~benchbot.server.service.BackendService` gathers the strings; every error the server answers passes
through :func:`redact` (:func:`~benchbot.server.http_errors.error_response`).
"""

from __future__ import annotations

import os

#: What a ground-truth path is replaced with in an error message.
HIDDEN = "<hidden>"


def ground_truth_strings(environments: list[dict]) -> set[str]:
    """The strings of environment specs that name files holding (or building) ground truth: ``map_path``,
    ``_file_path``, each of ``home_files`` (as given and as the simulator resolves it) and each mesh object's ``mesh`` (at least 4 characters long, so that
    blanking them out of a message cannot blank out ordinary words).

    Args:
        environments: environment specs (dicts; other values of their fields are ignored).

    Returns:
        The strings to hide (never raises).
    """
    found: set[str] = set()
    for env in environments:
        values = [env.get("map_path"), env.get("_file_path")]
        home = env.get("home_files")
        if isinstance(home, list):
            values += home + _resolved(home, env.get("_file_path"))
        objects = env.get("objects")
        if isinstance(objects, list):
            values += [o.get("mesh") for o in objects if isinstance(o, dict)]
        found |= {v for v in values if isinstance(v, str) and len(v) >= 4}
    return found


def _resolved(names: list, file_path) -> list[str]:
    """The absolute, symlink-free paths of ``home_files`` entries as the simulator opens them (relative ones against
    the folder of the environment file ``file_path``, else the working directory): an error names a file so,
    and the sandbox hides the folders of absolute paths only. Entries that cannot be resolved are left out."""
    out = []
    try:
        base = os.path.dirname(os.path.realpath(file_path)) if isinstance(file_path, str) and file_path \
            else os.getcwd()
        for name in names:
            if isinstance(name, str) and name and "\0" not in name:
                out.append(os.path.realpath(os.path.join(base, os.path.expanduser(name))))
    except (OSError, ValueError):  # a NUL character in the file path, a working directory gone
        pass
    return out


def redact(text: str, hidden: set[str]) -> str:
    """``text`` with every string of ``hidden`` replaced by :data:`HIDDEN` (longest first; never raises)."""
    for secret in sorted(hidden, key=len, reverse=True):
        if secret in text:
            text = text.replace(secret, HIDDEN)
    return text
