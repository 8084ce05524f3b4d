"""``benchbot run`` through the resident simulator service (docs/service.md), tested for real: a real service on a
real socket folder of the test's own (``service_env``), a real ``benchbot run`` process on a real port, real clients
over loopback (``benchbot submit`` and the original client's request sequence), Ctrl-C as SIGINT. The backend
serves what it serves in the command's own process, byte for byte, on the port the command was given; Ctrl-C frees
the service and the port; a killed service is one line; a recording, ``--no-service`` and a service busy with
another installation's episode run in the command's process."""

from __future__ import annotations

import os
import queue
import re
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from test_service import BENCHBOT, SMALL, service_env, status  # noqa: E402, F401 - service_env is a fixture

READY = "backend ready at "
STARTED = "started the simulator service"
#: The live view's pose line (benchbot.tui.run_app.describe): the view shows the service's snapshot.
VIEW_POSE = r"pose +x [+-]\d"


class RunningBackend:
    """A ``benchbot run -e miniroom:1`` process (small camera, no live view, ``flags`` added), its stderr read on a
    thread; :attr:`address` once it said it serves."""

    def __init__(self, *flags: str, env: dict | None = None, port: int = 0) -> None:
        self.proc = subprocess.Popen([*BENCHBOT, "run", "-e", "miniroom:1", "--port", str(port), "--no-tui", *SMALL,
                                      *flags], stderr=subprocess.PIPE, stdout=subprocess.DEVNULL,
                                     stdin=subprocess.DEVNULL, text=True,
                                     env=dict(os.environ, COLUMNS="400", **(env or {})))
        self.lines: list[str] = []
        self._new: queue.Queue = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()
        self.address = self.wait_for(READY).split(READY, 1)[1].split()[0]

    def _read(self) -> None:
        for line in self.proc.stderr:
            self.lines.append(line.rstrip("\n"))
            self._new.put(line)
        self._new.put(None)

    def wait_for(self, text: str, timeout_s: float = 300) -> str:
        """The first line holding ``text`` (waiting for it). AssertionError: the process ended or it took too long."""
        deadline = time.monotonic() + timeout_s
        seen = 0
        while True:
            for line in self.lines[seen:]:
                if text in line:
                    return line
            seen = len(self.lines)
            try:
                if self._new.get(timeout=max(0.01, deadline - time.monotonic())) is None:
                    raise AssertionError(f"benchbot run ended before saying {text!r}:\n" + "\n".join(self.lines))
            except queue.Empty:
                raise AssertionError(f"benchbot run did not say {text!r}:\n" + "\n".join(self.lines)) from None

    def stop(self, sig: int = signal.SIGINT, timeout_s: float = 60) -> int:
        """Send ``sig`` (Ctrl-C by default); the exit status."""
        self.proc.send_signal(sig)
        code = self.proc.wait(timeout=timeout_s)
        time.sleep(0.1)  # the reader thread takes the last lines
        return code

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()


def submit_example(address: str, results: Path) -> subprocess.CompletedProcess:
    """``benchbot submit --example semslam_geometric`` against ``address``, its results copied to ``results``."""
    return subprocess.run([*BENCHBOT, "submit", "--example", "semslam_geometric", "--address", address,
                           "--results-location", str(results)], capture_output=True, text=True, timeout=300,
                          stdin=subprocess.DEVNULL, cwd=results.parent)


def original_client_observations(address: str, steps: int = 2) -> list[dict]:
    """The original client's (``tests/legacy_client.py``) observations after its start and ``steps`` actions."""
    from legacy_client import LegacyBenchBot

    bot = LegacyBenchBot(supervisor_address=address, poll_s=0.1)
    seen = [bot.reset()[0]]
    for _ in range(steps):
        seen.append(bot.step(bot.actions[0])[0])
    return seen


def same_observations(a: list[dict], b: list[dict]) -> bool:
    """Whether two lists of observation dicts hold equal values (arrays element for element)."""
    def same(x, y) -> bool:
        if isinstance(x, dict):
            return isinstance(y, dict) and x.keys() == y.keys() and all(same(x[k], y[k]) for k in x)
        if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            return np.array_equal(np.asarray(x), np.asarray(y))
        if isinstance(x, (list, tuple)):
            return len(x) == len(y) and all(same(p, q) for p, q in zip(x, y))
        return x == y
    return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def can_listen_on(port: int) -> bool:
    with socket.socket() as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind(("127.0.0.1", port))
            probe.listen(1)
        except OSError:
            return False
    return True


