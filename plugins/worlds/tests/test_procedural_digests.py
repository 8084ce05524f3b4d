"""Procedural homes are the same on every machine: the digests of some validation homes (their five ground-truth
files' bytes and their floor plan, :mod:`tools/world_digests.py`), pinned in ``data/procedural_v5_digests.json``
from the 2-core development machine (Python 3.11, NumPy 2.4) and found equal on an H200 host (Python 3.12, NumPy 2.5)
for 100 homes, must come out equal wherever the tests run. A change to the generator that alters homes must raise
``GENERATOR_VERSION`` and pin new digests."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
PINNED = json.loads((Path(__file__).parent / "data" / "procedural_v5_digests.json").read_text())


def digests(split: str, indices: list[int]) -> dict:
    sys.path.insert(0, str(ROOT / "tools"))
    try:
        from world_digests import digests as compute
    finally:
        sys.path.remove(str(ROOT / "tools"))
    out = {}
    for i in indices:
        out.update(compute(split, i, 1)["homes"])
    return out


@pytest.fixture(autouse=True)
def own_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("BENCHBOT_CACHE_DIR", str(tmp_path / "cache"))


def test_the_pinned_version_is_the_generators():
    from benchbot_worlds.procedural.generator import GENERATOR_VERSION

    assert PINNED["generator_version"] == GENERATOR_VERSION, "pin the new version's digests (tools/world_digests.py)"


def test_every_pinned_home_is_byte_identical():
    indices = [int(name.rsplit("_", 1)[1]) for name in PINNED["homes"]]
    assert digests("val", indices) == PINNED["homes"]
