"""Hook implementations of the ``eval_omq`` plugin: the ``omq`` evaluation method."""

from __future__ import annotations

from pathlib import Path

from benchbot.core.hookspecs import hookimpl

EVALUATION_METHODS_DIR = Path(__file__).resolve().parent / "evaluation_methods"


@hookimpl
def benchbot_evaluators() -> list[Path]:
    """Return the path of the ``omq`` evaluation-method spec (``evaluation_methods/omq.yaml``)."""
    return [EVALUATION_METHODS_DIR / "omq.yaml"]
