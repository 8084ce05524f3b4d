"""BenchBot hook implementations of ``benchbot_worlds``: the ten BEAR environments and their ground truths, and the
BEAR batches. Imports nothing heavy (no simulator, no mesh library)."""

from __future__ import annotations

from pathlib import Path

from benchbot.core.hookspecs import hookimpl
from benchbot_worlds.bear import environment_specs, ground_truth_specs

PACKAGE_DIR = Path(__file__).resolve().parent


@hookimpl
def benchbot_environments() -> list[dict]:
    """The ten BEAR environments (miniroom:1..5, house:1..5), of type ``world``."""
    return environment_specs()


@hookimpl
def benchbot_ground_truths() -> list[dict]:
    """The ten BEAR ground truths, found by ``name:variant``."""
    return ground_truth_specs()


@hookimpl
def benchbot_batches() -> list[Path]:
    """The BEAR batches in ``batches/``: ``develop_1..3`` (4 single scenes each), ``develop_4..6`` (6 scene pairs
    each, for scene change detection) and ``bear_all`` (all ten environments)."""
    return [PACKAGE_DIR / "batches"]


@hookimpl
def benchbot_world_generators() -> list:
    """The ``procedural`` generator: homes of the splits train, val and test, made on demand."""
    from benchbot_worlds.procedural.worlds import ProceduralWorlds

    return [ProceduralWorlds()]


@hookimpl
def benchbot_settings() -> list:
    """The environment variables this package reads (benchbot_worlds.settings): ``BENCHBOT_SIM_STYLE`` and ``BENCHBOT_WORLDS_KEY_FILE``."""
    from benchbot_worlds.settings import SETTINGS

    return list(SETTINGS)


@hookimpl
def benchbot_commands(app) -> None:
    """``benchbot worlds generate|key`` (see :mod:`benchbot_worlds.cli`)."""
    from benchbot_worlds.cli import app as worlds_app

    app.add_typer(worlds_app, name="worlds")
