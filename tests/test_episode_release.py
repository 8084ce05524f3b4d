"""Finished means finished: the episode is free again as soon as the client using it has ended, however it ended,
and every refusal a user can meet is one line with its fix (docs/protocol.md, "One client at a time").

Real backends on 127.0.0.1 (the ``served`` fixture, the default 60 s lease), real child processes, the real
``benchbot submit``: a client object dropped without ``close()`` (the examples' ``BenchBot(agent=...).run()``), a
solution killed with SIGKILL mid-episode, an original client that never releases; the supervisor's release and who
may send it; the one-line errors in the solution's terminal and in the CLI's.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import tempfile
import textwrap
import threading
import time
from pathlib import Path

import httpx
import pytest
import uvicorn

from benchbot.api import BenchBot
from benchbot.api.benchbot import BackendRefused, BackendUnreachable, EpisodeRefused, HttpTransport
from benchbot.protocol import wire
from benchbot.server import CLIENT_HEADER, ServerThread, build_app

PASSIVE = "semantic_slam:passive:ground_truth"
TESTS = Path(__file__).resolve().parent
BENCHBOT = [sys.executable, "-m", "benchbot.cli"]


def _child(code: str, address: str, **env: str) -> subprocess.Popen:
    """A Python child process running ``code`` against the backend at ``address`` (stdout and stderr piped)."""
    return subprocess.Popen([sys.executable, "-c", textwrap.dedent(code)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ, BENCHBOT_SUPERVISOR_ADDRESS=address, **env))


def _starts(address: str) -> bool:
    """Whether a new client can start (reset) the episode now: True, or False when it is refused (409)."""
    try:
        BenchBot(supervisor_address=address).close()
    except EpisodeRefused:
        return False
    return True


def _submit(address: str, *args: str, cwd: Path | None = None, env: dict | None = None,
            ) -> subprocess.CompletedProcess:
    """``benchbot submit`` to ``address``; its results file goes to a temporary folder removed afterwards."""
    with tempfile.TemporaryDirectory(prefix="benchbot-release-test-") as results:
        return subprocess.run([*BENCHBOT, "submit", "--address", address, "--no-sandbox", *args], cwd=cwd,
                              capture_output=True, text=True, timeout=240,
                              env=dict(os.environ, COLUMNS="200",
                                       BENCHBOT_RESULT_LOCATION=str(Path(results) / "result.json"), **(env or {})))


AGENT = """
from benchbot.api import ActionResult, Agent, BenchBot

class Two(Agent):
    steps = 0
    def is_done(self, result):
        return result != ActionResult.SUCCESS or self.steps >= 2
    def pick_action(self, observations, actions):
        self.steps += 1
        return "move_next", {}
    def save_result(self, filename, empty_results, fns):
        pass
