"""The seed of a world: a name and variant give one scene, wherever the environment stands in a batch.

Two kinds of seed reach a simulator (docs/noise.md, *Seeds*):

* the **world seed** fixes what a scene looks like (object colour variation, the furnished home's model choices):
  :func:`world_seed` of the run's seed (``benchbot batch --seed``, ``benchbot run --seed``; the same for every
  episode of a batch) and the environment's ``name:variant``. The same environment therefore builds the same scene
  in any batch, whatever the order of ``--envs`` or the repetition; another ``--seed`` gives another look.
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
