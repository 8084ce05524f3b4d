"""Containerised solutions (docs/containers.md): the engine's command line, the outputs and report that come back,
the limits' reasons, the base image's contents; and, with a real engine (Podman or Docker), original-style
Dockerfile solutions scored end to end through ``submit`` and ``batch``, past their memory, process and CPU limits,
and cut off from every network but their backend."""

from __future__ import annotations

import io
import json
import os
import socket
import subprocess
import sys
import tarfile
from pathlib import Path

import pytest

from benchbot.core.errors import UsageError
from benchbot.solutions.container_base import apt_mirror, debian_suite, distribution_closure, stage_distributions
from benchbot.solutions.containers import container_exceeded, limits_record, run_arguments, unpack_outputs
from benchbot.solutions.container_engine import EngineFacts
from benchbot.solutions.sandbox_limits import SandboxLimits

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]
LIMITS = SandboxLimits(memory_bytes=256 << 20, processes=64, file_bytes=32 << 20, cpu_s=3, tmp_bytes=16 << 20,
                       outputs_bytes=24 << 20)


def cli(*args: str, env: dict | None = None, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run([*BENCHBOT, *args], capture_output=True, text=True, timeout=timeout,
                          env=dict(os.environ, COLUMNS="200", **(env or {})))


# ------------------------------------------------------------------------------------------------- no engine needed
def test_the_run_command_line_gives_no_network_no_capability_and_only_private_mounts(tmp_path):
    socket_path = tmp_path / "episode" / "backend.sock"
    argv = run_arguments("podman", "benchbot/submission:abc", ["python", "hello"], name="n", private=tmp_path / "p",
                         backend_socket=socket_path, address="http://127.0.0.1:10000/", result_name="r.json",
                         args="a b", limits=LIMITS, interactive=False, env={"BENCHBOT_TOKEN": "secret"})
    assert argv[argv.index("--network") + 1] == "none" and "--read-only" in argv
    assert argv[argv.index("--cap-drop") + 1] == "ALL" and "no-new-privileges" in argv
    assert "--privileged" not in argv and "--device" not in argv and "-i" not in argv
    assert argv[argv.index("--log-driver") + 1] == "none"  # no copy of its output on the engine's disk
    mounts = [argv[i + 1] for i, word in enumerate(argv) if word == "-v"]
    assert mounts == [f"{tmp_path / 'p' / 'hosts'}:/etc/hosts:ro", f"{tmp_path / 'p' / 'init'}:/run/benchbot-init:ro",
                      f"{socket_path}:/run/benchbot/backend.sock"]
    tmpfs = [argv[i + 1] for i, word in enumerate(argv) if word == "--tmpfs"]
    assert tmpfs == [f"/tmp:rw,size={16 << 20},mode=1777", f"/benchbot/results:rw,size={24 << 20},mode=1777"]
    assert argv[argv.index("--memory") + 1] == argv[argv.index("--memory-swap") + 1] == str(256 << 20)
    assert argv[argv.index("--pids-limit") + 1] == "64"
    ulimits = {argv[i + 1].split("=")[0]: argv[i + 1].split("=")[1] for i, w in enumerate(argv) if w == "--ulimit"}
    assert ulimits["cpu"] == "3:4" and ulimits["fsize"] == f"{32 << 20}:{32 << 20}" and ulimits["nproc"] == "64:64"
    variables = [argv[i + 1] for i, word in enumerate(argv) if word == "-e"]
    assert "BENCHBOT_TOKEN" in variables and not any("secret" in word for word in argv)  # by name only
    assert "BENCHBOT_RESULT_LOCATION=/benchbot/results/r.json" in variables and "args=a b" in variables
    assert argv[argv.index("--entrypoint") + 1] == "python3"
    assert argv[-3:] == ["--", "python", "hello"] and "--port" in argv and "10000" in argv


def test_an_interactive_run_keeps_standard_input_open(tmp_path):
    argv = run_arguments("docker", "t", ["x"], name="n", private=tmp_path, backend_socket=tmp_path / "s",
                         address="http://localhost:8080/", result_name="r", args="", limits=LIMITS,
                         interactive=True, env={})
    assert "-i" in argv and "--read-only-tmpfs=false" not in argv  # a Podman-only flag
    assert argv[argv.index("-i") - 1].endswith(":/run/benchbot/backend.sock") and "8080" in argv


def _stream(path: Path, members: list[tuple[str, object]]) -> Path:
    """A tar stream as a container's first process writes it: (name, bytes | 'dir' | ('link', target) | 'fifo')."""
    with tarfile.open(path, "w") as tar:
        for name, what in members:
            info = tarfile.TarInfo(name)
            data = None
            if what == "dir":
                info.type = tarfile.DIRTYPE
            elif what == "fifo":
                info.type = tarfile.FIFOTYPE
            elif isinstance(what, tuple):
                info.type, info.linkname = tarfile.SYMTYPE, what[1]
            else:
                data = what
                info.size = len(data)
            tar.addfile(info, io.BytesIO(data) if data is not None else None)
    return path


def test_outputs_come_back_as_regular_files_and_folders_only(tmp_path):
    outputs = tmp_path / "outputs"
    outputs.mkdir()
    stream = _stream(tmp_path / "s.tar", [
        ("report.json", json.dumps({"status": 0, "oom_kills": 0, "pids_refused": 0}).encode()),
        ("outputs/result.json", b"{}"), ("outputs/pictures", "dir"), ("outputs/pictures/a.png", b"png"),
        ("outputs/gt", ("link", "/etc/passwd")), ("outputs/pipe", "fifo"), ("outputs/../escape", b"x"),
        ("outputs/pictures/../../escape2", b"x"), ("elsewhere", b"x"),
    ])
    report, dropped, problem = unpack_outputs(stream, outputs)
    assert report == {"status": 0, "oom_kills": 0, "pids_refused": 0} and problem == ""
    assert sorted(dropped) == ["../escape", "gt", "pictures/../../escape2", "pipe"]
    made = sorted(str(p.relative_to(outputs)) for p in outputs.rglob("*"))
    assert made == ["pictures", "pictures/a.png", "result.json"] and not (tmp_path / "escape").exists()
    assert not any(p.is_symlink() for p in outputs.rglob("*"))


def test_a_stream_cut_short_keeps_what_came_before(tmp_path):
    whole = _stream(tmp_path / "whole.tar", [("report.json", b'{"status": 1}'), ("outputs/a", b"a" * 4096),
                                             ("outputs/b", b"b" * 4096)])
    cut = tmp_path / "cut.tar"
    cut.write_bytes(whole.read_bytes()[:512 * 12])  # the second file's data cut
    outputs = tmp_path / "outputs"
    outputs.mkdir()
    report, _, problem = unpack_outputs(cut, outputs)
    assert report == {"status": 1} and (outputs / "a").read_bytes() == b"a" * 4096
    assert "cut short" in problem
    assert unpack_outputs(tmp_path / "none.tar", outputs) == (None, [], "")  # a container stopped before it wrote


def test_each_limit_has_its_one_line_reason(tmp_path):
    log = tmp_path / "log"
    log.write_text("Traceback ...\nOSError: [Errno 28] No space left on device\n")
    cases = {
        (137, json.dumps({"oom_kills": 1})): "memory limit of 256 MiB (BENCHBOT_SANDBOX_MEMORY_BYTES)",
        (1, json.dumps({"pids_refused": 3})): "limit on processes and threads of 64 tasks",
        (128 + 24, "{}"): "CPU time limit of 3 seconds (BENCHBOT_SANDBOX_CPU_S)",
        (1, json.dumps({"full": ["/benchbot/results"]})): "outputs folder of 24 MiB (BENCHBOT_SANDBOX_OUTPUTS_BYTES)",
        (1, json.dumps({"full": ["/tmp"]})): "filled its /tmp of 16 MiB (BENCHBOT_SANDBOX_TMP_BYTES)",
    }
    for (code, report), reason in cases.items():
        found = container_exceeded(LIMITS, code, json.loads(report), tmp_path, log)
        assert reason in found and "\n" not in found, (code, found)
    assert container_exceeded(LIMITS, 0, {"oom_kills": 1}, tmp_path, log) == ""  # a run that succeeded is ok
    log.write_text("ValueError: a bug of its own\n")
    assert container_exceeded(LIMITS, 1, {"oom_kills": 0, "pids_refused": 0, "full": []}, tmp_path, log) == ""


def test_the_manifest_says_how_each_limit_is_enforced():
    record = limits_record(LIMITS, EngineFacts("podman", "4.3.1", False, "1", "runc"))
    assert record["memory_bytes"] == 256 << 20 and record["outputs_bytes"] == 24 << 20
    assert record["mechanism"]["memory_bytes"].startswith("--memory") and "cgroup v1" in record["mechanism"]["processes"]
    assert record["mechanism"]["engine"] == "podman 4.3.1 (root, cgroup v1, runtime runc)"
    assert record["mechanism"]["network"].startswith("--network none")
    rootless_v1 = limits_record(LIMITS, EngineFacts("podman", "4.3.1", True, "1"))["mechanism"]
    assert rootless_v1["memory_bytes"].startswith("NOT enforced") and rootless_v1["processes"].startswith("NOT")


def test_the_base_image_carries_the_client_and_what_it_imports(tmp_path):
    names = {d.metadata["Name"].lower() for d in distribution_closure()}
    assert {"benchbot", "numpy", "msgpack", "starlette", "pyyaml"} <= names
    assert not {"taichi", "benchbot-sim-taichi", "pytest"} & names  # the client only: no simulator, no tests
    import importlib.metadata as md

    dists = [md.distribution("benchbot"), md.distribution("msgpack")]
    count = stage_distributions(dists, tmp_path / "site")
    assert count > 10 and (tmp_path / "site" / "benchbot" / "api" / "__init__.py").is_file()
    assert (tmp_path / "site" / "benchbot_api" / "__init__.py").is_file()
    assert list((tmp_path / "site" / "benchbot" / "schemas").glob("*.schema.json"))
    assert list((tmp_path / "site").glob("msgpack-*.dist-info/METADATA"))
    assert not list((tmp_path / "site").rglob("*.pth")) and not list((tmp_path / "site").rglob("direct_url.json"))


def test_the_debian_release_and_mirror_come_from_this_machine(tmp_path):
    assert debian_suite((3, 11)) == "bookworm"
    with pytest.raises(UsageError, match="no Debian release ships Python 3.12"):
        debian_suite((3, 12))
    (tmp_path / "sources.list.d").mkdir()
    assert apt_mirror(tmp_path) == "http://deb.debian.org/debian"
    (tmp_path / "sources.list.d" / "debian.sources").write_text(
        "Types: deb\nURIs: http://mirror.example/debian-security\nSuites: bookworm-security\n\n"
        "Types: deb\nURIs: http://mirror.example/debian\nSuites: bookworm\n")
    assert apt_mirror(tmp_path) == "http://mirror.example/debian"
    (tmp_path / "sources.list.d" / "debian.sources").unlink()
    (tmp_path / "sources.list").write_text("# a comment\ndeb [arch=amd64 signed-by=/k.gpg] http://other.example/debian "
                                           "bookworm main\n")
    assert apt_mirror(tmp_path) == "http://other.example/debian"


# ------------------------------------------------------------------------------------------------- a real engine
#: An original-style solution (the shape of the original examples' hello_passive): the original client's imports,
#: an Agent that follows the passive trajectory, an empty object map saved. What it does first depends on ``args``
#: and on the environment the backend runs (``hog-memory-in ENV``: allocate until stopped there).
HELLO = '''#!/usr/bin/env python
import json, os, sys, threading, time, urllib.request
from benchbot_api import ActionResult, Agent, BenchBot

def environments():
    address = os.environ["BENCHBOT_SUPERVISOR_ADDRESS"]
    return json.load(urllib.request.urlopen(address + "robot/run_info", timeout=10))["environments"]

class GuidedAgent(Agent):
    def __init__(self):
        self.steps = 0

    def is_done(self, action_result):
        return action_result != ActionResult.SUCCESS

    def pick_action(self, observations, action_list):
        self.steps += 1
        return "move_next", {}

    def save_result(self, filename, empty_results, results_format_fns):
        print("followed %d poses" % self.steps)
        with open(filename, "w") as f:
            json.dump(empty_results, f)

if __name__ == "__main__":
    what = os.environ.get("args", "").split()
    if what[:1] == ["hog-memory-in"] and what[1] in json.dumps(environments()):
        blocks = []
        while True:
            blocks.append(bytearray(32 << 20))
    if what[:1] == ["threads"]:
        for _ in range(10000):
            threading.Thread(target=time.sleep, args=(60,), daemon=True).start()
    if what[:1] == ["spin"]:
        while True:
            pass
    if what[:1] == ["fill"]:
        with open("/benchbot/results/big", "wb") as f:
            while True:
                f.write(bytes(1 << 20))
    BenchBot(agent=GuidedAgent()).run()
'''
#: The original examples' Dockerfile shape: their base image, pip for more, the files, the command (shell form).
DOCKERFILE = """# Use a base image which provides as many of your dependencies as possible
FROM {base}

# Install any extra dependencies you may have
RUN pip3 install numpy

# Add the files from your solution
ADD hello_boxed .

# Make the command used to run your solution the default command
CMD python hello_boxed
"""


def _solution(folder: Path, base: str, script: str = HELLO, dockerfile: str = DOCKERFILE) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "Dockerfile").write_text(dockerfile.format(base=base))
    (folder / "hello_boxed").write_text(script)
    return folder


