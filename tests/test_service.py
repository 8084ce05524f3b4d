"""The resident simulator service (docs/service.md), tested for real: a real service process on a real Unix socket in a
folder of each test's own (``XDG_RUNTIME_DIR``), driven by the real ``benchbot`` command. Episodes through it give the
results and scores files of episodes run in-process, byte for byte; a service killed mid-episode is a one-line error
and the next command starts a fresh one; only its owner, outside any sandbox, may talk to it; it stops when idle."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import socket
import stat
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from benchbot.core.errors import UsageError
from benchbot.service import location, protocol

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]
SMALL = ["--camera-size", "64x48"]
#: A solution (--no-sandbox) that marks that it runs, then asks the backend for its greeting until the backend is gone.
POLLING_SOLUTION = """
import os, sys, time, urllib.request
open(sys.argv[1], "w").close()
deadline = time.monotonic() + 120
while time.monotonic() < deadline:
    try:
        urllib.request.urlopen(os.environ["BENCHBOT_SUPERVISOR_ADDRESS"], timeout=5).read()
    except OSError as exc:
        print("backend gone:", exc)
        sys.exit(3)
    time.sleep(0.1)
"""


def benchbot(*args: str, timeout: float = 600, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([*BENCHBOT, *args], capture_output=True, text=True, timeout=timeout, cwd=cwd,
                          stdin=subprocess.DEVNULL, env=dict(os.environ, COLUMNS="200"))


def status() -> dict:
    proc = benchbot("service", "status", "--json")
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


@pytest.fixture
def service_env(monkeypatch):
    """The service on, in a socket folder of this test's own (``XDG_RUNTIME_DIR``, a new folder in the temporary
    folder), idle for at most 120 s; any service left at the end is stopped (killed if it does not stop). Not under
    ``tmp_path``: under pytest-xdist that is 10 characters longer (``popen-gw1/``), and a pool worker's socket path
    there passed the 107 bytes a Unix socket's path may have, so the workers could not listen."""
    runtime = Path(tempfile.mkdtemp(prefix="bb-xdg-"))  # mode 0700, as a runtime folder must be
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(runtime))
    monkeypatch.setenv("BENCHBOT_SERVICE", "auto")
    monkeypatch.setenv("BENCHBOT_SERVICE_IDLE_S", "120")
    yield runtime / "benchbot"
    left = status()
    if left["running"]:
        benchbot("service", "stop", timeout=60)
        try:
            os.kill(left["pid"], signal.SIGKILL)
        except ProcessLookupError:
            pass
    shutil.rmtree(runtime, ignore_errors=True)


@pytest.fixture
def short_tmp():
    """A new folder (mode 0700) with a short path, removed afterwards."""
    folder = Path(tempfile.mkdtemp(prefix="bb-short-"))
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


# ------------------------------------------------------------------------------------------------ the parts, alone
def test_the_socket_folder_must_be_a_private_folder_of_the_user(tmp_path):
    made = location.private_dir(tmp_path / "fresh")
    assert stat.S_IMODE(made.stat().st_mode) == 0o700
    open_folder = tmp_path / "open"
    open_folder.mkdir(mode=0o755)
    os.chmod(open_folder, 0o755)
    with pytest.raises(UsageError, match="open to other users.*0755"):
        location.private_dir(open_folder)
    link = tmp_path / "link"
    link.symlink_to(made)
    with pytest.raises(UsageError, match="not a folder of its own"):
        location.private_dir(link)


def _deep_folder(root: Path, length: int) -> Path:
    """A folder of this user's under ``root`` whose path is ``length`` bytes or a few more."""
    folder = root
    while len(str(folder)) < length:
        folder = folder / ("d" * 40)
    folder.mkdir(parents=True, mode=0o700)
    return folder


def test_a_runtime_folder_too_long_for_the_pool_workers_sockets_is_passed_over(short_tmp, tmp_path, monkeypatch):
    """A pool worker's socket is the longest path the service makes; where ``XDG_RUNTIME_DIR`` is too long for it
    the temporary folder is used, and where that is too long too the command says so in one line."""
    monkeypatch.setenv("TMPDIR", str(short_tmp))
    monkeypatch.setattr(tempfile, "tempdir", None)  # gettempdir() reads TMPDIR again
    long_runtime = _deep_folder(tmp_path, 90)
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(long_runtime))
    assert location.runtime_dir() == short_tmp / f"benchbot-service-{os.geteuid()}"
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(short_tmp))
    assert location.runtime_dir() == short_tmp / "benchbot"
    monkeypatch.setenv("TMPDIR", str(_deep_folder(tmp_path / "t", 90)))
    monkeypatch.setattr(tempfile, "tempdir", None)
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(long_runtime))
    with pytest.raises(UsageError, match="too long for a Unix socket's path.*at most 107"):
        location.runtime_dir()
    proc = benchbot("service", "status")
    assert proc.returncode != 0 and "Traceback" not in proc.stderr, proc.stderr
    assert "too long for a Unix socket" in proc.stderr and "TMPDIR" in proc.stderr, proc.stderr


