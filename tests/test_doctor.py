"""`benchbot doctor --json`: structure, a fix for every problem, exit code = whether the main job can run."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

REQUIRED = {"python", "packages", "main-job content", "taichi cpu", "sandbox"}


def doctor(*args, env=None):
    return subprocess.run([sys.executable, "-m", "benchbot.cli", "doctor", "--json", *args], capture_output=True,
                          text=True, timeout=400, env={**os.environ, **(env or {})})


@pytest.mark.slow
def test_doctor_json_and_exit_code(tmp_path):
    proc = doctor("--timeout", "240", env={"BENCHBOT_DATA_DIR": str(tmp_path / "data")})
    report = json.loads(proc.stdout)
    names = [c["name"] for c in report["checks"]]
    for name in ("python", "packages", "plugins", "taichi cpu", "taichi cuda", "taichi vulkan", "gpu", "ros",
                 "containers", "ray", "port 10000", "data directory"):
        assert name in names, name
    for c in report["checks"]:
        assert set(c) == {"name", "ok", "required", "detail", "fix"}
        assert c["ok"] or c["fix"], f"{c['name']} failed without a fix"
    assert {c["name"] for c in report["checks"] if c["required"]} == REQUIRED
    assert report["ok"] is all(c["ok"] for c in report["checks"] if c["required"])
    assert proc.returncode == (0 if report["ok"] else 1)
    assert report["ok"], proc.stdout  # this machine runs the main job (the test suite does)
    data = next(c for c in report["checks"] if c["name"] == "data directory")
    assert data["ok"] and str(tmp_path / "data") in data["detail"]


def test_doctor_fails_without_the_simulator(tmp_path):
    proc = doctor("--no-render", env={"BENCHBOT_ONLY_PLUGINS": "core_examples,eval_omq,task_semslam"})
    report = json.loads(proc.stdout)
    assert proc.returncode == 1 and report["ok"] is False
    content = next(c for c in report["checks"] if c["name"] == "main-job content")
    assert not content["ok"] and "sim_taichi" in content["detail"] and content["fix"]


def test_doctor_into_a_log_says_each_check_as_it_starts():
    proc = doctor("--no-render")
    assert json.loads(proc.stdout)["checks"]  # stdout keeps the JSON alone
    lines = proc.stderr.splitlines()
    for what in ("Python", "the installed packages", "the plugins", "the solution sandbox", "the data directory"):
        assert f"checking {what} …" in lines, lines
    assert "\x1b[" not in proc.stderr  # plain lines in a log


def test_doctor_names_the_packages_as_a_user_reads_them():
    from benchbot.cli.doctor_cmd import check_packages

    detail = check_packages().detail
    assert detail.startswith("benchbot ") and "; plugins of the main job: worlds " in detail
    assert "; libraries: taichi " in detail and "benchbot-" not in detail


BYTECODE_PROBE = """
import json, sys
from dataclasses import asdict
from benchbot.cli.main import get_app
from benchbot.cli.common import registry
import benchbot.cli.doctor_cmd as doctor
registry()  # what a command imports: the CLI, the registry, its plugins, NumPy
print(json.dumps(asdict(doctor.check_bytecode())))
"""


def test_modules_without_up_to_date_bytecode_are_found(tmp_path, monkeypatch):
    import importlib
    import py_compile

    from benchbot.cli.doctor_cmd import runs_from_source

    (tmp_path / "bytecode_probe_module.py").write_text("A = 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(sys, "dont_write_bytecode", True)
    module = importlib.import_module("bytecode_probe_module")
    source = module.__file__
    assert runs_from_source([module]) == [source]  # never compiled to a file
    py_compile.compile(source, cfile=importlib.util.cache_from_source(source))
    assert runs_from_source([module]) == []
    (tmp_path / "bytecode_probe_module.py").write_text("A = 22\n")  # edited: the .pyc is stale
    assert runs_from_source([module]) == [source]
    assert runs_from_source([sys, json]) == []  # built in; a compiled standard module (the venv's Python)


def test_doctor_says_when_every_command_compiles_its_modules_again(tmp_path):
    def bytecode(**env):
        done = subprocess.run([sys.executable, "-c", BYTECODE_PROBE], capture_output=True, text=True, timeout=300,
                              env={**os.environ, **env})
        assert done.returncode == 0, done.stderr
        return json.loads(done.stdout.strip().splitlines()[-1])

    empty = tmp_path / "no-bytecode"  # a bytecode folder with nothing in it: every module comes from its source
    empty.mkdir()
    got = bytecode(PYTHONPYCACHEPREFIX=str(empty), PYTHONDONTWRITEBYTECODE="1")
    assert not got["ok"] and "PYTHONDONTWRITEBYTECODE" in got["detail"] and "compileall" in got["fix"]
    assert not any(empty.iterdir())
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    done = subprocess.run([sys.executable, "-c", BYTECODE_PROBE], capture_output=True, text=True, timeout=300,
                          env={**env, "PYTHONPYCACHEPREFIX": str(tmp_path / "written")})
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout.strip().splitlines()[-1])["ok"]  # Python writes what is missing as it imports


SOLUTION_BYTECODE_PROBE = """
import json
from dataclasses import asdict
import benchbot.cli.doctor_cmd as doctor
print(json.dumps(asdict(doctor.check_solution_bytecode())))
"""


def test_doctor_says_when_sandboxed_solutions_compile_scipy_in_every_episode(tmp_path):
    """SciPy's ndimage, which the example solutions import and a command does not: with no bytecode and none written
    (a sandboxed solution can never write it) the check says every episode compiles it, and how to compile it once;
    where this process may write bytecode, the check's own import writes it and it passes."""
    def check(**env):
        base = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        done = subprocess.run([sys.executable, "-c", SOLUTION_BYTECODE_PROBE], capture_output=True, text=True,
                              timeout=300, env={**base, **env})
        assert done.returncode == 0, done.stderr
        return json.loads(done.stdout.strip().splitlines()[-1])

    empty = tmp_path / "no-bytecode"
    empty.mkdir()
    got = check(PYTHONPYCACHEPREFIX=str(empty), PYTHONDONTWRITEBYTECODE="1")
    assert not got["ok"] and "every episode compiles them again" in got["detail"] and "compileall" in got["fix"]
    assert "scipy.ndimage" in got["detail"] and not any(empty.iterdir())
    got = check(PYTHONPYCACHEPREFIX=str(tmp_path / "written"))
    assert got["ok"] and "scipy.ndimage" in got["detail"], got
    assert any((tmp_path / "written").rglob("*.pyc"))