def _skip_without_cgroup_limits(engine: str) -> None:
    """Skip, saying why, where the engine cannot set cgroup limits (rootless Podman on a cgroup v1 host: the
    manifest then records the memory and process limits as not enforced)."""
    from benchbot.solutions.container_engine import engine_facts

    facts = engine_facts(engine)
    if not facts.limits_enforced():
        pytest.skip(f"{facts.describe()} cannot set cgroup limits (rootless on cgroup v1)")


@pytest.fixture
def backend_address(served):
    """The address of a real backend (passive semantic SLAM on miniroom:1, small images) on 127.0.0.1."""
    return served("semantic_slam:passive:ground_truth", "miniroom:1")[1].address


@pytest.mark.slow
def test_an_original_dockerfile_solution_is_scored_through_submit(tmp_path, container_engine_with_base_image,
                                                                  backend_address, registry):
    _, base = container_engine_with_base_image
    folder = _solution(tmp_path / "hello", base)
    proc = cli("submit", "--containerised", str(folder), "--address", backend_address, "--evaluate-with", "omq",
               "--scores", str(tmp_path / "scores.json"), env={"BENCHBOT_RESULT_LOCATION": str(tmp_path / "r.json")})
    assert proc.returncode == 0, proc.stderr[-3000:]
    poses = len(registry.scenes("miniroom:1")[0]["trajectory_poses"])
    assert f"followed {poses} poses" in proc.stderr and "STEP 2/4: RUN pip3 install numpy" in proc.stderr
    scores = json.loads((tmp_path / "scores.json").read_text())["scores"]
    assert scores["OMQ"] == 0.0 and scores["FN"] > 0  # an empty map, scored against miniroom:1's objects
    results = json.loads((tmp_path / "r.json").read_text())
    assert results["task_details"]["name"] == "semantic_slam:passive:ground_truth"
    assert results["results"]["objects"] == []


