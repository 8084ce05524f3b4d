"""The ten BEAR environments (``miniroom:1``-``5``, ``house:1``-``5``) and their ground truths, as data: the
ground-truth JSON files in ``data/bear/`` (credited in ``data/bear/ATTRIBUTION.md``) as environment and ground-truth
specs for :mod:`benchbot_worlds.plugin` to register."""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent
DATA_DIR = PACKAGE_DIR / "data" / "bear"
BEAR_HOMES = ("miniroom", "house")
BEAR_FILES = tuple(f"{n}_{v}.json" for n in BEAR_HOMES for v in range(1, 6))
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


def home_files_of(name: str) -> list[str]:
    """The absolute paths of the five variants' ground-truth files of the BEAR home ``name`` (``miniroom``,
    ``house``), by variant: the ``home_files`` of each of its environments, so that the five share one floor plan."""
    return [str(DATA_DIR / f) for f in BEAR_FILES if f.rsplit("_", 1)[0] == name]


def environment_specs() -> list[dict]:
    """The ten BEAR environment specs (``type: world``, ``map_path`` = the bundled JSON's absolute path,
    ``home_files`` = the five files of its home: its variants share their furnished floor plan)."""
    out = []
    for fname in BEAR_FILES:
        env = _load(fname)["environment"]
        out.append({
            "name": env["name"],
            "variant": int(env["variant"]),
            "type": "world",
            "map_path": str(DATA_DIR / fname),
            "home_files": home_files_of(env["name"]),
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
