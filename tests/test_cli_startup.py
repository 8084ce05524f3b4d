"""What ``benchbot --version`` and ``--help`` load: the version imports no command and builds no registry; help
loads the plugins (their commands are listed) but builds no registry; a command builds it as before, importing no
jsonschema once its specs are known valid."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from benchbot.cli.main import asks_only_for_help

PROBE = """
import contextlib, io, json, sys
sys.argv = ["benchbot", *json.loads(sys.argv[1])]
out = io.StringIO()
code = 0
with contextlib.redirect_stdout(out):
    try:
        from benchbot.cli.main import main
        main()
    except SystemExit as exc:
        code = exc.code or 0
registry = sys.modules.get("benchbot.core.registry")
import atexit, gc
atexit._run_exitfuncs()  # what the interpreter runs at exit, before its last garbage collections
print(json.dumps({
    "code": code, "out": out.getvalue(),
    "commands_imported": "benchbot.cli.batch_cmd" in sys.modules,
    "registry_built": bool(registry and registry.get_registry.cache_info().currsize),
    "frozen_at_exit": gc.get_freeze_count(),
    "jsonschema_imported": "jsonschema" in sys.modules,
}))
"""


def probe(*args: str, env: dict | None = None) -> dict:
    done = subprocess.run([sys.executable, "-c", PROBE, json.dumps(list(args))], capture_output=True, text=True,
                          timeout=120, env={**__import__("os").environ, "COLUMNS": "160", **(env or {})})
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("flag", ["--version", "-v"])
def test_version_imports_no_command_and_builds_no_registry(flag: str) -> None:
    from benchbot import __version__

    got = probe(flag)
    assert got["out"] == f"benchbot {__version__}\n" and got["code"] == 0
    assert not got["commands_imported"] and not got["registry_built"]


def test_help_lists_plugin_commands_without_building_the_registry() -> None:
    got = probe("--help")
    assert got["code"] == 0 and not got["registry_built"]
    assert "batch" in got["out"] and " sim " in got["out"]  # a core command and sim_taichi's (benchbot_commands)
    plugin_help = probe("sim", "--help")
    assert plugin_help["code"] == 0 and not plugin_help["registry_built"] and "render" in plugin_help["out"]


def test_a_command_still_builds_the_registry() -> None:
    got = probe("list", "tasks")
    assert got["code"] == 0 and got["registry_built"]


def test_a_command_whose_specs_are_known_valid_imports_no_jsonschema(tmp_path) -> None:
    cache = {"BENCHBOT_CACHE_DIR": str(tmp_path / "cache")}
    first = probe("list", "tasks", env=cache)  # validates every spec, and remembers them (specs.ValidStore)
    assert first["code"] == 0 and first["registry_built"] and first["jsonschema_imported"]
    again = probe("list", "tasks", env=cache)
    assert again["code"] == 0 and again["registry_built"] and not again["jsonschema_imported"]
    assert again["out"] == first["out"]


@pytest.mark.parametrize(("argv", "only_help"), [
    ([], True), (["--help"], True), (["-h"], True), (["batch", "--help"], True), (["sim", "render", "-h"], True),
    (["list", "tasks"], False), (["--version"], False),
    (["submit", "--native", "python", "my.py", "-h"], False),  # the solution's own -h
    (["submit", "-a", "--help"], False),
])
def test_asks_only_for_help(argv: list[str], only_help: bool) -> None:
    assert asks_only_for_help(argv) is only_help


def test_a_command_freezes_its_objects_for_the_exit() -> None:
    """A command's exit handlers freeze its objects (``gc.freeze``), so that the interpreter's last garbage
    collections at exit skip them (0.1 s of README command 1's 3.4 s on the 2-core CPU); ``--version`` returns
    before and leaves them alone."""
    assert probe("list", "tasks")["frozen_at_exit"] > 10_000
    assert probe("--version")["frozen_at_exit"] == 0


BLAS_PROBE = """
import contextlib, io, json, os, sys
if sys.argv[1] == "command":
    sys.argv = ["benchbot", "list", "tasks"]
    from benchbot.cli.main import main
    with contextlib.redirect_stdout(io.StringIO()):
        try:
            main()
        except SystemExit:
            pass
import numpy as np
a = np.ones((400, 400))
a @ a
print(json.dumps({"threads": len(os.listdir("/proc/self/task")),
                  "variable": os.environ.get("OPENBLAS_NUM_THREADS")}))
"""


@pytest.mark.skipif(not sys.platform.startswith("linux") or len(os.sched_getaffinity(0)) < 2,
                    reason="counts the threads in /proc; OpenBLAS starts one per core, so two cores are needed")
def test_the_command_runs_one_blas_thread_and_leaves_the_environment_as_it_was() -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")}

    def threads(mode: str) -> dict:
        done = subprocess.run([sys.executable, "-c", BLAS_PROBE, mode], capture_output=True, text=True, env=env,
                              timeout=120)
        assert done.returncode == 0, done.stderr[-2000:]
        return json.loads(done.stdout.strip().splitlines()[-1])

    plain, command = threads("numpy"), threads("command")
    assert plain["threads"] > 1, "NumPy's OpenBLAS started no thread per core: the probe cannot tell"
    assert command == {"threads": 1, "variable": None}