@pytest.mark.slow
def test_a_batch_of_containers_scores_and_goes_on_past_a_memory_limit(tmp_path, container_engine_with_base_image):
    """Two episodes of one original-style image: in miniroom:1 it allocates until the memory cgroup stops it (that
    episode ends ``resource_limit`` with the limit's one line), in miniroom:2 it drives and is scored with OMQ."""
    engine, base = container_engine_with_base_image
    _skip_without_cgroup_limits(engine)
    folder = _solution(tmp_path / "hello", base)
    proc = cli("batch", "--containerised", str(folder), "--args", "hog-memory-in miniroom:1", "--envs",
               "miniroom:1,miniroom:2", "--camera-size", "64x48", "--output-dir", str(tmp_path / "runs"), "--json",
               "--no-tui", env={"BENCHBOT_SANDBOX_MEMORY_BYTES": "256M"}, timeout=1200)
    run_dir = Path(json.loads(proc.stdout)["run_dir"]) if proc.stdout.strip().startswith("{") else None
    assert run_dir is not None, proc.stderr[-3000:]
    manifest = json.loads((run_dir / "manifest.json").read_text())
    first, second = manifest["episodes"]
    assert first["status"] == "resource_limit", first
    assert first["error"] == ("the solution exceeded its memory limit of 256 MiB (BENCHBOT_SANDBOX_MEMORY_BYTES)")
    assert second["status"] == "ok", (second, (run_dir / second["log"]).read_text()[-2000:])
    assert manifest["sandbox"] == "container" and manifest["limits"]["memory_bytes"] == 256 << 20
    assert manifest["limits"]["mechanism"]["memory_bytes"].startswith("--memory")
    scores = json.loads((run_dir / "scores.json").read_text())
    assert "OMQ" in json.dumps(scores)


