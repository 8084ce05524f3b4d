"""End to end: `benchbot plugin new` → wheel → a fresh venv with the core (path install) and the wheel →
its content in `benchbot list`/`show`, its own tests pass, `benchbot run` validates and serves with it (task from a
content pack installed by path) → `benchbot uninstall` → gone."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.slow

TASK = "name: e2e:passive\nactions: [move_next]\nobservations: [image_rgb, image_depth, laser, poses]\n"


def sh(*cmd, env=None, timeout=600, cwd=None):
    proc = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, env=env, timeout=timeout, cwd=cwd)
    assert proc.returncode == 0, f"{' '.join(map(str, cmd))} failed:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return proc


@pytest.mark.skipif(shutil.which("uv") is None, reason="needs uv")
def test_generated_sim_plugin_end_to_end(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("BENCHBOT_ONLY_PLUGINS", "VIRTUAL_ENV", "PYTHONPATH")}
    env.update(BENCHBOT_DATA_DIR=str(tmp_path / "data"), UV_PYTHON_DOWNLOADS="never")
    project = Path(sh(sys.executable, "-m", "benchbot.cli", "plugin", "new", "demo", "--kind", "sim", "-o", tmp_path,
                      env=env).stdout.strip())
    assert project.name == "benchbot-sim-demo" and (project / ".github/workflows/ci.yml").is_file()
    sh("uv", "build", "--wheel", "--out-dir", tmp_path / "dist", project, env=env)
    (wheel,) = (tmp_path / "dist").glob("benchbot_sim_demo-0.1.0-*.whl")
    venv = tmp_path / "venv"
    sh("uv", "venv", "--python", sys.executable, venv, env=env)
    py, bb = venv / "bin" / "python", venv / "bin" / "benchbot"
    core = tmp_path / "core"  # a copy without .venv and caches: a non-editable path install of the core
    shutil.copytree(ROOT, core, ignore=shutil.ignore_patterns(".venv", ".git", "runs", "*.pyc", "__pycache__",
                                                              "tests", ".pytest_cache", "benchmarks", "dist"))
    sh("uv", "pip", "install", "--python", py, core, "pytest", env=env)
    # `benchbot install` of the wheel goes through uv into this venv (benchbot's own environment)
    sh(bb, "install", wheel, env=env)
    plugins = {p["name"]: p for p in json.loads(sh(bb, "plugins", "--json", env=env).stdout)}
    assert plugins["sim_demo"]["distribution"] == "benchbot-sim-demo" and plugins["sim_demo"]["status"] == "loaded"
    assert plugins["sim_demo"]["registers"]["robot_backends"] == ["sim_demo"]
    assert "benchbot_robot_backends" in plugins["sim_demo"]["hooks"]
    envs = [e["name"] for e in json.loads(sh(bb, "list", "environments", "--json", env=env).stdout)]
    assert envs == ["demo_room:1"]
    assert "demo_bot" in sh(bb, "show", "robots", "demo_bot", env=env).stdout
    # its tests pass unchanged against the installed wheel (contract fixture from the core's pytest11 entry point)
    sh(py, "-m", "pytest", "-q", "-p", "no:cacheprovider", project / "tests", env=env, cwd=tmp_path)
    # a content pack supplies a task; `benchbot run` validates the combination and serves it
    pack = tmp_path / "e2e_pack"
    (pack / "tasks").mkdir(parents=True)
    (pack / "tasks" / "e2e.yaml").write_text(TASK)
    sh(bb, "install", pack, env=env)
    run = subprocess.Popen([bb, "run", "--env", "demo_room:1", "--robot", "demo_bot", "--task", "e2e:passive",
                            "--port", "0"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        deadline, seen = time.monotonic() + 120, ""
        while time.monotonic() < deadline and "backend ready" not in seen:
            line = run.stderr.readline()
            if not line and run.poll() is not None:
                break
            seen += line
        assert "backend ready" in seen, seen
    finally:
        run.terminate()
        run.wait(timeout=30)
    sh(bb, "uninstall", "benchbot-sim-demo", "e2e_pack", env=env)
    plugins = {p["name"] for p in json.loads(sh(bb, "plugins", "--json", env=env).stdout)}
    assert "sim_demo" not in plugins
    assert json.loads(sh(bb, "list", "environments", "--json", env=env).stdout) == []
    assert json.loads(sh(bb, "list", "tasks", "--json", env=env).stdout) == []


@pytest.mark.skipif(shutil.which("uv") is None, reason="needs uv")
@pytest.mark.parametrize("kind", ["sim", "robot", "task", "eval", "env"])
def test_a_generated_projects_readme_works_outside_this_checkout(tmp_path, kind):
    """The README's Develop commands, run as written in a project made outside the checkout, install it with
    BenchBot from where this machine's came from ([tool.uv.sources]) and pass its tests; nothing points users to the
    original QUT project."""
    env = {k: v for k, v in os.environ.items() if k not in ("BENCHBOT_ONLY_PLUGINS", "VIRTUAL_ENV", "PYTHONPATH")}
    env.update(BENCHBOT_DATA_DIR=str(tmp_path / "data"), UV_PYTHON_DOWNLOADS="never")
    env.pop("UV_PYTHON", None)  # it would make `uv pip install` install into that interpreter's environment
    project = Path(sh(sys.executable, "-m", "benchbot.cli", "plugin", "new", "lidar_noise", "--kind", kind,
                      "-o", tmp_path, env=env).stdout.strip())
    assert project.name == f"benchbot-{kind}-lidar-noise" and not project.is_relative_to(ROOT)
    readme = (project / "README.md").read_text()
    assert "qcr" not in readme and "github.com" not in readme
    develop = readme.split("## Develop", 1)[1].split("```bash", 1)[1].split("```", 1)[0]
    commands = [line.split("#", 1)[0].strip() for line in develop.splitlines() if line.split("#", 1)[0].strip()]
    assert commands[:2] == ['uv venv && uv pip install -e ".[test]"', "uv run --no-sync pytest"]
    for command in commands:
        sh("bash", "-c", command, env=env, cwd=project)
    assert list((project / "dist").glob(f"benchbot_{kind}_lidar_noise-0.1.0-*.whl"))
    import importlib.metadata

    with pytest.raises(importlib.metadata.PackageNotFoundError):  # it went into the project's .venv, not this one
        importlib.metadata.distribution(f"benchbot-{kind}-lidar-noise")
    assert list((project / ".venv").glob(f"lib/python*/site-packages/*benchbot_{kind}_lidar_noise*"))
    assert "[tool.uv.sources]" in (project / "pyproject.toml").read_text()