def test_the_installation_key_follows_code_and_settings_but_not_the_services_own(tmp_path, monkeypatch):
    base = {"PATH": "/usr/bin", "BENCHBOT_SIM_STYLE": "primitives"}
    key = location.installation_key(base)
    assert location.installation_key(dict(base)) == key
    assert location.installation_key({**base, "BENCHBOT_SIM_STYLE": "furnished"}) != key
    assert location.installation_key({**base, "TI_OFFLINE_CACHE_FILE_PATH": "/x"}) != key
    assert location.installation_key({**base, "BENCHBOT_SERVICE_IDLE_S": "5", "HOME": "/elsewhere"}) == key
    package = tmp_path / "benchbot_fake"
    package.mkdir()
    (package / "code.py").write_text("A = 1\n")
    monkeypatch.setattr(location, "_package_folders", lambda: [package])
    before = location.installation_key(base)
    (package / "code.py").write_text("A = 22\n")  # an edit of a checkout
    assert location.installation_key(base) != before


def test_messages_round_trip_and_an_oversized_one_is_refused():
    left, right = socket.socketpair(socket.AF_UNIX, socket.SOCK_STREAM)
    with left, right:
        protocol.send(left, {"event": "step", "info": {"pose": np.array([1.5, -2.0, 0.25]), "step": np.int64(3)}})
        assert protocol.receive(right) == {"event": "step", "info": {"pose": [1.5, -2.0, 0.25], "step": 3}}
        left.sendall((protocol.MAX_MESSAGE_BYTES + 1).to_bytes(4, "big"))
        with pytest.raises(protocol.ConnectionLost, match="announced"):
            protocol.receive(right)
    left, right = socket.socketpair(socket.AF_UNIX, socket.SOCK_STREAM)
    with right:
        left.close()
        with pytest.raises(protocol.ConnectionLost, match="closed the connection"):
            protocol.receive(right)


def test_a_process_of_the_user_is_served_and_one_in_a_sandboxs_user_namespace_is_refused(tmp_path):
    from benchbot.solutions.sandbox import check_available

    try:
        bwrap = check_available()
    except UsageError as exc:
        pytest.skip(exc.message)
    path = tmp_path / "s.sock"
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(str(path))
    listener.listen(4)
    problems: list[str] = []

    def judge() -> None:
        conn, _ = listener.accept()
        with conn:
            problems.append(protocol.peer_problem(conn))

    connect = f"import socket; socket.socket(socket.AF_UNIX).connect({str(path)!r})"
    for argv in ([sys.executable, "-c", connect],  # this user, this user namespace: served
                 [bwrap, "--unshare-user", "--dev-bind", "/", "/", sys.executable, "-c", connect]):  # as a sandbox
        judging = threading.Thread(target=judge)
        judging.start()
        subprocess.run(argv, check=True, timeout=60)
        judging.join(60)
    listener.close()
    assert problems[0] == ""
    assert "another user namespace" in problems[1]


# ------------------------------------------------------------------------------------------------ a real service
@pytest.mark.slow
def test_service_start_status_stop_and_the_owner_only_files(service_env):
    assert status()["running"] is False
    started = benchbot("service", "start")
    assert started.returncode == 0 and "started the simulator service" in started.stderr, started.stderr
    now = status()
    assert now["running"] and now["key"] == now["this_installation"] and now["episodes_served"] == 0
    assert stat.S_IMODE(service_env.stat().st_mode) == 0o700
    assert stat.S_IMODE((service_env / "service.sock").stat().st_mode) == 0o600
    again = benchbot("service", "start")
    assert "already running" in again.stderr and status()["pid"] == now["pid"]
    shown = benchbot("service", "status")
    assert "serves this installation:  yes" in shown.stdout, shown.stdout
    stopped = benchbot("service", "stop")
    assert stopped.returncode == 0 and f"stopped the simulator service (pid {now['pid']})" in stopped.stderr
    assert status()["running"] is False and not (service_env / "service.sock").exists()
    assert "no simulator service is running" in benchbot("service", "stop").stderr


