"""BenchBot hook implementations of ``benchbot_sim_taichi``: the ten BEAR environments (and their ground truths),
the ``carter`` robot and the ``sim_taichi`` robot backend. Imports nothing heavy: Taichi is loaded by the backend."""

from __future__ import annotations

from pathlib import Path

from benchbot.core.hookspecs import hookimpl
from benchbot_sim_taichi.bear import environment_specs, ground_truth_specs

PACKAGE_DIR = Path(__file__).resolve().parent
ROBOTS_DIR = PACKAGE_DIR / "robots"


@hookimpl
def benchbot_environments() -> list[dict]:
    """The ten BEAR environments (miniroom:1..5, house:1..5)."""
    return environment_specs()


@hookimpl
def benchbot_ground_truths() -> list[dict]:
    """The ten BEAR ground truths, found by ``name:variant``."""
    return ground_truth_specs()


@hookimpl
def benchbot_robots() -> list[str]:
    """The ``carter`` robot spec (a YAML path)."""
    return [str(ROBOTS_DIR / "carter.yaml")]


def _factory(robot_spec: dict, options: dict):
    from benchbot_sim_taichi.backend import TaichiSimBackend

    return TaichiSimBackend(robot_spec, options)


@hookimpl
def benchbot_robot_backends() -> dict:
    """``{'sim_taichi': factory}``; ``factory(robot_spec, options) -> TaichiSimBackend`` (Taichi loads lazily)."""
    return {"sim_taichi": _factory}


@hookimpl
def benchbot_batches() -> list[Path]:
    """The BEAR batches in ``batches/``: ``develop_1..3`` (4 single scenes each), ``develop_4..6`` (6 scene pairs
    each, for scene change detection) and ``bear_all`` (all ten environments)."""
    return [Path(__file__).parent / "batches"]


@hookimpl
def benchbot_commands(app) -> None:
    """``benchbot sim render|export|ground-truth`` (see :mod:`benchbot_sim_taichi.cli`)."""
    from benchbot_sim_taichi.cli import app as sim_app

    app.add_typer(sim_app, name="sim")