@pytest.mark.slow
def test_run_serves_through_the_service_what_it_serves_in_process_and_ctrl_c_frees_service_and_port(service_env,
                                                                                                     tmp_path):
    """The same port either way (the command's reserved socket, passed to the service); equal observations for the
    original client and byte-identical results of a submitted example; after Ctrl-C the service is free and healthy
    (a second ``run`` uses it, warm) and the port can be taken again."""
    outcome = {}
    for name, flags in (("in_process", ["--no-service"]), ("service", []), ("service_warm", [])):
        port = free_port()
        backend = RunningBackend(*flags, port=port)
        try:
            assert backend.address == f"http://127.0.0.1:{port}/", backend.lines
            said = [line for line in backend.lines if STARTED in line]
            assert len(said) == (1 if name == "service" else 0), backend.lines
            if name != "in_process":
                assert status()["episodes_running"] == 1
            folder = tmp_path / name
            folder.mkdir()
            proc = submit_example(backend.address, folder / "results.json")
            assert proc.returncode == 0, proc.stderr
            observed = original_client_observations(backend.address)  # the episode is free again: a new start
            assert backend.stop() == 130, backend.lines
        finally:
            backend.kill()
        assert backend.lines[-1] == "interrupted" and not any("Traceback" in line for line in backend.lines)
        assert can_listen_on(port), f"{name}: port {port} still taken after Ctrl-C"
        outcome[name] = (observed, (folder / "results.json").read_bytes(), backend.lines)
        if name != "in_process":
            now = status()
            assert now["running"] and now["episodes_running"] == 0, now
    assert status()["episodes_served"] == 2  # both runs through one service
    assert not any("loading the scene" in line for line in outcome["service_warm"][2])  # kept loaded
    reference_observed, reference_results, _ = outcome["in_process"]
    assert len(reference_observed[0]["image_rgb"]) and b'"objects"' in reference_results
    for name in ("service", "service_warm"):
        assert same_observations(outcome[name][0], reference_observed), name
        assert outcome[name][1] == reference_results, name


@pytest.mark.slow
def test_a_service_killed_while_run_serves_is_one_line_and_a_recording_runs_in_process(service_env, tmp_path):
    backend = RunningBackend()
    try:
        killed = status()["pid"]
        os.kill(killed, signal.SIGKILL)
        code = backend.proc.wait(timeout=60)
        time.sleep(0.1)
    finally:
        backend.kill()
    assert code == 5, backend.lines  # a backend error
    errors = [line for line in backend.lines if line.startswith("error:")]
    assert len(errors) == 1 and errors[0].startswith("error: the simulator service stopped during the episode "
                                                     "(killed or crashed; its log: "), backend.lines
    assert not any("Traceback" in line for line in backend.lines)
    assert not status()["running"]
    recorded = RunningBackend("--record", str(tmp_path / "episode.mcap"))
    try:
        assert not status()["running"], recorded.lines  # nothing started: the recorder observes it here
        assert recorded.stop() == 130
    finally:
        recorded.kill()
    assert (tmp_path / "episode.mcap").stat().st_size > 0


@pytest.mark.slow
def test_run_beside_a_busy_service_of_other_settings_runs_in_process(service_env, tmp_path):
    """Another installation's service serving an episode cannot be replaced: the command says so in one line and
    serves the backend itself; the other episode goes on."""
    other = RunningBackend(env={"BENCHBOT_OTHER_INSTALLATION": "1"})  # a BENCHBOT_* variable: another key
    try:
        assert status()["key"] != status()["this_installation"]
        mine = RunningBackend()
        try:
            busy = [line for line in mine.lines if "is busy" in line]
            assert len(busy) == 1 and "runs another installation's code or settings" in busy[0], \
                (mine.lines, other.lines, status())
            assert not any(STARTED in line for line in mine.lines)
            with urllib.request.urlopen(mine.address, timeout=10) as reply:
                assert reply.status == 200
            assert status()["episodes_running"] == 1  # the other command's only
            assert mine.stop() == 130
        finally:
            mine.kill()
        with urllib.request.urlopen(other.address, timeout=10) as reply:
            assert reply.status == 200
        assert other.stop() == 130
    finally:
        other.kill()


