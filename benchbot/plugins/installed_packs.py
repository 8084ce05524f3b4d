"""Built-in plugin ``content_packs``: the content of the packs installed with ``benchbot install ./my_pack``
(``<data dir>/packs/*``, see :mod:`benchbot.packs.content_packs`)."""

from __future__ import annotations

from typing import Any

from benchbot.core.hookspecs import hookimpl


def _specs(kind: str) -> list[Any]:
    from benchbot.packs.content_packs import load_installed_specs

    return load_installed_specs().get(kind, [])


@hookimpl
def benchbot_tasks() -> list[Any]:
    """Task specs of the installed packs (``tasks/``)."""
    return _specs("tasks")


@hookimpl
def benchbot_robots() -> list[Any]:
    """Robot specs of the installed packs (``robots/``)."""
    return _specs("robots")


@hookimpl
def benchbot_environments() -> list[Any]:
    """Environment specs of the installed packs (``environments/``; relative ``map_path`` resolved)."""
    return _specs("environments")


@hookimpl
def benchbot_formats() -> list[Any]:
    """Results-format specs of the installed packs (``formats/``)."""
    return _specs("formats")


@hookimpl
def benchbot_evaluators() -> list[Any]:
    """Evaluation methods of the installed packs (``evaluation_methods/``)."""
    return _specs("evaluators")


@hookimpl
def benchbot_examples() -> list[Any]:
    """Example specs of the installed packs (``examples/``)."""
    return _specs("examples")


@hookimpl
def benchbot_batches() -> list[Any]:
    """Batch specs of the installed packs (``batches/``)."""
    return _specs("batches")


@hookimpl
def benchbot_ground_truths() -> list[Any]:
    """Ground truths of the installed packs (``ground_truths/*.json``)."""
    return _specs("ground_truths")
