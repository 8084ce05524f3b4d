"""Ground truth is never served: the strings that name ground-truth files, and text with them blanked out.

:class:`~benchbot.core.server.service.BackendService` gathers the strings; every error the server answers passes
through :func:`redact` (:func:`~benchbot.core.server.http_errors.error_response`).
"""

from __future__ import annotations

#: What a ground-truth path is replaced with in an error message.
HIDDEN = "<hidden>"


def ground_truth_strings(environments: list[dict]) -> set[str]:
    """The strings of environment specs that name files holding (or building) ground truth: ``map_path``,
    ``_file_path``, each of ``home_files`` and each mesh object's ``mesh`` (at least 4 characters long, so that
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
            values += home
        objects = env.get("objects")
        if isinstance(objects, list):
            values += [o.get("mesh") for o in objects if isinstance(o, dict)]
        found |= {v for v in values if isinstance(v, str) and len(v) >= 4}
    return found


def redact(text: str, hidden: set[str]) -> str:
    """``text`` with every string of ``hidden`` replaced by :data:`HIDDEN` (longest first; never raises)."""
    for secret in sorted(hidden, key=len, reverse=True):
        if secret in text:
            text = text.replace(secret, HIDDEN)
    return text
