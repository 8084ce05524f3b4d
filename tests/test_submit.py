"""``benchbot submit``: modes, flag validation, tarball + manifest, containers (where an engine works)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tarfile
from pathlib import Path

import pytest

from benchbot.core.errors import UsageError
from benchbot.core.server import SUPERVISOR_GREETING
from benchbot.core.submission import container_engine, container_image_tag

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]


def cli(*args: str, cwd: Path | None = None, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([*BENCHBOT, *args], cwd=cwd, capture_output=True, text=True, timeout=300,
                          env=dict(os.environ, COLUMNS="200", **(env or {})))


def _engine() -> str | None:
    try:
        return container_engine()
    except UsageError as exc:
        return "skip:" + exc.message


def test_flag_validation_is_one_line():
    for args, text in [
        (["--native", "python", "x.py", "--example", "hello_passive"], "not both"),
        (["--native", "a", "--containerised", "."], "give one mode"),
        (["--example-containerised"], "needs --example"),
        (["--submission", ".", "--evaluate-with", "omq"], "cannot be combined"),
    ]:
        proc = cli("submit", *args)
        assert proc.returncode == 2, (args, proc.stderr)
        assert proc.stderr.startswith("error:") and text in proc.stderr and len(proc.stderr.splitlines()) <= 2


def test_submission_archive_and_manifest(tmp_path):
    folder = tmp_path / "solution"
    (folder / "pkg").mkdir(parents=True)
    (folder / "my.py").write_text("print('hi')\n")
    (folder / "pkg" / "data.txt").write_text("x")
    out = tmp_path / "out" / "sub.tgz"
    proc = cli("submit", "--submission", str(folder), "--args", str(out), "--address", "http://127.0.0.1:9/")
    assert proc.returncode == 0, proc.stderr
    with tarfile.open(out) as tar:
        assert sorted(tar.getnames()) == ["./my.py", "./pkg/data.txt"]
    manifest = json.loads(out.with_name("sub.tgz.manifest.json").read_text())
    assert set(manifest["files"]) == {"my.py", "pkg/data.txt"} and len(manifest["files"]["my.py"]) == 64
    assert "benchbot" in manifest["packages"] and {"task", "robot", "environments", "seeds"} <= set(manifest)
    default = cli("submit", "--submission", str(folder), "--address", "http://127.0.0.1:9/")
    assert default.returncode == 0 and (tmp_path / "submission.tgz").is_file()


def test_submission_manifest_names_the_running_backend(served, tmp_path):
    _, server = served("semantic_slam:passive:ground_truth", "miniroom:1")
    folder = tmp_path / "s"
    folder.mkdir()
    (folder / "a.py").write_text("")
    proc = cli("submit", "-s", str(folder), "-a", str(tmp_path / "x.tgz"), "--address", server.address)
    assert proc.returncode == 0, proc.stderr
    manifest = json.loads((tmp_path / "x.tgz.manifest.json").read_text())
    assert manifest["task"] == "semantic_slam:passive:ground_truth" and manifest["robot"] == "carter"
    assert manifest["environments"] == ["miniroom:1"] and manifest["seeds"] == [0]


def test_containerised_without_an_engine_says_so(tmp_path):
    engine = _engine()
    if engine and not engine.startswith("skip:"):
        pytest.skip(f"{engine} works here: the error path cannot be exercised")
    (tmp_path / "Dockerfile").write_text("FROM python:3.11-slim\n")
    proc = cli("submit", "--containerised", str(tmp_path))
    assert proc.returncode == 2
    assert proc.stderr.startswith("error:") and ("no container engine answers" in proc.stderr or "neither is installed" in proc.stderr)


def test_containerised_submission_reaches_the_backend(served, tmp_path, container_engine_with_base_image):
    """The container reaches the backend by BENCHBOT_SUPERVISOR_ADDRESS and by the original client's
    ``benchbot_supervisor`` name, gets ``args``, the token and BENCHBOT_SHARED_MEMORY=0, and its results are
    copied out."""
    _, base_image = container_engine_with_base_image
    _, server = served("semantic_slam:passive:ground_truth", "miniroom:4")
    (tmp_path / "Dockerfile").write_text(
        f"FROM {base_image}\nCOPY run.py /run.py\nCMD [\"python3\", \"/run.py\"]\n")
    (tmp_path / "run.py").write_text(
        "import json, os, urllib.request\n"
        "def get(url):\n"
        "    return json.loads(urllib.request.urlopen(url, timeout=10).read())\n"
        "address = os.environ['BENCHBOT_SUPERVISOR_ADDRESS']\n"
        f"out = {{'greeting': get(address), 'by_name': get('http://benchbot_supervisor:{server.port}/'),\n"
        "       'args': os.environ.get('args'), 'token': os.environ.get('BENCHBOT_TOKEN'),\n"
        "       'shm': os.environ.get('BENCHBOT_SHARED_MEMORY')}\n"
        "json.dump(out, open(os.environ['BENCHBOT_RESULT_LOCATION'], 'w'))\n")
    proc = cli("submit", "--containerised", str(tmp_path), "--address", server.address, "--args", "a b",
               "--results-location", str(tmp_path / "copied.json"), env={"BENCHBOT_TOKEN": "t0ken"})
    assert proc.returncode == 0, proc.stderr + proc.stdout
    assert json.loads((tmp_path / "copied.json").read_text()) == {
        "greeting": SUPERVISOR_GREETING, "by_name": SUPERVISOR_GREETING, "args": "a b", "token": "t0ken", "shm": "0"}


def test_containerised_build_failure_is_one_line(tmp_path):
    engine = _engine()
    if engine is None or engine.startswith("skip:"):
        pytest.skip(f"no working container engine: {engine[5:] if engine else 'none'}")
    (tmp_path / "Dockerfile").write_text("FROM scratch\nNOT_AN_INSTRUCTION x\n")  # fails before any pull
    proc = cli("submit", "--containerised", str(tmp_path), "--address", "http://127.0.0.1:9/")
    assert proc.returncode == 1, proc.stderr
    errors = [line for line in proc.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and f"{engine} build of" in errors[0] and "failed" in errors[0], proc.stderr


def test_containerised_timeout_kills_and_removes_the_container(tmp_path, container_engine_with_base_image):
    engine, base_image = container_engine_with_base_image
    (tmp_path / "Dockerfile").write_text(
        f"FROM {base_image}\nCMD [\"python3\", \"-c\", \"import time; time.sleep(300)\"]\n")
    proc = cli("submit", "--containerised", str(tmp_path), "--address", "http://127.0.0.1:9/", "--timeout", "2")
    assert proc.returncode == 1 and "exited with status -9" in proc.stderr, proc.stderr
    name = "benchbot_submission_" + container_image_tag(tmp_path).rsplit(":", 1)[1]
    left = subprocess.run([engine, "ps", "-a", "-q", "--filter", f"name={name}"], capture_output=True, text=True)
    assert left.stdout.strip() == ""


def test_an_example_without_a_container_says_how_to_run_it():
    proc = cli("submit", "--example", "hello_passive", "--example-containerised")
    assert proc.returncode == 2
    assert proc.stderr.startswith("error: example 'hello_passive' has no container set up") and \
        "--example hello_passive" in proc.stderr


def test_an_example_with_a_container_runs_in_it(served, tmp_path, container_engine_with_base_image):
    """``--example NAME --example-containerised`` for an example whose spec names a container folder (a content
    pack, in the original add-on layout): built from that folder, run against the backend, results copied out."""
    _, base_image = container_engine_with_base_image
    _, server = served("semantic_slam:passive:ground_truth", "miniroom:4")
    pack = tmp_path / "pack"
    files = {
        "examples/boxed_hello.yaml": "name: boxed_hello\nnative_command: python run.py\n"
                                     "container_directory: boxed_hello\n",
        "examples/boxed_hello/Dockerfile": f"FROM {base_image}\nCOPY run.py /run.py\nCMD [\"python3\", \"/run.py\"]\n",
        "examples/boxed_hello/run.py": (
            "import json, os, urllib.request\n"
            "greeting = json.loads(urllib.request.urlopen(os.environ['BENCHBOT_SUPERVISOR_ADDRESS'], timeout=10).read())\n"
            "json.dump({'greeting': greeting}, open(os.environ['BENCHBOT_RESULT_LOCATION'], 'w'))\n"),
    }
    for rel, text in files.items():
        (pack / rel).parent.mkdir(parents=True, exist_ok=True)
        (pack / rel).write_text(text)
    env = {"BENCHBOT_DATA_DIR": str(tmp_path / "data")}
    installed = cli("install", str(pack), "--allow-code", env=env)
    assert installed.returncode == 0, installed.stderr
    proc = cli("submit", "--example", "boxed_hello", "--example-containerised", "--address", server.address,
               "--results-location", str(tmp_path / "copied.json"), env=env)
    assert proc.returncode == 0, proc.stderr
    assert json.loads((tmp_path / "copied.json").read_text()) == {"greeting": SUPERVISOR_GREETING}
