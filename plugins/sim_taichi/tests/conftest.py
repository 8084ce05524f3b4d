"""Fixtures of the sim_taichi tests (real Taichi on the CPU, small images)."""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import pytest

os.environ.setdefault("BENCHBOT_TAICHI_ARCH", "cpu")

def _worlds_fixtures():
    """The benchbot_worlds tests' conftest (its ``synthetic_env`` fixture: a BEAR-style JSON world in tmp_path),
    loaded under a name of its own: one home for the fixture, used by both plugins' tests."""
    path = Path(__file__).resolve().parents[2] / "worlds" / "tests" / "conftest.py"
    spec = importlib.util.spec_from_file_location("benchbot_worlds_test_fixtures", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


synthetic_env = _worlds_fixtures().synthetic_env


@pytest.fixture(autouse=True)
def taichi_on_a_live_thread():
    """Taichi builds fields only on the thread that initialised it: when an earlier test of the run initialised it on
    the process's backend thread (a served episode of tests/), reset it so that this test's renders initialise it
    here, on the main thread. (The tests of this folder use Taichi on the main thread only.)"""
    import sys

    renderer = sys.modules.get("benchbot_sim_taichi.render.renderer")
    if renderer is not None and renderer.initialised_on_another_thread():
        renderer.release_taichi()
    yield


@pytest.fixture(scope="session")
def bear_envs():
    """The plugin's ten environment specs, keyed 'name:variant'."""
    from benchbot_worlds import bear

    return {f"{e['name']}:{e['variant']}": e for e in bear.environment_specs()}


@pytest.fixture(scope="session")
def carter_spec():
    """The carter robot spec (YAML)."""
    import yaml

    from benchbot_sim_taichi import plugin

    with open(plugin.ROBOTS_DIR / "carter.yaml", encoding="utf-8") as f:
        return yaml.safe_load(f)


@pytest.fixture
def make_backend(carter_spec):
    """make_backend(width=64, height=48, **options) → TaichiSimBackend."""
    from benchbot_sim_taichi.backend import TaichiSimBackend

    def make(width=64, height=48, **options):
        return TaichiSimBackend(carter_spec, {"arch": "cpu", "width": width, "height": height, **options})

    return make
