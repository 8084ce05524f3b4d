"""The ``procedural`` world generator (hook ``benchbot_world_generators``): homes ``procedural_<split>_<index>``
of the splits ``train``, ``val`` and ``test`` (:mod:`.splits`), each made by
:func:`benchbot_worlds.procedural.generator.generate_home` from its seed and written, once, as five BEAR-format
ground-truth files (its variants) under ``<cache dir>/worlds/`` — the files its environments' ``map_path`` and
``home_files`` name, so that every simulator builds the home as it builds a BEAR one.

The files of a home are a cache: their folder is named by the generator's version and a digest of the generator's
code (and, for the test split, the key's public id), so that changed code never reuses them; they are written
atomically and made again when missing. The cache directory is hidden from sandboxed solutions.
"""

from __future__ import annotations

import functools
import hashlib
import json
from pathlib import Path

from benchbot.core.atomic import write_text
from benchbot.packs.pack_layout import cache_dir
from benchbot_worlds.procedural import splits

GENERATOR_NAME = "procedural"
#: Where generated homes are credited: their environments' ``source``.
SOURCE = "benchbot-worlds procedural home generator"


@functools.lru_cache(maxsize=1)
def code_digest() -> str:
    """12 hex characters of SHA-256 over the path and bytes of every ``.py`` file of this package
    (``benchbot_worlds.procedural``), in sorted order."""
    package = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for path in sorted(package.rglob("*.py")):
        h.update(str(path.relative_to(package)).encode() + b"\0" + path.read_bytes())
    return h.hexdigest()[:12]


def home_name(split: str, index: int) -> str:
    """``procedural_<split>_<index>``."""
    return f"{GENERATOR_NAME}_{split}_{index}"


def _home_folder(split: str, index: int, version: int, key: bytes | None) -> Path:
    folder = f"{split}-{splits.key_id(key)}" if key is not None else split
    return cache_dir() / "worlds" / f"{GENERATOR_NAME}-v{version}-{code_digest()}" / folder / str(index)


def home_files(split: str, index: int) -> list[Path]:
    """The five ground-truth files (variants 1..5, in order) of home ``index`` of ``split``, made if missing.

    Raises:
        SpecError: unknown split, negative index, or the test split without this host's key.
    """
    from benchbot_worlds.procedural.generator import GENERATOR_VERSION, generate_home

    key = splits.read_key() if split == splits.HELD_OUT else None
    seed = splits.home_seed(split, index, GENERATOR_VERSION, key)
    folder = _home_folder(split, index, GENERATOR_VERSION, key)
    name = home_name(split, index)
    files = [folder / f"{name}_{v}.json" for v in range(1, 6)]
    if all(f.is_file() for f in files):
        return files
    home = generate_home(seed, name)
    folder.mkdir(parents=True, exist_ok=True)
    for path, variant in zip(files, home.variants):
        write_text(path, json.dumps(variant, sort_keys=True, indent=1) + "\n")
    return files


@functools.lru_cache(maxsize=256)
def _load(path: str) -> dict:
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def environment_spec(path: Path, files: list[Path], split: str, index: int) -> dict:
    """The environment spec (type ``world``) of one variant's ground-truth file ``path`` of a home whose variants are
    ``files``."""
    from benchbot_worlds.bear import lighting_of_map_path

    env = _load(str(path))["environment"]
    return {
        "name": env["name"], "variant": int(env["variant"]), "type": "world", "map_path": str(path),
        "home_files": [str(f) for f in files], "start_pose": list(env["start_pose"]),
        "trajectory_poses": [list(p) for p in env["trajectory_poses"]],
        "object_labels": list(env["object_labels"]), "description": env.get("description", ""),
        "robots": ["carter"], "lighting": lighting_of_map_path(env.get("map_path", "")),
        "source": f"{SOURCE}, split {split}, home {index}",
    }


class ProceduralWorlds:
    """The ``procedural`` generator (:class:`benchbot.core.world_generators.WorldGenerator`)."""

    name = GENERATOR_NAME
    splits = splits.SPLITS

    def content(self, kind: str, split: str, index: int) -> list[dict]:
        """Environment (``kind="environments"``) or ground-truth specs of the five variants of home ``index`` of
        ``split`` (see :func:`home_files`; raises its SpecError)."""
        files = home_files(split, index)
        if kind == "environments":
            return [environment_spec(f, files, split, index) for f in files]
        out = []
        for f in files:
            data = json.loads(json.dumps(_load(str(f))))
            out.append({k: data[k] for k in ("environment", "format", "ground_truth")})
        return out

    def prepare(self, homes: list[tuple[str, int]], workers: int) -> None:
        """Make the files of ``homes`` ((split, index) pairs) that are missing, in up to ``workers`` processes (at
        most one per CPU; spawned, so nothing of this process is shared): a sweep over 100 new homes on a 16-core
        host makes them in seconds instead of one by one (:func:`home_files` in each)."""
        import os
        from concurrent.futures import ProcessPoolExecutor
        from multiprocessing import get_context

        if any(split == splits.HELD_OUT for split, _ in homes):
            splits.read_key()  # its one-line error here, not from a worker process
        processes = max(1, min(int(workers), os.cpu_count() or 1, len(homes)))
        if processes == 1:
            for split, index in homes:
                home_files(split, index)
            return
        with ProcessPoolExecutor(processes, mp_context=get_context("spawn")) as pool:
            list(pool.map(home_files, [s for s, _ in homes], [i for _, i in homes]))

    def describe(self, split: str) -> str:
        """A few words on the homes of ``split`` for ``benchbot list environments``."""
        return {"train": "procedural homes to train on (public)",
                "val": "procedural homes to validate on (public)",
                "test": "held-out procedural homes (only a host with the key: benchbot worlds key)"}[split]