@pytest.mark.slow
def test_the_service_stops_by_itself_after_its_idle_time(service_env, monkeypatch):
    monkeypatch.setenv("BENCHBOT_SERVICE_IDLE_S", "1")
    started = benchbot("service", "start")
    assert started.returncode == 0, started.stderr
    pid = int(re.search(r"started the simulator service, pid (\d+)", started.stderr).group(1))
    deadline = time.monotonic() + 60
    while (service_env / "service.sock").exists() and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not (service_env / "service.sock").exists(), "the idle service did not stop"
    while Path(f"/proc/{pid}").exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not Path(f"/proc/{pid}").exists(), "the idle service removed its socket but did not exit"


@pytest.mark.slow
def test_a_killed_service_is_replaced_and_one_of_other_settings_too(service_env, monkeypatch):
    assert benchbot("service", "start").returncode == 0
    first = status()["pid"]
    os.kill(first, signal.SIGKILL)
    time.sleep(0.5)
    assert (service_env / "service.sock").exists()  # a stale socket no one answers on
    restarted = benchbot("service", "start")
    assert "started the simulator service" in restarted.stderr, restarted.stderr
    second = status()["pid"]
    assert second != first
    monkeypatch.setenv("BENCHBOT_SIM_STYLE", "furnished")  # another key: the idle service is replaced
    assert status()["key"] != status()["this_installation"]
    replaced = benchbot("service", "start")
    assert "replaced the simulator service" in replaced.stderr, replaced.stderr
    assert status()["pid"] not in (first, second) and status()["key"] == status()["this_installation"]


def _run_files(run_dir: Path) -> dict[str, bytes]:
    """Every file of the results, trajectories and scores of a run directory, by relative path."""
    files = {}
    for name in ("results", "trajectories", "scores.json", "episode_scores.json"):
        path = run_dir / name
        for file in sorted(path.rglob("*")) if path.is_dir() else [path]:
            if file.is_file():
                files[str(file.relative_to(run_dir))] = file.read_bytes()
    return files


@pytest.mark.slow
def test_episodes_through_the_service_give_the_files_of_episodes_run_in_process_byte_for_byte(service_env, tmp_path):
    """semslam_geometric maps what it observes, so equal results mean equal observations, frame by frame; the second
    run through the service finds Taichi, its kernels and the scene loaded already."""
    outcome = {}
    for name, flags in (("in_process", ["--no-service"]), ("service_first", []), ("service_warm", [])):
        proc = benchbot("batch", "--example", "semslam_geometric", "--envs", "miniroom:1", "--repeat", "2", *SMALL,
                        "--output-dir", str(tmp_path / name), "--json", "--no-tui", *flags)
        assert proc.returncode == 0, proc.stderr
        assert ("started the simulator service" in proc.stderr) == (name == "service_first"), proc.stderr
        assert name != "service_first" or "the scene (miniroom:1" in proc.stderr, proc.stderr  # its stages shown
        outcome[name] = json.loads(proc.stdout)
        outcome[name]["files"] = _run_files(Path(outcome[name]["run_dir"]))
    # both through one service, unless the code changed in between (a checkout being edited): a new one then
    replaced = "replaced the simulator service" in proc.stderr
    assert status()["episodes_served"] == (2 if replaced else 4)
    if not replaced:  # the service kept the scene of the command before: nothing loaded, Taichi started already
        assert "loading the scene" not in proc.stderr and "starting Taichi" not in proc.stderr, proc.stderr
    reference = outcome["in_process"]
    assert any(json.loads(b)["results"]["objects"] for p, b in reference["files"].items() if p.startswith("results"))
    for name in ("service_first", "service_warm"):
        assert outcome[name]["files"] == reference["files"], name
        for mine, theirs in zip(outcome[name]["episodes"], reference["episodes"]):
            same = ("status", "steps", "collided", "seed", "backend", "returncode")
            assert {k: mine[k] for k in same} == {k: theirs[k] for k in same}