@pytest.fixture
def quiet_backend():
    """The address of a real HTTP server on 127.0.0.1 answering every GET with the supervisor's greeting: a backend
    for solutions that never drive (their limits stop them first)."""
    import http.server
    import threading

    from benchbot.server import SUPERVISOR_GREETING

    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self):
            body = json.dumps(SUPERVISOR_GREETING).encode()
            self.send_response(200)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

        def log_message(self, *args):
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield f"http://127.0.0.1:{server.server_address[1]}/"
    server.shutdown()
    server.server_close()


@pytest.mark.slow
@pytest.mark.parametrize("args, variable, reason", [
    ("threads", {"BENCHBOT_SANDBOX_PROCESSES": "32"}, "exceeded its limit on processes and threads of 32 tasks"),
    ("spin", {"BENCHBOT_SANDBOX_CPU_S": "1"}, "exceeded its CPU time limit of 1 second (BENCHBOT_SANDBOX_CPU_S)"),
    ("fill", {"BENCHBOT_SANDBOX_OUTPUTS_BYTES": "16M"}, "exceeded its limit on its outputs folder of 16 MiB"),
])
def test_a_container_past_its_process_cpu_or_outputs_limit_is_stopped_with_the_reason(
        tmp_path, container_engine_with_base_image, quiet_backend, args, variable, reason):
    engine, base = container_engine_with_base_image
    if args == "threads":
        _skip_without_cgroup_limits(engine)
    folder = _solution(tmp_path / "hello", base)
    proc = cli("submit", "--containerised", str(folder), "--address", quiet_backend, "--args", args,
               "--timeout", "120", env=variable)
    assert proc.returncode != 0 and reason in proc.stderr, proc.stderr[-3000:]


