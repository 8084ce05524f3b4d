"""``benchbot sim prepare`` (benchbot_sim_taichi/prepare.py): run into empty caches, it compiles the kernels and
builds the scene, so that a later process loading the environment builds and compiles nothing; its steps; its
one-line errors."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

#: A later process: loads ENV as an episode does and renders with soft shadows; prints the stages it went through.
LATER = r"""
import json, sys
from benchbot.core import stages
from benchbot.core.registry import get_registry
from benchbot.core.seeding import environment_world_seed
from benchbot_sim_taichi.backend import TaichiSimBackend, trajectory_cameras
from benchbot_sim_taichi.render.renderer import Renderer, intrinsics
seen = []
env = get_registry().scenes(sys.argv[1])[0]
with stages.listening(lambda e: seen.append(e.name) if e.kind == "start" else None):
    backend = TaichiSimBackend(get_registry().get("robots", "carter"), {"arch": "cpu"})
    backend.load_scene(env, seed=environment_world_seed(0, env))
    soft = Renderer("cpu", shadow_samples=2)
    soft.set_scene(backend.scene)
    soft.render(intrinsics(8, 6, 90.0), trajectory_cameras(backend.scene)[0], 8, 6)
print("SEEN " + json.dumps(seen))
"""


def _env(tmp_path: Path) -> dict:
    return dict(os.environ, BENCHBOT_CACHE_DIR=str(tmp_path / "cache"),
                TI_OFFLINE_CACHE_FILE_PATH=str(tmp_path / "taichi"), BENCHBOT_SERVICE="off")


@pytest.mark.slow
def test_prepare_compiles_and_builds_so_that_a_later_process_does_neither(tmp_path):
    env = _env(tmp_path)
    proc = subprocess.run([sys.executable, "-m", "benchbot.cli", "sim", "prepare", "miniroom:4", "--arch", "cpu",
                           "--json"], env=env, capture_output=True, text=True, timeout=900, stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stderr[-3000:]
    summary = json.loads(proc.stdout)
    assert summary["kernel_cache"] == str(tmp_path / "taichi") and summary["kernel_cache_bytes"] > 100_000
    assert summary["scene_cache_bytes"] > 0 and Path(summary["scene_cache"]).is_dir()
    assert "miniroom:4: scene, shadow maps, baked light and fast mode's kernels:" in proc.stderr  # each step's time
    assert "compiling kernels" in proc.stderr
    kernels = sorted(p.name for p in (tmp_path / "taichi").iterdir())

    later = subprocess.run([sys.executable, "-c", LATER, "miniroom:4"], env=env, capture_output=True, text=True,
                           timeout=900, stdin=subprocess.DEVNULL)
    assert later.returncode == 0, later.stderr[-3000:]
    seen = json.loads([x for x in later.stdout.splitlines() if x.startswith("SEEN ")][-1][5:])
    assert "loading the scene" in seen and "loading cached kernels" in seen, seen
    assert not {"building the scene", "compiling kernels"} & set(seen), seen
    assert sorted(p.name for p in (tmp_path / "taichi").iterdir()) == kernels  # no kernel compiled anew


def test_the_steps_prepare_each_environment_then_the_other_kernels():
    from benchbot_sim_taichi import prepare

    envs = [("miniroom:1", {"name": "miniroom", "variant": 1}), ("house:1", {"name": "house", "variant": 1})]
    labels = [s.label for s in prepare.steps(envs, {}, {"arch": "cpu"})]
    assert labels == ["miniroom:1: scene, shadow maps, baked light and fast mode's kernels",
                      "house:1: scene, shadow maps, baked light and fast mode's kernels",
                      "the shading kernel with shadow rays (on miniroom:1)"]
    assert prepare.steps(envs, {}, {"arch": "cpu"}, quality=True)[-1].label == "quality mode's kernels (on miniroom:1)"
    with pytest.raises(ValueError, match="no environment"):
        prepare.steps([], {}, {"arch": "cpu"})


@pytest.mark.parametrize("args, says", [
    (["--arch", "vulkan"], "unknown --arch 'vulkan'"),
    (["nowhere:7"], "nowhere"),
])
def test_prepare_refuses_bad_input_in_one_line(tmp_path, args, says):
    proc = subprocess.run([sys.executable, "-m", "benchbot.cli", "sim", "prepare", *args], env=_env(tmp_path),
                          capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL)
    assert proc.returncode != 0
    assert says in proc.stderr and "Traceback" not in proc.stderr, proc.stderr
    assert not (tmp_path / "taichi").exists()  # refused before anything was compiled


def test_workers_give_the_threads_a_batch_worker_gets(monkeypatch):
    """``--workers N``: the steps run with BENCHBOT_TAICHI_THREADS = cores // N (as ``benchbot batch --workers N``
    gives each worker; Taichi keys its kernels by it), unless it is set already."""
    from typer.testing import CliRunner

    from benchbot_sim_taichi import prepare
    from benchbot_sim_taichi.cli import app

    seen = []
    monkeypatch.setattr(prepare, "steps", lambda *a, **k: [prepare.Step("look", lambda: seen.append(
        os.environ.get("BENCHBOT_TAICHI_THREADS")))])
    monkeypatch.setattr(prepare, "finish", lambda: {"kernel_cache": None, "kernel_cache_bytes": 0,
                                                    "scene_cache": "x", "scene_cache_bytes": 0})
    monkeypatch.delenv("BENCHBOT_TAICHI_THREADS", raising=False)
    for args, want in ((["--workers", "2"], str(max(1, (os.cpu_count() or 1) // 2))), ([], None)):
        monkeypatch.delenv("BENCHBOT_TAICHI_THREADS", raising=False)
        result = CliRunner().invoke(app, ["prepare", "miniroom:1", "--arch", "cpu", "--json", *args])
        assert result.exit_code == 0, result.output
        assert seen[-1] == want
    monkeypatch.setenv("BENCHBOT_TAICHI_THREADS", "7")
    assert CliRunner().invoke(app, ["prepare", "miniroom:1", "--arch", "cpu", "--workers", "2"]).exit_code == 0
    assert seen[-1] == "7"
