"""Hostile files (issue 14): content packs that name functions outside the pack (``os:system``), YAML alias bombs,
invalid UTF-8, deep nesting, huge integers and oversized files in `benchbot install`; zip bombs, oversized and deep
results in `benchbot eval`. Each is refused with a one-line error naming the file and the limit, in bounded time
and memory, by the real command in a subprocess."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from benchbot.core import content_packs as cp
from benchbot.core.errors import SpecError
from benchbot.core.registry import Registry

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]
MEASURE = ("import resource, subprocess, sys; p = subprocess.run(sys.argv[1:]); "
           "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, file=sys.stderr); sys.exit(p.returncode)")
"""Runs a command and prints its peak resident memory (KiB) as the last stderr line."""

EVIL_FORMAT = "name: evil_fmt\ndescription: shell\nfunctions:\n  create: \"{function}\"\n"
TASK = ("name: evil:passive:ground_truth\nactions: [move_next]\nobservations: [poses]\nresults_format: evil_fmt\n"
        "description: A task whose results format runs shell commands.\n")
ALLOWED = "benchbot_task_semslam.formats:create_object_map"


@pytest.fixture(autouse=True)
def data_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("BENCHBOT_DATA_DIR", str(tmp_path / "data"))
    return tmp_path / "data"


def make_pack(root: Path, files: dict[str, str | bytes]) -> Path:
    for rel, content in files.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, bytes):
            (root / rel).write_bytes(content)
        else:
            (root / rel).write_text(content)
    return root


def cli(*args: str, env: dict | None = None, measure: bool = False, timeout: float = 120) -> tuple:
    """``(process, seconds, peak RSS in MiB or None)`` of ``benchbot ARGS`` run as a user would."""
    cmd = [sys.executable, "-c", MEASURE, *BENCHBOT, *args] if measure else [*BENCHBOT, *args]
    start = time.monotonic()
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, "COLUMNS": "200", **(env or {})})
    seconds = time.monotonic() - start
    rss = None
    if measure:
        *lines, last = proc.stderr.rstrip("\n").splitlines()
        rss = int(last) / 1024
        proc.stderr = "\n".join(lines) + "\n"
    return proc, seconds, rss


def one_line_error(proc: subprocess.CompletedProcess) -> str:
    """The single ``error:`` line of a failed command (asserting there is exactly one and no traceback)."""
    assert "Traceback" not in proc.stderr, proc.stderr
    errors = [line for line in proc.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, proc.stderr
    return errors[0]


# --- 1. functions named by packs -------------------------------------------------------------------------------


def test_install_refuses_a_format_that_names_os_system(tmp_path, data_dir):
    marker = tmp_path / "ran"
    pack = make_pack(tmp_path / "evil", {"formats/f.yaml": EVIL_FORMAT.format(function="os:system"),
                                         "tasks/t.yaml": TASK})
    proc, _, _ = cli("install", str(pack))
    assert proc.returncode == 3, proc.stderr
    one_line_error(proc)
    assert "  formats/f.yaml: $.functions.create: 'os:system' is neither code in the pack nor in a module of an " \
           "installed plugin's formats/evaluators (allowed: " in proc.stderr
    assert not (data_dir / "packs" / "evil").exists() and not marker.exists()
    registry = Registry()
    for function in ("subprocess:getoutput", "benchbot.core.atomic:write_json", "benchbot_packs.other.x:y"):
        (pack / "formats" / "f.yaml").write_text(EVIL_FORMAT.format(function=function))
        assert f"formats/f.yaml: $.functions.create: '{function}'" in cp.verify_pack(pack).errors[0]  # --dry-run
        with pytest.raises(cp.PackError) as exc:
            cp.install_pack(pack, allow_code=True, registry=registry)
        assert f"formats/f.yaml: $.functions.create: '{function}'" in exc.value.details[0]


def test_a_pack_may_name_installed_plugin_functions_without_allow_code(tmp_path):
    pack = make_pack(tmp_path / "reuse", {"formats/f.yaml": EVIL_FORMAT.format(function=ALLOWED)})
    manifest = cp.install_pack(pack, registry=Registry())
    assert manifest["allow_code"] is False and manifest["code"] == []
    create = Registry().functions("formats", "evil_fmt")["create"]
    assert create()["objects"] == []


def test_hand_edited_pack_cannot_import_os_system_at_load_time(tmp_path, data_dir):
    """A pack installed cleanly, then its format and manifest edited by hand: the registry refuses to import
    os:system, so the server never offers it through POST /results_functions/create."""
    from benchbot.core.session import resolve_run, start_service

    pack = make_pack(tmp_path / "edited", {"formats/f.yaml": EVIL_FORMAT.format(function=ALLOWED),
                                           "tasks/t.yaml": TASK})
    cp.install_pack(pack, registry=Registry())
    installed = data_dir / "packs" / "edited"
    (installed / "formats" / "f.yaml").write_text(EVIL_FORMAT.format(function="os:system"))
    manifest = json.loads((installed / cp.MANIFEST).read_text())
    (installed / cp.MANIFEST).write_text(json.dumps({**manifest, "allow_code": True, "code": []}))
    registry = Registry()
    with pytest.raises(SpecError, match=r"functions.create: 'os:system' is neither code in the pack .*refusing"):
        registry.functions("formats", "evil_fmt")
    run = resolve_run(registry, "evil:passive:ground_truth", "carter", "miniroom:1")
    with pytest.raises(SpecError, match="os:system"):
        start_service(registry, run)  # the results functions are resolved before any backend is built
    # a name imported into an allowed plugin module from elsewhere is refused by where it is defined
    (installed / "formats" / "f.yaml").write_text(
        EVIL_FORMAT.format(function="benchbot_task_semslam.formats:ResultsError"))
    with pytest.raises(SpecError, match="defined in benchbot.core.errors, not in benchbot_task_semslam"):
        Registry().functions("formats", "evil_fmt")


def test_code_added_to_a_pack_installed_without_allow_code_is_not_loaded(tmp_path, data_dir):
    pack = make_pack(tmp_path / "plain", {"formats/f.yaml": EVIL_FORMAT.format(function=ALLOWED)})
    cp.install_pack(pack, registry=Registry())
    installed = data_dir / "packs" / "plain"
    make_pack(installed, {"formats/f.yaml": EVIL_FORMAT.format(function="mine.create"),
                          "formats/mine.py": "import os\ndef create():\n    os.system('true')\n",
                          "examples/e.yaml": "name: pack_sneaky\nnative_command: python run.py\n"})
    registry = Registry()
    assert "pack_sneaky" not in registry.names("examples") and "evil_fmt" not in registry.names("formats")
    problems = "\n".join(registry.problems.values())
    assert "formats/f.yaml: functions.create runs pack code 'mine.create', but pack 'plain' was installed " \
           "without --allow-code" in problems
    assert "examples/e.yaml: example runs 'python run.py' from the pack, but pack 'plain' was installed " \
           "without --allow-code" in problems