PROBE = '''import json, os, socket, urllib.request
def attempt(host, port):
    try:
        socket.create_connection((host, port), timeout=5).close()
        return "connected"
    except OSError as exc:
        return type(exc).__name__ + ": " + str(exc)
def resolve(name):
    try:
        return socket.gethostbyname(name)
    except OSError as exc:
        return type(exc).__name__
host_ip, port = os.environ["args"].split()
out = {"backend": json.load(urllib.request.urlopen(os.environ["BENCHBOT_SUPERVISOR_ADDRESS"], timeout=10)),
       "host_loopback": attempt("127.0.0.1", int(port)), "host_address": attempt(host_ip, int(port)),
       "internet": attempt("1.1.1.1", 80), "dns": resolve("deb.debian.org"),
       "interfaces": sorted(os.listdir("/sys/class/net"))}
json.dump(out, open(os.environ["BENCHBOT_RESULT_LOCATION"], "w"))
'''


def _host_address() -> str:
    """This machine's own address on its default route (no packet is sent), loopback where it has none."""
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        probe.connect(("192.0.2.1", 9))
        return probe.getsockname()[0]
    except OSError:
        return "127.0.0.1"
    finally:
        probe.close()


@pytest.mark.slow
def test_a_container_reaches_its_backend_and_nothing_else(tmp_path, container_engine_with_base_image, quiet_backend):
    """A listener on every address of the host, the internet, DNS: none is reached; the backend is."""
    _, base = container_engine_with_base_image
    folder = _solution(tmp_path / "probe", base, PROBE, DOCKERFILE.replace("CMD python hello_boxed",
                                                                           "CMD [\"python3\", \"hello_boxed\"]"))
    listener = socket.socket()
    listener.bind(("0.0.0.0", 0))
    listener.listen(8)
    listener.settimeout(0.1)
    try:
        proc = cli("submit", "--containerised", str(folder), "--address", quiet_backend, "--args",
                   f"{_host_address()} {listener.getsockname()[1]}", "--results-location", str(tmp_path / "r.json"))
        reached = []
        try:
            reached.append(listener.accept())
        except OSError:
            pass
    finally:
        listener.close()
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads((tmp_path / "r.json").read_text())
    assert out["backend"] == "Hello, I am the BenchBot supervisor" and out["interfaces"] == ["lo"]
    for what in ("host_loopback", "host_address", "internet"):
        assert out[what] != "connected" and ("refused" in out[what] or "unreachable" in out[what]), (what, out)
    assert out["dns"] == "gaierror" and not reached


