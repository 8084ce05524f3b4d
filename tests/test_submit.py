"""``benchbot submit``: modes, flag validation, tarball + manifest, containers (where an engine works)."""

from __future__ import annotations

import fcntl
import http.server
import json
import os
import socket
import subprocess
import sys
import tarfile
import threading
import time
from pathlib import Path

import pytest

from benchbot.core.errors import UsageError
from benchbot.solutions.result_files import ORIGINAL_RESULT_LOCATION
from benchbot.server import SUPERVISOR_GREETING
from benchbot.solutions.container_engine import container_engine, container_image_tag

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]


def cli(*args: str, cwd: Path | None = None, env: dict | None = None, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run([*BENCHBOT, *args], cwd=cwd, capture_output=True, text=True, timeout=timeout,
                          env=dict(os.environ, COLUMNS="200", **(env or {})))


def _engine() -> str | None:
    try:
        return container_engine()
    except UsageError as exc:
        return "skip:" + exc.message


@pytest.mark.slow
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


@pytest.mark.slow
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


@pytest.mark.slow
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


@pytest.mark.slow
def test_containerised_without_an_engine_says_so(tmp_path):
    """No engine installed, or one installed whose engine does not answer: one line each (engines hidden from
    PATH; a stand-in podman whose `info` fails)."""
    (tmp_path / "Dockerfile").write_text("FROM python:3.11-slim\n")
    (tmp_path / "bin").mkdir()
    proc = cli("submit", "--containerised", str(tmp_path), env={"PATH": str(tmp_path / "bin")})
    assert proc.returncode == 2 and proc.stderr.startswith("error:") and "neither is installed" in proc.stderr
    (tmp_path / "bin" / "podman").write_text("#!/bin/sh\necho 'cannot connect' >&2\nexit 125\n")
    (tmp_path / "bin" / "podman").chmod(0o755)
    proc = cli("submit", "--containerised", str(tmp_path), env={"PATH": str(tmp_path / "bin")})
    assert proc.returncode == 2 and proc.stderr.startswith("error: podman installed but no container engine answers")


@pytest.mark.slow
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


@pytest.mark.slow
def test_containerised_build_failure_is_one_line(tmp_path, greeter):
    engine = _engine()
    if engine is None or engine.startswith("skip:"):
        pytest.skip(f"no working container engine: {engine[5:] if engine else 'none'}")
    (tmp_path / "Dockerfile").write_text("FROM scratch\nNOT_AN_INSTRUCTION x\n")  # fails before any pull
    proc = cli("submit", "--containerised", str(tmp_path), "--address", greeter())
    assert proc.returncode == 1, proc.stderr
    errors = [line for line in proc.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and f"{engine} build of" in errors[0] and "failed" in errors[0], proc.stderr


@pytest.mark.slow
def test_containerised_timeout_kills_and_removes_the_container(tmp_path, container_engine_with_base_image, greeter):
    engine, base_image = container_engine_with_base_image
    (tmp_path / "Dockerfile").write_text(
        f"FROM {base_image}\nCMD [\"python3\", \"-c\", \"import time; time.sleep(300)\"]\n")
    proc = cli("submit", "--containerised", str(tmp_path), "--address", greeter(), "--timeout", "2")
    assert proc.returncode == 1 and "exited with status -9" in proc.stderr, proc.stderr
    name = "benchbot_submission_" + container_image_tag(tmp_path).rsplit(":", 1)[1]
    left = subprocess.run([engine, "ps", "-a", "-q", "--filter", f"name={name}"], capture_output=True, text=True)
    assert left.stdout.strip() == ""


@pytest.mark.slow
def test_an_example_without_a_container_says_how_to_run_it():
    proc = cli("submit", "--example", "hello_passive", "--example-containerised")
    assert proc.returncode == 2
    assert proc.stderr.startswith("error: example 'hello_passive' has no container set up") and \
        "--example hello_passive" in proc.stderr


@pytest.mark.slow
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


# ------------------------------------------------------------------------------------------------- the backend check
def _script(folder: Path, text: str) -> Path:
    """A solution file in ``folder`` (``--native python -c ...`` would hand ``-c`` to submit)."""
    path = folder / "solution.py"
    path.write_text(text + "\n")
    return path


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.fixture
def greeter():
    """``greeter(status=200)`` → the address of a real HTTP server on 127.0.0.1 answering every GET with ``status``
    and the supervisor's greeting (a backend for submissions that never use it); stopped after."""
    servers = []

    def serve(status: int = 200) -> str:
        class Handler(http.server.BaseHTTPRequestHandler):
            def do_GET(self):
                body = json.dumps(SUPERVISOR_GREETING).encode()
                self.send_response(status)
                self.send_header("Content-Type", "application/json")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, *args):
                pass

        server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        threading.Thread(target=server.serve_forever, daemon=True).start()
        servers.append(server)
        return f"http://127.0.0.1:{server.server_address[1]}/"

    yield serve
    for server in servers:
        server.shutdown()
        server.server_close()


@pytest.mark.slow
def test_no_backend_fails_at_once_naming_the_address_and_the_fix(tmp_path):
    """Before: the solution waited 60 s for a backend, then printed its traceback."""
    port = _free_port()
    marker = tmp_path / "started"
    solution = _script(tmp_path, f"open({str(marker)!r}, 'w').close()\nfrom benchbot_api import BenchBot\nBenchBot()")
    proc = cli("submit", "--native", sys.executable, str(solution), "--address", f"http://127.0.0.1:{port}/",
               timeout=45)
    assert proc.returncode == 5, proc.stderr
    lines = proc.stderr.splitlines()
    assert lines[0].startswith(f"error: no BenchBot backend answers at http://127.0.0.1:{port}/"), proc.stderr
    assert "benchbot run --env" in lines[1] and len(lines) == 2, proc.stderr
    assert not marker.exists(), "the solution must not start against nothing"


@pytest.mark.parametrize("status, text", [(401, "wants a token"), (404, "answered GET / with HTTP 404")])
@pytest.mark.slow
def test_a_backend_that_refuses_is_one_line(greeter, tmp_path, status, text):
    marker = tmp_path / "started"
    solution = _script(tmp_path, f"open({str(marker)!r}, 'w').close()")
    proc = cli("submit", "--native", sys.executable, str(solution), "--address", greeter(status), timeout=45)
    assert proc.returncode == 5 and text in proc.stderr and "Traceback" not in proc.stderr, proc.stderr
    assert not marker.exists()


@pytest.mark.slow
def test_a_backend_still_starting_is_waited_for(tmp_path):
    """A socket that accepts connections but answers only later (``benchbot run`` building its simulator): the
    check says it waits, then the submission runs."""
    listener = socket.create_server(("127.0.0.1", 0))
    address = f"http://127.0.0.1:{listener.getsockname()[1]}/"

    def answer_later():
        listener.settimeout(60)
        try:
            first, _ = listener.accept()  # the check's first request: left unanswered past its 1 s
            time.sleep(1.5)
            first.close()
            while True:
                conn, _ = listener.accept()
                with conn:
                    conn.settimeout(5)
                    try:
                        conn.recv(65536)
                        body = json.dumps(SUPERVISOR_GREETING).encode()
                        conn.sendall(b"HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nConnection: close\r\n"
                                     b"Content-Length: " + str(len(body)).encode() + b"\r\n\r\n" + body)
                    except OSError:
                        pass
        except OSError:  # closed by the test, or no client for 60 s
            return

    thread = threading.Thread(target=answer_later, daemon=True)
    thread.start()
    result = tmp_path / "result.json"
    try:
        solution = _script(tmp_path, "import json, os\n"
                           "json.dump({'ok': 1}, open(os.environ['BENCHBOT_RESULT_LOCATION'], 'w'))")
        proc = cli("submit", "--native", sys.executable, str(solution), "--address", address,
                   env={"BENCHBOT_RESULT_LOCATION": str(result)}, timeout=60)
    finally:
        listener.close()
    assert proc.returncode == 0, proc.stderr
    assert "accepted the connection but has not answered yet; waiting" in proc.stderr
    assert json.loads(result.read_text()) == {"ok": 1} and f"results saved to {result}" in proc.stderr


# ------------------------------------------------------------------------------------------------- where results go
@pytest.fixture
def original_location():
    """:data:`ORIGINAL_RESULT_LOCATION` (``/tmp/benchbot_result``, one file for the whole machine), set aside during
    the test and put back after; a lock next to it keeps test sessions running at the same time out of each other's
    way (at most 5 min)."""
    with open(f"{ORIGINAL_RESULT_LOCATION}.test-lock", "w") as lock:
        deadline = time.monotonic() + 300
        while True:
            try:
                fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                assert time.monotonic() < deadline, "another test session held /tmp/benchbot_result for 5 min"
                time.sleep(0.2)
        saved = None
        if ORIGINAL_RESULT_LOCATION.is_file():
            saved = ORIGINAL_RESULT_LOCATION.read_bytes(), ORIGINAL_RESULT_LOCATION.stat()
            ORIGINAL_RESULT_LOCATION.unlink()
        try:
            yield ORIGINAL_RESULT_LOCATION
        finally:
            ORIGINAL_RESULT_LOCATION.unlink(missing_ok=True)
            if saved is not None:
                ORIGINAL_RESULT_LOCATION.write_bytes(saved[0])
                os.utime(ORIGINAL_RESULT_LOCATION, ns=(saved[1].st_atime_ns, saved[1].st_mtime_ns))


def _without_result_location() -> dict:
    return {k: v for k, v in os.environ.items() if k != "BENCHBOT_RESULT_LOCATION"}


@pytest.mark.slow
def test_results_stay_where_the_readme_says(served, original_location):
    """Before: without -r they were saved in a temporary folder removed on exit (the path the solution printed no
    longer existed)."""
    _, server = served("semantic_slam:passive:ground_truth", "miniroom:1")
    proc = subprocess.run([*BENCHBOT, "submit", "--example", "hello_eval_semantic_slam", "--no-sandbox",
                           "--address", server.address],
                          capture_output=True, text=True, timeout=300, env=_without_result_location())
    assert proc.returncode == 0, proc.stderr
    assert f"results saved to {original_location}" in proc.stderr
    results = json.loads(original_location.read_text())
    assert results["environment_details"][0]["name"] == "miniroom" and results["results"]["objects"]


ORIGINAL_CLIENT = """\
import json, os, sys
sys.path.insert(0, {tests!r})
from legacy_client import LegacyBenchBot
from benchbot.core.registry import get_registry


class GroundTruth:
    def is_done(self, action_result):
        return True

    def save_result(self, filename, empty_results, results_format_fns):
        classes = empty_results["results"]["class_list"]
        for env in empty_results["environment_details"]:
            gt = get_registry().ground_truth(f"{{env['name']}}:{{env['variant']}}")["ground_truth"]
            for obj in gt["objects"]:
                probs = [0.0] * len(classes)
                probs[classes.index(obj["class"])] = 1.0
                empty_results["results"]["objects"].append(
                    {{"label_probs": probs, "centroid": obj["centroid"], "extent": obj["extent"]}})
        with open(filename, "w") as f:
            json.dump(empty_results, f)


# the original client's RESULT_LOCATION is /tmp/benchbot_result whatever BENCHBOT_RESULT_LOCATION says
LegacyBenchBot(GroundTruth(), supervisor_address=os.environ["BENCHBOT_SUPERVISOR_ADDRESS"], poll_s=0.1).run()
"""


@pytest.mark.slow
def test_an_original_client_s_results_are_found_and_scored(served, original_location, tmp_path):
    """An original benchbot_api client writes /tmp/benchbot_result even when BENCHBOT_RESULT_LOCATION names another
    file. Before: "saved no results" and the evaluation of {} failed. (Unsandboxed: this solution submits the
    ground truth, which only a solution outside the sandbox can read; sandboxed, /tmp/benchbot_result leads to the
    solution's outputs folder: tests/test_sandbox.py.)"""
    _, server = served("semantic_slam:passive:ground_truth", "miniroom:1")
    solution = tmp_path / "original_solution.py"
    solution.write_text(ORIGINAL_CLIENT.format(tests=str(Path(__file__).parent)))
    given, scores = tmp_path / "given.json", tmp_path / "scores.json"
    proc = cli("submit", "--no-sandbox", "--native", sys.executable, str(solution), "--address", server.address,
               "--evaluate-with", "omq", "--scores", str(scores), env={"BENCHBOT_RESULT_LOCATION": str(given)})
    assert proc.returncode == 0, proc.stderr
    assert not given.exists() and original_location.is_file()
    assert f"results saved to {original_location}, written by this submission in place of " \
           f"BENCHBOT_RESULT_LOCATION={given}" in proc.stderr
    assert f"(from {original_location})" in proc.stderr
    assert json.loads(scores.read_text())["scores"]["OMQ"] == 1.0


@pytest.mark.slow
def test_a_stale_results_file_is_never_scored(greeter, original_location, tmp_path):
    """A /tmp/benchbot_result (or a BENCHBOT_RESULT_LOCATION file) older than the submission is not its results."""
    perfect = {"task_details": {}, "environment_details": [], "results": {"objects": []}}
    given = tmp_path / "given.json"
    for stale in (original_location, given):
        stale.write_text(json.dumps(perfect))
        os.utime(stale, (time.time() - 3600, time.time() - 3600))
    before = original_location.stat().st_mtime_ns, given.stat().st_mtime_ns
    copy = tmp_path / "copy.json"
    proc = cli("submit", "--native", sys.executable, str(_script(tmp_path, "pass")), "--address", greeter(),
               "--results-location", str(copy), env={"BENCHBOT_RESULT_LOCATION": str(given)})
    assert proc.returncode == 0, proc.stderr
    assert f"saved no results at {given} (the file there is older than this submission: not used); using {{}}" \
        in proc.stderr, proc.stderr
    assert "results saved to" not in proc.stderr
    assert json.loads(copy.read_text()) == {}
    assert (original_location.stat().st_mtime_ns, given.stat().st_mtime_ns) == before  # left as they were


@pytest.mark.parametrize("address, why", [("http://127.0.0.1:99999/", "Port out of range 0-65535"),
                                          ("http://127.0.0.1:abc/", "Port could not be cast to integer value")])
def test_an_address_with_a_bad_port_is_one_usage_line(address, why):
    """Before: ``--address http://127.0.0.1:99999/`` ended in urllib's ValueError traceback."""
    from benchbot.cli.submit_cmd import check_backend

    with pytest.raises(UsageError, match=f"backend address {address}: {why}") as caught:
        check_backend(address)
    assert "--address" in caught.value.hint