@pytest.mark.slow
def test_the_service_serves_a_pool_workers_backend_on_the_commands_socket_with_its_token(service_env):
    """The path of ``run`` on a GPU (a warm worker of the service's pool), here on the CPU: the command's listening
    socket and its token reach the worker; a request without the token is refused, one with it served."""
    from benchbot.core.registry import get_registry
    from benchbot.core.session import resolve_run
    from benchbot.service.episodes import ServiceEpisode

    spec = resolve_run(get_registry(), "semantic_slam:passive:ground_truth", "carter", "miniroom:1")
    listener = socket.create_server(("127.0.0.1", 0))
    port = listener.getsockname()[1]
    tcp = {"host": "127.0.0.1", "token": "s3cret", "action_timeout_s": 5.0, "tls_cert": None, "tls_key": None}
    served = ServiceEpisode(spec, seed=0, options={"arch": "cpu", "width": 64, "height": 48}, world_seed=None,
                            on_step=lambda info: None, on_stage=lambda event: None,
                            pool={"threads": 1, "gpus": [], "world": "test"}, tcp=tcp, listener=listener)
    listener.close()
    try:
        assert served.address == f"http://127.0.0.1:{port}/"
        with pytest.raises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(served.address + "robot/is_running", timeout=30)
        assert refused.value.code == 401
        request = urllib.request.Request(served.address + "robot/is_running", headers={"X-BenchBot-Token": "s3cret"})
        with urllib.request.urlopen(request, timeout=30) as reply:
            assert reply.status == 200
        assert [w["busy"] for w in status()["pool"]] == [True]
    finally:
        served.end()
    assert can_listen_on(port)
    assert [w["busy"] for w in status()["pool"]] == [False]


def test_a_listening_socket_passes_over_the_service_connection_and_a_byte_without_one_is_refused():
    """What ``run`` hands the service: the receiver gets its own descriptor of the same listening socket, which
    accepts after the sender closed its own; a byte that carries no socket is a lost connection, not a hang."""
    from benchbot.service import protocol

    ours, theirs = socket.socketpair()
    with ours, theirs:
        listener = socket.create_server(("127.0.0.1", 0))
        address = listener.getsockname()
        protocol.send_listener(ours, listener)
        listener.close()
        with protocol.receive_listener(theirs) as passed:
            assert passed.getsockname() == address
            with socket.create_connection(address, timeout=5):
                accepted, _ = passed.accept()
                accepted.close()
        ours.sendall(b"L")
        with pytest.raises(protocol.ConnectionLost, match="listening socket did not arrive"):
            protocol.receive_listener(theirs)


@pytest.mark.slow
def test_runs_live_view_at_a_terminal_shows_the_episode_the_service_serves(service_env):
    """``benchbot run`` at a terminal (the live view by default) through the service: the view shows the task and the
    client's actions from the snapshots the service writes; Ctrl-C in the view ends the episode in the service."""
    from terminal import Terminal

    argv = [*BENCHBOT, "run", "-e", "miniroom:1", "--port", "0", *SMALL]
    with Terminal(argv, env=dict(os.environ, COLUMNS="160")) as terminal:
        assert terminal.wait_for(r"backend ready at http://127\.0\.0\.1:\d+/", 300), terminal.text
        assert STARTED in terminal.text
        address = re.search(r"backend ready at (http://127\.0\.0\.1:\d+/)", terminal.text)[1]
        assert terminal.wait_for(VIEW_POSE, 60), terminal.text
        assert status()["episodes_running"] == 1
        original_client_observations(address, steps=2)
        assert terminal.wait_for(r"move_next\(\) → .*SUCCESS", 60), terminal.text[-3000:]
        terminal.press(b"\x03")
        assert terminal.wait(60) == 130, terminal.text[-3000:]
    assert "Traceback" not in terminal.text
    now = status()
    assert now["running"] and now["episodes_running"] == 0 and now["episodes_served"] == 1, now


@pytest.mark.slow
def test_a_service_killed_under_runs_live_view_closes_the_view_with_one_line(service_env):
    from terminal import Terminal

    argv = [*BENCHBOT, "run", "-e", "miniroom:1", "--port", "0", *SMALL]
    with Terminal(argv, env=dict(os.environ, COLUMNS="160")) as terminal:
        assert terminal.wait_for(READY, 300) and terminal.wait_for(VIEW_POSE, 60), terminal.text[-3000:]
        os.kill(status()["pid"], signal.SIGKILL)
        assert terminal.wait(60) == 5, terminal.text[-3000:]
    said = re.sub(r"\s+", " ", terminal.text)  # the terminal wraps long lines
    assert said.count("error: the simulator service stopped during the episode (killed or crashed") == 1, said
    assert "Traceback" not in terminal.text