@pytest.mark.slow
def test_a_service_killed_mid_episode_is_a_one_line_error_and_the_next_command_starts_a_fresh_one(service_env,
                                                                                                   tmp_path):
    script, marker = tmp_path / "poll.py", tmp_path / "running"
    script.write_text(POLLING_SOLUTION)
    batch = subprocess.Popen([*BENCHBOT, "batch", "--native", f"{sys.executable} {script} {marker}", "--no-sandbox",
                              "--envs", "miniroom:1", *SMALL, "--no-tui", "--json", "--output-dir",
                              str(tmp_path / "runs")], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             stdin=subprocess.DEVNULL)
    deadline = time.monotonic() + 300
    while not marker.exists() and batch.poll() is None and time.monotonic() < deadline:
        time.sleep(0.1)
    assert marker.exists(), batch.communicate()[1]
    killed = status()["pid"]
    os.kill(killed, signal.SIGKILL)
    stdout, stderr = batch.communicate(timeout=120)
    assert batch.returncode != 0
    assert "Traceback" not in stderr, stderr
    outcome = json.loads(stdout)
    episode = outcome["episodes"][0]
    assert episode["status"] == "error"
    assert episode["error"].startswith("the simulator service stopped during the episode (killed or crashed; its "
                                       "log: ") and "\n" not in episode["error"]
    log = (Path(outcome["run_dir"]) / episode["log"]).read_text()  # the episode's log says why, too
    assert log.endswith(f"benchbot: the episode ended with an error: {episode['error']}\n"), log[-2000:]
    said = [line for line in stderr.splitlines() if "the simulator service stopped during the episode" in line]
    assert said and all(line.startswith(("[1/1] miniroom:1", "miniroom:1: error")) for line in said), stderr
    again = benchbot("batch", "--example", "hello_passive", "--envs", "miniroom:1", *SMALL, "--no-tui", "--json",
                     "--output-dir", str(tmp_path / "runs"))
    assert again.returncode == 0, again.stderr
    assert "started the simulator service" in again.stderr
    assert status()["pid"] != killed


@pytest.mark.slow
def test_a_sandboxed_solution_whose_folder_holds_the_socket_folder_cannot_see_it(service_env, short_tmp, tmp_path,
                                                                                monkeypatch):
    """The socket folder inside the solution's own folder (shown to it, read-only) is hidden: the solution finds an
    empty folder where the socket is. (A short folder, not under ``tmp_path``: there the sockets' paths would be too
    long for a Unix socket, and the service would pass the folder over.)"""
    solution = short_tmp
    (solution / "run").mkdir(parents=True, mode=0o700)
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(solution / "run"))
    socket_path = solution / "run" / "benchbot" / "service.sock"
    (solution / "look.py").write_text(
        "import os, sys\n"
        f"print('SOCKET VISIBLE:', os.path.exists({str(socket_path)!r}))\n"
        f"print('SOLUTION FOLDER SHOWN:', os.path.exists({str(solution / 'look.py')!r}))\n")
    proc = benchbot("batch", "--native", "python look.py", "--envs", "miniroom:1", *SMALL, "--no-tui", "--json",
                    "--no-evaluate", "--output-dir", str(tmp_path / "runs"), cwd=solution)
    assert socket_path.exists(), proc.stderr  # the service runs, its socket in the solution's folder
    run_dir = Path(json.loads(proc.stdout)["run_dir"])
    log = (run_dir / json.loads(proc.stdout)["episodes"][0]["log"]).read_text()
    assert "SOLUTION FOLDER SHOWN: True" in log and "SOCKET VISIBLE: False" in log, log
    benchbot("service", "stop")


# ------------------------------------------------------------------------------------ the pool: batch --workers N
@pytest.mark.slow
def test_batches_with_workers_are_served_by_warm_pool_workers_byte_for_byte(service_env, tmp_path):
    """``--workers 2`` through the service: two warm worker processes of its pool serve the episodes; the second
    command finds them (same pids) with Taichi started and the scene loaded; results, trajectories and scores are
    those of the batch's own worker processes (``--no-service``), byte for byte."""
    outcome, pools = {}, {}
    for name, flags in (("in_process", ["--no-service"]), ("pool_first", []), ("pool_warm", [])):
        proc = benchbot("batch", "--example", "semslam_geometric", "--envs", "miniroom:1", "--repeat", "2",
                        "--workers", "2", *SMALL, "--output-dir", str(tmp_path / name), "--json", "--no-tui", *flags)
        assert proc.returncode == 0, proc.stderr
        outcome[name] = json.loads(proc.stdout)
        outcome[name]["files"] = _run_files(Path(outcome[name]["run_dir"]))
        outcome[name]["stderr"] = proc.stderr
        if name != "in_process":
            pools[name] = status()["pool"]
            assert len(pools[name]) == 2 and all(not w["busy"] and w["gpu"] is None for w in pools[name])
    reference = outcome["in_process"]
    for name in ("pool_first", "pool_warm"):
        assert outcome[name]["files"] == reference["files"], name
        assert [e["status"] for e in outcome[name]["episodes"]] == ["ok", "ok"]
    if "replaced the simulator service" not in outcome["pool_warm"]["stderr"]:  # the code did not change meanwhile
        assert {w["pid"] for w in pools["pool_warm"]} == {w["pid"] for w in pools["pool_first"]}
        assert sum(w["served"] for w in pools["pool_warm"]) == 4
        assert "starting Taichi" not in outcome["pool_warm"]["stderr"], outcome["pool_warm"]["stderr"]


