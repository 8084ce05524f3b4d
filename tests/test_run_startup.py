"""``benchbot run``'s start-up, as a user meets it: bad input (a taken port, a folder as --record) fails in one line
before the simulator is built; the port is taken first and clients that connect meanwhile are served once it is
ready."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time

import httpx
import pytest

from benchbot.server import SUPERVISOR_GREETING

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]
SIMULATOR_STARTED = "[Taichi]"  # the simulator's banner: printed when the backend is being built


def cli(*args: str, timeout: float = 60) -> subprocess.CompletedProcess:
    return subprocess.run([*BENCHBOT, *args], capture_output=True, text=True, timeout=timeout,
                          env=dict(os.environ, COLUMNS="200"))


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def test_a_port_in_use_is_said_first_in_one_line():
    """Before: the simulator was built, then uvicorn printed its own ERROR line, then ours."""
    with socket.create_server(("127.0.0.1", 0)) as taken:
        port = taken.getsockname()[1]
        proc = cli("run", "--env", "miniroom:1", "--port", str(port), "--no-tui")
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.splitlines() == [f"error: port {port} on 127.0.0.1 is in use",
                                        "hint: --port 0 picks a free one, or stop the other backend"], proc.stderr


def test_a_folder_as_record_fails_before_the_simulator(tmp_path):
    """Before: the backend served, and the recording failed with a traceback only when it was stopped."""
    proc = cli("run", "--env", "miniroom:1", "--port", "0", "--no-tui", "--record", str(tmp_path))
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.startswith(f"error: --record {tmp_path} is a folder"), proc.stderr
    assert SIMULATOR_STARTED not in proc.stderr and "Traceback" not in proc.stderr


@pytest.mark.slow
def test_an_address_of_another_machine_fails_before_the_simulator():
    """Before: a token was generated and printed, the simulator built, then uvicorn's bind error came."""
    proc = cli("run", "--env", "miniroom:1", "--host", "192.0.2.1", "--port", "0", "--no-tui")  # TEST-NET-1
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.startswith("error: cannot listen on 192.0.2.1:0"), proc.stderr
    assert SIMULATOR_STARTED not in proc.stderr and "token" not in proc.stderr and len(proc.stderr.splitlines()) == 2


@pytest.mark.slow
def test_the_port_is_taken_first_and_early_clients_are_served():
    """The port listens before the backend is built (seconds before 'backend ready'; before: only once it was
    built); a client that connects meanwhile gets its answer once the backend is ready; after SIGTERM the port is
    free again."""
    port = _free_port()
    proc = subprocess.Popen([*BENCHBOT, "run", "--env", "miniroom:1", "--port", str(port), "--no-tui",
                             "--camera-size", "64x48"], stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                            env=dict(os.environ, COLUMNS="200"))
    watchdog = threading.Timer(120, proc.kill)  # a backend that never comes up cannot hang the test
    watchdog.start()
    ready_at: list[float] = []

    def read_stderr():
        for line in proc.stderr:
            if "backend ready" in line:
                ready_at.append(time.monotonic())

    reader = threading.Thread(target=read_stderr, daemon=True)
    reader.start()
    try:
        deadline = time.monotonic() + 60
        while True:  # connect as soon as anything listens
            try:
                early = socket.create_connection(("127.0.0.1", port), timeout=1)
                connected_at = time.monotonic()
                break
            except OSError:
                assert proc.poll() is None and time.monotonic() < deadline, "benchbot run never listened"
                time.sleep(0.05)
        with early:
            early.settimeout(90)
            early.sendall(f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n\r\n".encode())
            reply = b""
            while chunk := early.recv(65536):
                reply += chunk
        assert reply.startswith(b"HTTP/1.1 200") and SUPERVISOR_GREETING.encode() in reply, reply[:200]
        assert httpx.get(f"http://127.0.0.1:{port}/", timeout=10).json() == SUPERVISOR_GREETING
        wait_until = time.monotonic() + 10  # the line may come just after the first answers
        while not ready_at and proc.poll() is None and time.monotonic() < wait_until:
            time.sleep(0.05)
        assert ready_at and ready_at[0] - connected_at > 0.5, "the port should listen while the backend is built"
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=60) == 130
    finally:
        watchdog.cancel()
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    with socket.create_server(("127.0.0.1", port)):  # released
        pass