"""


# ------------------------------------------------------------------------------------------- the client itself
def test_an_example_style_client_frees_the_episode_when_its_process_exits(served):
    """``BenchBot(agent=...).run()`` drops its object as soon as run returns: the episode is released then (it was
    held for the whole lease before, as nothing released it at exit)."""
    _, server = served(PASSIVE, "miniroom:1")
    child = _child(AGENT + "BenchBot(agent=Two()).run()\n", server.address)
    _, err = child.communicate(timeout=120)
    assert child.returncode == 0, err
    assert _starts(server.address), "the next client must start at once"


def test_a_dropped_client_frees_the_episode_while_its_process_lives(served):
    _, server = served(PASSIVE, "miniroom:1")
    child = _child("""
        import sys, time
        from benchbot.api import BenchBot
        BenchBot().step("move_next")  # the object is dropped right away, never closed
        print("dropped", flush=True)
        time.sleep(60)
        """, server.address)
    try:
        assert child.stdout.readline().strip() == "dropped", child.stderr.read()
        assert _starts(server.address)
    finally:
        child.kill()
        child.communicate()


def test_a_forked_child_that_exits_leaves_its_parents_episode_alone(served):
    """The release at exit belongs to the process that made the client: a forked helper that exits normally (its
    exit handlers run) must not release the episode its parent is using."""
    _, server = served(PASSIVE, "miniroom:1")
    child = _child("""
        import os, sys, time
        from benchbot.api import BenchBot
        bot = BenchBot()
        bot.step("move_next")
        pid = os.fork()
        if pid == 0:
            sys.exit(0)  # runs the exit handlers of the inherited client
        os.waitpid(pid, 0)
        print("forked", flush=True)
        time.sleep(60)
        """, server.address)
    try:
        assert child.stdout.readline().strip() == "forked", child.stderr.read()
        assert not _starts(server.address), "the parent still uses the episode"
    finally:
        child.kill()
        child.communicate()


# ------------------------------------------------------------------------------------- the supervisor's release
def test_a_supervisor_release_ends_a_clients_hold_and_refuses_it_afterwards(served):
    _, server = served(PASSIVE, "miniroom:1")
    solution = BenchBot(transport=HttpTransport(server.address, 60.0))
    solution.step("move_next")
    solution_id = solution.transport.client_id
    assert not _starts(server.address)
    # anyone may ask whether it could start now; asking claims nothing
    asked = httpx.post(server.address + "robot/is_free", headers={CLIENT_HEADER: "q" * 32}).json()
    assert asked["is_free"] is False and asked["error"].startswith("the episode belongs to another client: ")
    assert httpx.post(server.address + "robot/is_free", headers={CLIENT_HEADER: solution_id}).json() == \
        {"is_free": True}
    # another id's release changes nothing; the solution's own id ends its hold
    assert httpx.post(server.address + "robot/release", json={"client": "f" * 32}).json() == \
        {"release_success": False}
    assert not _starts(server.address)
    assert httpx.post(server.address + "robot/release", json={"client": solution_id}).json() == \
        {"release_success": True}
    other = BenchBot(supervisor_address=server.address)  # starts at once
    other.close()
    # a request the ended solution left behind never takes the episode back, even once the episode is free
    with pytest.raises(EpisodeRefused, match="its supervisor \\(benchbot submit\\) released the episode"):
        solution.step("move_next")
    solution.close()


def test_a_supervisor_release_names_the_anonymous_original_client(served):
    _, server = served(PASSIVE, "miniroom:1")
    assert httpx.post(server.address + "robot/is_running", json={}).status_code == 200  # an original client starts
    assert not _starts(server.address)
    assert httpx.post(server.address + "robot/release", json={"client": "f" * 32}).json() == \
        {"release_success": False}, "an id names only that id"
    assert httpx.post(server.address + "robot/release", json={"anonymous": True}).json() == \
        {"release_success": True}
    assert _starts(server.address)
    # the anonymous client is not refused afterwards: the next original client of this host is the same client
    assert httpx.post(server.address + "robot/is_running", json={}).status_code == 200
    for body in ({"client": "short"}, {"client": 7}, {"anonymous": "yes"}):
        reply = httpx.post(server.address + "robot/release", json=body)
        assert reply.status_code == 400 and "\n" not in reply.json()["error"], body


def test_a_solution_killed_during_a_request_frees_the_episode_when_that_request_ends(served):
    service, server = served(PASSIVE, "miniroom:1")
    solution_id = "k" * 32
    gate = threading.Event()
    service.executor.submit(gate.wait, 30)  # the backend thread is busy: the solution's next step waits behind it
    headers = {CLIENT_HEADER: solution_id, "content-type": wire.MSGPACK_TYPE}
    step = threading.Thread(target=httpx.post, args=(server.address + "native/step",),
                            kwargs={"content": wire.pack({"action": "move_next", "args": {}}), "headers": headers,
                                    "timeout": 60})
    step.start()
    deadline = time.monotonic() + 10
    while server.app.state.ownership.in_flight == 0 and time.monotonic() < deadline:
        time.sleep(0.01)
    assert server.app.state.ownership.owner == f"id:{solution_id}"
    # the solution is dead; its step still runs: the release waits for it
    assert httpx.post(server.address + "robot/release", json={"client": solution_id}).json() == \
        {"release_success": True}
    refused = httpx.post(server.address + "robot/reset", json={}, headers={CLIENT_HEADER: "n" * 32})
    assert refused.status_code == 409 and "still running" in refused.json()["error"]
    gate.set()
    step.join(30)
    assert _starts(server.address), "free once the last request of the ended solution is over"


def _unix_server(app, path: str) -> tuple[uvicorn.Server, threading.Thread]:
    server = uvicorn.Server(uvicorn.Config(app, uds=path, log_level="warning", lifespan="off"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 10
    while not server.started and time.monotonic() < deadline:
        time.sleep(0.01)
    return server, thread


@pytest.mark.parametrize("token", [None, "s3cret-token"])
def test_only_the_backends_host_or_a_token_holder_may_release_another_client(make_service, token):
    """A caller with no address (a Unix socket: how a sandboxed solution reaches a tokenless backend through its
    relay) may release its own hold but not another client's: 403. With the backend's token it may."""
    service = make_service(PASSIVE, "miniroom:1")
    owner = "o" * 32
    with tempfile.TemporaryDirectory() as folder:
        path = str(Path(folder) / "backend.sock")
        server, thread = _unix_server(build_app(service, token=token), path)
        try:
            auth = {"X-BenchBot-Token": token} if token else {}
            with httpx.Client(transport=httpx.HTTPTransport(uds=path), base_url="http://backend") as http:
                assert http.post("/robot/reset", json={}, headers={CLIENT_HEADER: owner, **auth}).status_code == 200
                reply = http.post("/robot/release", json={"client": owner}, headers=auth)
                if token is None:
                    assert reply.status_code == 403 and "only the supervisor" in reply.json()["error"]
                    assert http.post("/robot/reset", json={}, headers={CLIENT_HEADER: "p" * 32}).status_code == 409
                    # its own hold, it may always give up
                    assert http.post("/robot/release", headers={CLIENT_HEADER: owner}).json() == \
                        {"release_success": True}
                else:
                    assert reply.json() == {"release_success": True}
                assert http.post("/robot/reset", json={}, headers={CLIENT_HEADER: "p" * 32, **auth}).status_code \
                    == 200
        finally:
            server.should_exit = True
            thread.join(10)


# ---------------------------------------------------------------------------------------- benchbot submit
@pytest.mark.slow
def test_submit_twice_in_a_row(served):
    _, server = served(PASSIVE, "miniroom:1")
    for attempt in (1, 2):
        proc = _submit(server.address, "--example", "hello_passive")
        assert proc.returncode == 0, (attempt, proc.stderr)
        assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_submit_frees_the_episode_of_a_solution_killed_mid_episode(served, tmp_path):
    _, server = served(PASSIVE, "miniroom:1")
    (tmp_path / "killed.py").write_text(textwrap.dedent("""
        import os, signal
        from benchbot.api import BenchBot
        bot = BenchBot()
        bot.step("move_next")
        os.kill(os.getpid(), signal.SIGKILL)  # no close, no exit handler: only the supervisor can release
        """))
    proc = _submit(server.address, "--native", "python", "killed.py", cwd=tmp_path)
    assert proc.returncode != 0 and "status -9" in proc.stderr, proc.stderr
    assert _starts(server.address), "the supervisor released the killed solution's hold"


@pytest.mark.slow
def test_submit_frees_the_episode_of_an_original_client(served, tmp_path):
    """The original client sends no id and never releases: the supervisor releases the anonymous client."""
    _, server = served(PASSIVE, "miniroom:1")
    (tmp_path / "original.py").write_text(textwrap.dedent(f"""
        import os, sys
        sys.path.insert(0, {str(TESTS)!r})
        from legacy_client import LegacyBenchBot

        class Two:
            steps = 0
            def is_done(self, result):
                return result.name != "SUCCESS" or self.steps >= 2
            def pick_action(self, observations, actions):
                self.steps += 1
                return "move_next", {{}}
            def save_result(self, filename, empty_results, fns):
                pass

        LegacyBenchBot(agent=Two(), supervisor_address=os.environ["BENCHBOT_SUPERVISOR_ADDRESS"], poll_s=0.1).run()
        """))
    proc = _submit(server.address, "--native", "python", "original.py", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert _starts(server.address)


@pytest.mark.slow
def test_submit_against_a_held_episode_is_one_line_and_runs_nothing(served, tmp_path):
    _, server = served(PASSIVE, "miniroom:1")
    holder = BenchBot(supervisor_address=server.address)
    marker = tmp_path / "ran"
    (tmp_path / "solution.py").write_text(f"open({str(marker)!r}, 'w')\n")
    proc = _submit(server.address, "--native", "python", "solution.py", cwd=tmp_path)
    assert proc.returncode == 5, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if not line.startswith("warning:")]
    assert len(lines) == 2 and lines[0].startswith("error: the backend at") and (
        "is in use: the episode belongs to another client: it frees it when it ends, or after 60 s without a "
        "request (at most") in lines[0], lines
    assert lines[1].startswith("hint: wait and try again") and not marker.exists()
    # asking changed nothing: the holder's episode is still where it was
    assert holder._state["step"] == 0 and holder.step("move_next")[1].name == "SUCCESS"
    holder.close()


# ------------------------------------------------------------------------------ one line in the solution's terminal
def test_a_solution_refused_by_a_held_episode_prints_one_line(served):
    _, server = served(PASSIVE, "miniroom:1")
    holder = BenchBot(supervisor_address=server.address)
    try:
        for debug, expected in (("0", "one line"), ("1", "traceback")):
            child = _child("from benchbot.api import BenchBot\nBenchBot()\n", server.address, BENCHBOT_DEBUG=debug)
            _, err = child.communicate(timeout=60)
            assert child.returncode == 1
            if expected == "one line":
                assert err.count("\n") == 1 and "Traceback" not in err, err
                assert err.startswith("error: the episode belongs to another client: it frees it when it ends")
                assert "(wait and try again, or give this client a backend of its own" in err
            else:
                assert "Traceback" in err and "EpisodeRefused" in err
    finally:
        holder.close()


def test_a_token_refusal_is_said_at_once_in_one_line(make_service):
    service = make_service(PASSIVE, "miniroom:1")
    server = ServerThread(build_app(service, token="s3cret-token")).start()
    try:
        started = time.monotonic()
        child = _child("from benchbot.api import BenchBot\nBenchBot()\n", server.address)
        _, err = child.communicate(timeout=60)
        took = time.monotonic() - started
        assert child.returncode == 1 and err.count("\n") == 1, err
        assert err.startswith("error: BenchBot backend refused / (401): missing or wrong BenchBot token")
        assert "set BENCHBOT_TOKEN" in err
        assert took < 30, f"said at once, not after start()'s 60 s wait ({took:.1f} s)"
        with pytest.raises(BackendRefused):
            HttpTransport(server.address).ping()
    finally:
        server.stop()


def test_a_body_too_large_is_one_line_with_the_fix(served, monkeypatch):
    monkeypatch.setenv("BENCHBOT_MAX_REQUEST_BYTES", "4096")
    _, server = served(PASSIVE, "miniroom:1")
    child = _child("from benchbot.api import BenchBot\n"
                   "BenchBot().results_functions()['create_object'](label='x' * 10000)\n", server.address)
    _, err = child.communicate(timeout=60)
    assert child.returncode == 1 and err.count("\n") == 1, err
    assert err.startswith("error: BenchBot backend refused /results_functions/create_object (413): request body of")
    assert "BENCHBOT_MAX_REQUEST_BYTES on the backend raises the limit" in err


def test_a_backend_that_is_gone_is_one_line_with_the_fix():
    with socket.socket() as probe:  # a port where nothing listens
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    transport = HttpTransport(f"http://127.0.0.1:{port}/", shared_memory=False)
    with pytest.raises(BackendUnreachable) as caught:
        transport.step(None, {}, None)
    assert isinstance(caught.value, ConnectionError) and "\n" not in str(caught.value)
    assert "ConnectionRefusedError" in str(caught.value) and "is the backend (`benchbot run`) still running?" in \
        str(caught.value)