@pytest.mark.slow
def test_the_base_image_is_made_again_on_its_kept_root_file_system(container_engine_with_base_image):
    """``benchbot container-base`` (JSON): the Debian root file system reused, the packages' layer made again, the
    image's Python this Python's minor version."""
    _, base = container_engine_with_base_image
    if base != "benchbot/submission:base":
        pytest.skip(f"the tests use another base image ({base})")
    proc = cli("container-base", "--json", timeout=1200)
    assert proc.returncode == 0, proc.stderr[-3000:]
    made = json.loads(proc.stdout)
    assert made["tag"] == "benchbot/submission:base" and made["rootfs_s"] < 5
    assert made["python"].startswith("%d.%d." % sys.version_info[:2]) and made["distributions"] > 20


@pytest.mark.slow
def test_a_challenge_evaluates_a_container_submission_and_signs_it(tmp_path, container_engine_with_base_image):
    """`benchbot challenge evaluate DIR --containerised` runs the submission's Dockerfile as the solution under the
    challenge's conditions; the run is signed, records its isolation as a container, and verifies."""
    _, base = container_engine_with_base_image
    folder = _solution(tmp_path / "team", base)
    challenge = tmp_path / "ch"
    proc = cli("challenge", "init", str(challenge), "--environments", "miniroom:1")
    assert proc.returncode == 0, proc.stderr
    proc = cli("challenge", "evaluate", str(folder), "--challenge", str(challenge), "--containerised", timeout=1200)
    assert proc.returncode == 0, proc.stderr[-3000:]
    [run] = list((challenge / "runs").iterdir())
    assert json.loads((run / "manifest.json").read_text())["sandbox"] == "container"
    signed = json.loads((run / "signature.json").read_text())["signed"]
    assert signed["conditions"]["limits"]["solution"]["memory_bytes"] > 0
    proc = cli("verify", str(run), "--key", str(challenge / "host_key.pub.pem"))
    assert proc.returncode == 0 and proc.stdout.startswith("verified: "), proc.stderr
    proc = cli("challenge", "evaluate", str(tmp_path), "--challenge", str(challenge), "--containerised")
    assert proc.returncode == 2 and "no Dockerfile" in proc.stderr and "Traceback" not in proc.stderr