@pytest.mark.slow
def test_a_pool_worker_killed_mid_episode_is_a_one_line_error_and_the_next_episode_gets_a_fresh_one(service_env,
                                                                                                    tmp_path):
    script, marker = tmp_path / "poll.py", tmp_path / "running"
    script.write_text(POLLING_SOLUTION)
    batch = subprocess.Popen([*BENCHBOT, "batch", "--native", f"{sys.executable} {script} {marker}", "--no-sandbox",
                              "--envs", "miniroom:1", "--workers", "2", *SMALL, "--no-tui", "--json", "--output-dir",
                              str(tmp_path / "runs")], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             stdin=subprocess.DEVNULL)
    deadline = time.monotonic() + 300
    while not marker.exists() and batch.poll() is None and time.monotonic() < deadline:
        time.sleep(0.1)
    assert marker.exists(), batch.communicate()[1]
    service_pid = status()["pid"]
    busy = [w["pid"] for w in status()["pool"] if w["busy"]]
    assert len(busy) == 1
    os.kill(busy[0], signal.SIGKILL)
    stdout, stderr = batch.communicate(timeout=120)
    assert batch.returncode != 0 and "Traceback" not in stderr, stderr
    episode = json.loads(stdout)["episodes"][0]
    assert episode["status"] == "error"
    assert episode["error"].startswith(f"the simulator service's worker (pid {busy[0]}) stopped during the episode "
                                       "(killed or crashed; its log: ") and "\n" not in episode["error"], episode
    again = benchbot("batch", "--example", "hello_passive", "--envs", "miniroom:1", "--workers", "2", *SMALL,
                     "--no-tui", "--json", "--output-dir", str(tmp_path / "runs"))
    assert again.returncode == 0, again.stderr
    if "replaced the simulator service" not in again.stderr:  # the same service, a fresh worker
        assert status()["pid"] == service_pid
    assert busy[0] not in [w["pid"] for w in status()["pool"]]


@pytest.mark.slow
def test_the_pool_puts_a_gpu_batchs_workers_on_every_gpu(service_env, tmp_path, monkeypatch):
    """Two GPUs listed (a stand-in ``nvidia-smi``), ``--arch cuda --workers 2``: the pool's two workers get one GPU
    each (``CUDA_VISIBLE_DEVICES``); on this machine without CUDA, Taichi falls back to the CPU, and the records
    then name no GPU."""
    folder = tmp_path / "bin"
    folder.mkdir()
    (folder / "nvidia-smi").write_text("#!/bin/sh\n[ \"$1\" = \"-L\" ] || exit 9\n"
                                       "echo 'GPU 0: NVIDIA Fake A (UUID: GPU-0a0a0a0a-0000-0000-0000-000000000000)'\n"
                                       "echo 'GPU 1: NVIDIA Fake B (UUID: GPU-1b1b1b1b-0000-0000-0000-000000000000)'\n")
    (folder / "nvidia-smi").chmod(0o755)
    monkeypatch.setenv("PATH", f"{folder}{os.pathsep}{os.environ['PATH']}")
    proc = benchbot("batch", "--example", "hello_passive", "--envs", "miniroom:1", "--repeat", "2", "--workers", "2",
                    "--arch", "cuda", *SMALL, "--no-tui", "--json", "--output-dir", str(tmp_path / "runs"))
    assert proc.returncode == 0, proc.stderr
    workers = status()["pool"]
    assert sorted((w["gpu"]["index"], w["gpu"]["name"]) for w in workers) == [(0, "NVIDIA Fake A"),
                                                                                (1, "NVIDIA Fake B")]
    episodes = json.loads(proc.stdout)["episodes"]
    assert all(e["status"] == "ok" and "gpu" not in e["node"] and e["backend"]["arch"] == "x64" for e in episodes)
