"""A solution's standard input: ``benchbot submit`` passes the terminal through (sandboxed or not), and the
sandbox's session of its own keeps the solution from typing into your shell (TIOCSTI); batches give none and say
so once when a solution reads it (docs/security.md, "Processes"; benchbot/solutions/process_group.py)."""

from __future__ import annotations

import http.server
import json
import os
import subprocess
import sys
import termios
import textwrap
import threading
from pathlib import Path

import pytest

from benchbot.batch.episode_runner import READ_STDIN_ERROR
from benchbot.solutions.process_group import STDIN_NOTICE, run_child
from benchbot.server import SUPERVISOR_GREETING

sys.path.insert(0, str(Path(__file__).parent))
from terminal import Terminal  # noqa: E402

BENCHBOT = [sys.executable, "-m", "benchbot.cli"]

#: An interactive solution: asks, reads a line, tries to type into the terminal (TIOCSTI) and to make it its
#: controlling terminal (TIOCSCTTY), turns echo off and leaves it off, and writes what happened as its results.
INTERACTIVE = textwrap.dedent('''
    import errno, fcntl, json, os, sys, termios

    def attempt(request, arg):
        try:
            fcntl.ioctl(0, request, arg)
            return "allowed"
        except OSError as exc:
            return errno.errorcode[exc.errno]

    print("Press ENTER to continue, or type a word:", flush=True)
    line = sys.stdin.readline()
    out = {"line": line, "isatty": os.isatty(0), "tiocsti": attempt(termios.TIOCSTI, b"X"),
           "tiocsctty": attempt(termios.TIOCSCTTY, 0)}
    modes = termios.tcgetattr(0)
    modes[3] &= ~termios.ECHO
    termios.tcsetattr(0, termios.TCSANOW, modes)
    json.dump(out, open(os.environ["BENCHBOT_RESULT_LOCATION"], "w"))
    print("solution done", flush=True)
''')


@pytest.fixture
def greeter():
    """The address of a real HTTP server on 127.0.0.1 answering every request as a backend greets (enough for a
    submission that never uses the backend); stopped after."""

    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self):
            body = json.dumps(SUPERVISOR_GREETING).encode()
            self.send_response(200)
            self.send_header("Content-Type", "application/json")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)

        do_POST = do_GET

        def log_message(self, *args):
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    yield f"http://127.0.0.1:{server.server_address[1]}/"
    server.shutdown()
    server.server_close()


def _echo_on(terminal: Terminal) -> bool:
    return bool(termios.tcgetattr(terminal.master)[3] & termios.ECHO)


@pytest.mark.slow
@pytest.mark.parametrize("sandbox", [True, False], ids=["sandboxed", "no-sandbox"])
def test_submit_passes_the_terminal_to_the_solution(greeter, tmp_path, sandbox):
    """In a real pseudo-terminal the solution reads the line typed; sandboxed, TIOCSTI and TIOCSCTTY on it are
    refused (EPERM: the terminal is not its controlling terminal and it has no CAP_SYS_ADMIN); the echo it turned
    off is back on once submit ends."""
    folder = tmp_path / "solution"
    folder.mkdir()
    (folder / "solution.py").write_text(INTERACTIVE)
    results = tmp_path / "results.json"
    argv = [*BENCHBOT, "submit", "--native", "python", "solution.py", "--address", greeter]
    argv += [] if sandbox else ["--no-sandbox"]
    env = dict(os.environ, BENCHBOT_RESULT_LOCATION=str(results))
    with Terminal(argv, env=env, cwd=str(folder)) as terminal:
        assert terminal.wait_for("Press ENTER", 60), terminal.text
        terminal.press(b"hello\r")
        assert terminal.wait(60) == 0, terminal.text
        assert "solution done" in terminal.text
        assert _echo_on(terminal), "the terminal's echo stayed off after the solution ended"
    out = json.loads(results.read_text())
    assert out["line"] == "hello\n" and out["isatty"] is True
    if sandbox:
        assert out["tiocsti"] == "EPERM" and out["tiocsctty"] == "EPERM", out
    else:
        assert out["tiocsctty"] == "EPERM", out  # TIOCSTI: allowed to root (CAP_SYS_ADMIN), refused to others


def test_a_child_given_no_input_is_told_once_and_gets_end_of_file(tmp_path):
    """``stdin="none"`` (batches): a read blocks only until it is seen, then gets end-of-file, and so do later
    reads; the log says so once; a child that never reads gets no line."""
    reader = "import sys; print(repr(sys.stdin.read())); print(repr(sys.stdin.readline())); print('end')"
    with open(tmp_path / "reader.log", "w") as log:
        outcome = run_child([sys.executable, "-c", reader], cwd=tmp_path, env={}, log=log, timeout_s=30)
    text = (tmp_path / "reader.log").read_text()
    assert outcome.returncode == 0 and outcome.read_stdin and not outcome.timed_out
    assert text.count(STDIN_NOTICE) == 1 and text.endswith("''\n''\nend\n"), text
    with open(tmp_path / "quiet.log", "w") as log:
        outcome = run_child([sys.executable, "-c", "print('no input needed')"], cwd=tmp_path, env={}, log=log,
                            timeout_s=30)
    assert not outcome.read_stdin and STDIN_NOTICE not in (tmp_path / "quiet.log").read_text()


def test_a_child_that_forks_a_reader_is_seen_too(tmp_path):
    """The reader may be any process of the group, reading a copy of the descriptor (here: a forked child reading
    a dup of fd 0 as fd 5)."""
    code = ("import os, sys\nfd = os.dup2(0, 5)\npid = os.fork()\n"
            "if pid == 0:\n    os.read(5, 10); os._exit(0)\nos.waitpid(pid, 0)\nprint('parent end')")
    with open(tmp_path / "fork.log", "w") as log:
        outcome = run_child([sys.executable, "-c", code], cwd=tmp_path, env={}, log=log, timeout_s=30)
    assert outcome.read_stdin and outcome.returncode == 0, (tmp_path / "fork.log").read_text()


@pytest.mark.slow
def test_a_batch_says_when_its_solution_reads_input(tmp_path):
    """A sandboxed batch episode whose solution waits for a line: it gets end-of-file (its status is ``failed``,
    not ``timeout``), its log has the line, and its failed record says why."""
    folder = tmp_path / "solution"
    folder.mkdir()
    (folder / "ask.py").write_text("import sys\nanswer = sys.stdin.readline()\n"
                                   "sys.exit(0 if answer else 'no answer')\n")
    runs = tmp_path / "runs"
    proc = subprocess.run([*BENCHBOT, "batch", "--native", "python ask.py", "--envs", "miniroom:1", "--camera-size",
                           "64x48", "--json", "--no-tui", "--output-dir", str(runs), "--episode-timeout", "120"],
                          cwd=folder, capture_output=True, text=True, timeout=600,
                          env=dict(os.environ, BENCHBOT_SIM_STYLE="primitives"))
    result = json.loads(proc.stdout)
    episode = result["episodes"][0]
    assert episode["status"] == "failed" and episode["error"] == READ_STDIN_ERROR, episode
    log = (Path(result["run_dir"]) / episode["log"]).read_text()
    assert log.count(STDIN_NOTICE) == 1 and "no answer" in log, log
