"""BenchBot hook implementations of ``benchbot_sim_taichi``: the ten BEAR environments (and their ground truths),
the ``carter`` robot and the ``sim_taichi`` robot backend. Imports nothing heavy: Taichi is loaded by the backend."""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

from benchbot.core.hookspecs import hookimpl

PACKAGE_DIR = Path(__file__).resolve().parent
DATA_DIR = PACKAGE_DIR / "data" / "bear"
ROBOTS_DIR = PACKAGE_DIR / "robots"
BEAR_FILES = tuple(f"{n}_{v}.json" for n in ("miniroom", "house") for v in range(1, 6))
SOURCE = ('BEAR development ground truths from benchbot-addons/ground_truths_isaac_develop (QUT, 2020); '
          'Hall et al., "The Robotic Vision Scene Understanding Challenge", arXiv:2009.05246')


@lru_cache(maxsize=None)
def _load(name: str) -> dict:
    with open(DATA_DIR / name, encoding="utf-8") as f:
        return json.load(f)


def lighting_of_map_path(map_path: str) -> str:
    """The lighting name (``base``, ``day``, ``night``, ``day_extra``, ``night_extra``) encoded in an original
    Unreal ``map_path`` such as ``/Game/AI_vol3_03_base/Maps/AI_vol3_scene_03``; ``base`` if none is found."""
    first = [p for p in str(map_path).split("/") if p][1:2] or [str(map_path)]
    name = first[0]
    for suffix in ("night_extra", "day_extra", "night", "day", "base"):
        if name.endswith("_" + suffix):
            return suffix
    return "base"


def environment_specs() -> list[dict]:
    """The ten BEAR environment specs (``type: sim_taichi``, ``map_path`` = the bundled JSON's absolute path)."""
    out = []
    for fname in BEAR_FILES:
        env = _load(fname)["environment"]
        out.append({
            "name": env["name"],
            "variant": int(env["variant"]),
            "type": "sim_taichi",
            "map_path": str(DATA_DIR / fname),
            "start_pose": list(env["start_pose"]),
            "trajectory_poses": [list(p) for p in env["trajectory_poses"]],
            "object_labels": list(env["object_labels"]),
            "description": env.get("description", "").strip(),
            "robots": ["carter"],
            "lighting": lighting_of_map_path(env.get("map_path", "")),
            "source": SOURCE,
        })
    return out


def ground_truth_specs() -> list[dict]:
    """The ten ground truths ``{environment, format, ground_truth}`` as published (``environment._file_path``
    dropped)."""
    out = []
    for fname in BEAR_FILES:
        d = json.loads(json.dumps(_load(fname)))  # deep copy
        d["environment"].pop("_file_path", None)
        out.append(d)
    return out


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
