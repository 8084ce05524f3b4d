"""BenchBot hook implementations of ``benchbot_sim_taichi``: the ``carter`` robot and the ``sim_taichi`` robot
backend, which draws the worlds of ``benchbot_worlds`` (environments of type ``world``) and environments of type
``sim_taichi`` from content packs. Imports nothing heavy: Taichi is loaded by the backend."""

from __future__ import annotations

from pathlib import Path

from benchbot.core.hookspecs import hookimpl

PACKAGE_DIR = Path(__file__).resolve().parent
ROBOTS_DIR = PACKAGE_DIR / "robots"


@hookimpl
def benchbot_robots() -> list[Path]:
    """The robot specs in ``robots/`` (``carter``): the folder, whose spec files the registry reads, so a robot
    added there is registered without a change here."""
    return [ROBOTS_DIR]


def _factory(robot_spec: dict, options: dict):
    from benchbot_sim_taichi.backend import TaichiSimBackend

    return TaichiSimBackend(robot_spec, options)


@hookimpl
def benchbot_robot_backends() -> dict:
    """``{'sim_taichi': factory}``; ``factory(robot_spec, options) -> TaichiSimBackend`` (Taichi loads lazily)."""
    return {"sim_taichi": _factory}


@hookimpl
def benchbot_settings() -> list:
    """The environment variables this package reads (benchbot_sim_taichi.settings): ``BENCHBOT_TAICHI_ARCH``,
    ``BENCHBOT_TAICHI_THREADS``, ``BENCHBOT_TAICHI_FULL_POSITIONS``, ``BENCHBOT_TAICHI_QUICK_COMPILE``."""
    from benchbot_sim_taichi.settings import SETTINGS

    return list(SETTINGS)


@hookimpl
def benchbot_commands(app) -> None:
    """``benchbot sim render|export|ground-truth|plan`` (see :mod:`benchbot_sim_taichi.cli`)."""
    from benchbot_sim_taichi.cli import app as sim_app

    app.add_typer(sim_app, name="sim")
