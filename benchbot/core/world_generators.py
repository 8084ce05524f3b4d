"""World generators: plugins that make environments on demand (``benchbot_world_generators`` hook), so that a
benchmark is not limited to the homes a package can list.

A generator has a ``name`` (``procedural``) and ``splits`` (``train``, ``val``, ``test``). Its homes are named
``<generator>_<split>_<index>`` (``procedural_val_42``) and its environments ``<home>:<variant>``
(``procedural_val_42:1``); the short form ``procedural:val:42`` (variant 1) and ``procedural:val:42:1:2`` (a scene
pair) name the same environments wherever an environment string is taken. Batches named
``<generator>_<split>_<count>`` (``procedural_val_100``) hold variant 1 of the split's first ``count`` homes.

The registry (:class:`benchbot.core.registry.Registry`) asks a generator for the specs of a name it does not hold
(:meth:`WorldGenerator.content`), validates them as any plugin's and keeps them: a generated environment, its ground
truth and a generated batch are then used like any other.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from benchbot.core.errors import SpecError
from benchbot.core.limits import MAX_GENERATED_HOMES
from benchbot.core.limits import MAX_HOME_INDEX as _MAX_HOME_INDEX

#: The most homes a generated batch (``<generator>_<split>_<count>``) may hold (``BENCHBOT_MAX_GENERATED_HOMES``
#: raises it: :data:`benchbot.core.limits.MAX_GENERATED_HOMES`).
MAX_BATCH_HOMES = int(MAX_GENERATED_HOMES.default)
#: The largest home index a generator is asked for (indices are 0 .. MAX_HOME_INDEX).
MAX_HOME_INDEX = int(_MAX_HOME_INDEX.default)

_HOME = re.compile(r"^(?P<generator>[a-z][a-z0-9]*)_(?P<split>[a-z][a-z0-9]*)_(?P<index>-?[0-9]+)$")


@runtime_checkable
class WorldGenerator(Protocol):
    """What a ``benchbot_world_generators`` implementation returns: one generator of homes.

    Attributes:
        name: lower-case letters and digits (``procedural``): the first part of its homes' names.
        splits: its splits (``("train", "val", "test")``), lower-case letters and digits.
    """

    name: str
    splits: tuple[str, ...]

    def content(self, kind: str, split: str, index: int) -> list[dict]:
        """The specs of ``kind`` (``environments`` or ``ground_truths``) of home ``index`` of ``split``: one per
        variant, as any plugin's ``benchbot_environments``/``benchbot_ground_truths`` dicts (environments of a
        simulator-free world are of type ``world``).

        Raises:
            SpecError: the home cannot be made here (e.g. a held-out split without its key), one line with the fix.
        """

    # Optional: ``prepare(homes: list[tuple[str, int]], workers: int) -> None`` makes the (split, index) homes up to
    # ``workers`` at a time before they are asked for (Registry.make_generated; a batch calls it).

    def describe(self, split: str) -> str:
        """A few words for ``benchbot list environments`` on the homes of ``split`` (what they are for, what they
        need)."""


@dataclass(frozen=True)
class HomeName:
    """A generated home's name split into its parts: ``generator``, ``split``, ``index`` (≥ 0)."""

    generator: str
    split: str
    index: int

    def __str__(self) -> str:
        return f"{self.generator}_{self.split}_{self.index}"


def _split_of(name: str, generators: dict[str, WorldGenerator], what: str, example_number: int):
    """(generator, split, number) of ``<generator>_<split>_<number>`` when a generator of ``generators`` owns it, else
    None. Raises SpecError (naming ``what`` the name is) when the split is not the generator's."""
    m = _HOME.match(name)
    if m is None or m["generator"] not in generators:
        return None
    gen = generators[m["generator"]]
    if m["split"] not in gen.splits:
        raise SpecError(f"{what}'{name}': generator '{gen.name}' has no split '{m['split']}'",
                        f"its splits: {', '.join(gen.splits)} (e.g. {gen.name}_{gen.splits[0]}_{example_number})")
    return gen, m["split"], int(m["index"])


def parse_home(name: str, generators: dict[str, WorldGenerator]) -> HomeName | None:
    """The :class:`HomeName` of ``name`` (``procedural_val_42``) when it names a home of one of ``generators``,
    else ``None`` (it is no generated home's name).

    Raises:
        SpecError: it is one generator's name pattern but the split is unknown or the index is out of range.
    """
    found = _split_of(name, generators, "", 0)
    if found is None:
        return None
    gen, split, index = found
    if not 0 <= index <= MAX_HOME_INDEX:
        raise SpecError(f"'{name}': home index {index} is out of range",
                        f"indices run from 0 to {MAX_HOME_INDEX:,}".replace(",", " "))
    return HomeName(gen.name, split, index)


def short_form(env_string: str, generators: dict[str, WorldGenerator]) -> str:
    """``procedural:val:42`` → ``procedural_val_42:1``, ``procedural:val:42:1:2`` → ``procedural_val_42:1:2``; any
    other environment string is returned as it is.

    Raises:
        SpecError: the string starts with a generator's name but is not ``GENERATOR:SPLIT:INDEX[:VARIANT...]``.
    """
    fields = env_string.split(":")
    if fields[0] not in generators:
        return env_string
    gen = generators[fields[0]]
    example = f"{gen.name}:{gen.splits[0]}:0"
    if len(fields) < 3:
        raise SpecError(f"environment '{env_string}' is not of the form {gen.name}:SPLIT:INDEX[:VARIANT...]",
                        f"e.g. {example} (variant 1) or {example}:1:2 (a scene pair); splits: {', '.join(gen.splits)}")
    home = f"{gen.name}_{fields[1]}_{fields[2]}"
    if _HOME.match(home) is None:
        raise SpecError(f"environment '{env_string}': the index '{fields[2]}' is not a whole number",
                        f"e.g. {example}")
    return f"{home}:{':'.join(fields[3:]) or '1'}"


def parse_batch(name: str, generators: dict[str, WorldGenerator]) -> tuple[WorldGenerator, str, int] | None:
    """(generator, split, count) of a generated batch's name (``procedural_val_100``), else ``None``.

    Raises:
        SpecError: an unknown split, or a count of 0 or above :data:`MAX_BATCH_HOMES`.
    """
    found = _split_of(name, generators, "batch ", 100)
    if found is None:
        return None
    gen, split, count = found
    most = int(MAX_GENERATED_HOMES.value())
    if not 1 <= count <= most:
        raise SpecError(f"batch '{name}': {count} homes is outside 1..{most}",
                        f"a generated batch holds at most {most} homes (BENCHBOT_MAX_GENERATED_HOMES); sweep more as "
                        "several batches")
    return gen, split, count


def batch_spec(gen: WorldGenerator, split: str, count: int) -> dict:
    """The batch spec ``<generator>_<split>_<count>``: variant 1 of homes 0 .. count − 1 of ``split``."""
    return {"name": f"{gen.name}_{split}_{count}",
            "environments": [f"{gen.name}_{split}_{i}:1" for i in range(count)]}
