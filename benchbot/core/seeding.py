"""The seeds of a world: a name and variant give one scene, wherever the environment stands in a batch.

Three kinds of seed make a scene and an episode (docs/noise.md, *Seeds*); a simulator is given the world seed and
derives the home seed from the environment's name:

* the **world seed** fixes the rest of a scene's look (the colour variation of objects drawn with primitives):
  :func:`world_seed` of the run's seed (``benchbot batch --seed``, ``benchbot run --seed``; the same for every
  episode of a batch) and the environment's ``name:variant``. The same environment therefore builds the same scene
  in any batch, whatever the order of ``--envs`` or the repetition; another ``--seed`` gives another look.
* the **home seed** fixes what a home is, the same in all its variants and under every ``--seed``: a furnished
  home's floor plan (rooms, walls, doors, windows, lamps), its floors' and walls' materials, its furniture and the
  models its ground-truth objects are drawn with (:func:`home_seed` of the environment's ``name``). The variants of a
  home (``miniroom:1`` … ``miniroom:5``) are one house with objects moved, so what scene change detection compares
  differs only where the objects do.
* the **episode seed** (``--seed`` + the episode's index in a batch) seeds what should differ between repetitions:
  sensor noise, odometry noise, actuation noise.
"""

from __future__ import annotations

import zlib


def world_seed(seed: int, name: str, variant: int | str) -> int:
    """The seed of the world ``name:variant`` under the run's ``seed``: a stable hash, the same in every process
    and Python version (CRC-32, not Python's salted ``hash``).

    Args:
        seed: the run's world seed (an int; ``--seed``, 0 by default).
        name, variant: the environment's name and variant (``miniroom``, ``1``).

    Returns:
        An int in [0, 2**32): ``zlib.crc32(b"<name>:<variant>")`` combined with ``seed`` by a second CRC-32 over the
        seed's decimal text, so neighbouring seeds give unrelated worlds.
    """
    key = zlib.crc32(f"{name}:{variant}".encode("utf-8"))
    return zlib.crc32(str(int(seed)).encode("ascii"), key)


def environment_world_seed(seed: int, environment: dict) -> int:
    """:func:`world_seed` of an environment spec (its ``name`` and ``variant`` fields).

    Raises:
        KeyError: ``environment`` has no ``name`` or no ``variant``.
    """
    return world_seed(seed, environment["name"], environment["variant"])


def home_seed(name: str) -> int:
    """The seed of the home ``name`` (an environment's ``name``: ``miniroom``, ``house``): a stable hash of the name
    alone, the same for every variant and every run seed, so a home's variants are one house (module docstring).

    Args:
        name: the environment's name (its home).

    Returns:
        An int in [0, 2**32): ``zlib.crc32(b"home:<name>")``.
    """
    return zlib.crc32(f"home:{name}".encode("utf-8"))
