"""Starting, finding, asking and stopping the simulator service (docs/service.md).

:func:`start` is what a command calls: it connects to the user's service (:func:`benchbot.service.location.locate`)
when it serves this installation (its key), starts it first when none answers and replaces it when it serves another
key and is idle — under a lock, so that two commands starting at once start one — and says so once (``say``). A
socket file that no service answers on (a service that was killed) is replaced. :func:`wanted` says whether a
command should use the service at all (the setting ``BENCHBOT_SERVICE`` and ``--no-service``).
"""

from __future__ import annotations

import fcntl
import os
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable

from benchbot.core.errors import BackendError, BenchbotError, ExitCode, ResultsError, SpecError, UsageError
from benchbot.service import protocol
from benchbot.service.location import ServiceLocation, private_dir

#: Seconds a command waits for a service it started to answer (it imports BenchBot and builds the registry first).
START_TIMEOUT_S = 120.0
#: Seconds a command waits for a status or stop answer.
ANSWER_TIMEOUT_S = 10.0
#: Default of ``BENCHBOT_SERVICE_IDLE_S``: seconds without an episode after which the service stops by itself.
DEFAULT_IDLE_S = 900
#: Log files larger than this are renamed to ``.log.1`` (the one before is dropped) when a service starts.
LOG_ROTATE_BYTES = 4 << 20
#: The one-line hint of every service error: how to run without it.
IN_PROCESS_HINT = "run the command again (a fresh service starts), or with --no-service (BENCHBOT_SERVICE=off)"

_ERRORS = {int(ExitCode.USAGE): UsageError, int(ExitCode.SPEC): SpecError, int(ExitCode.RESULTS): ResultsError,
           int(ExitCode.BACKEND): BackendError}


#: The values of ``BENCHBOT_SERVICE``.
MODES = ("auto", "off")


def wanted(no_service: bool = False) -> bool:
    """Whether a command uses the service: not with ``--no-service`` (``no_service``) nor ``BENCHBOT_SERVICE=off``;
    only on Linux (Unix sockets with peer credentials).

    Raises:
        UsageError: ``BENCHBOT_SERVICE`` is neither ``auto`` nor ``off``."""
    from benchbot.core import settings

    mode = (settings.get("BENCHBOT_SERVICE") or "auto").lower()
    if mode not in MODES:
        raise UsageError(f"BENCHBOT_SERVICE={mode!r} is not one of {', '.join(MODES)}",
                         "set it to auto (the default) or off (run the simulator in each command's own process)")
    return not no_service and mode != "off" and sys.platform.startswith("linux")


def idle_seconds() -> float:
    """``BENCHBOT_SERVICE_IDLE_S``: seconds without an episode after which the service stops (a whole number ≥ 1).

    Raises:
        UsageError: not a whole number of at least 1."""
    from benchbot.core import settings

    text = settings.get("BENCHBOT_SERVICE_IDLE_S") or str(DEFAULT_IDLE_S)
    try:
        seconds = int(text)
    except ValueError:
        seconds = 0
    if seconds < 1:
        raise UsageError(f"BENCHBOT_SERVICE_IDLE_S={text!r} is not a whole number of at least 1",
                         f"set it to the seconds the simulator service may stay idle (default {DEFAULT_IDLE_S})")
    return float(seconds)


def error_from(message: dict) -> BenchbotError:
    """The :class:`BenchbotError` (subclass by its exit code) of a service's ``error`` message."""
    kind = _ERRORS.get(int(message.get("exit_code", 1)), BenchbotError)
    return kind(str(message.get("message", "the simulator service failed")), str(message.get("hint", "")))


def connect(location: ServiceLocation, timeout_s: float | None = None) -> socket.socket | None:
    """A connection to the service at ``location``, or None when none answers there (no socket file, or a stale
    one). The service's end must be a process of this user (its ``SO_PEERCRED`` uid).

    Raises:
        UsageError: the service folder is not private (:func:`benchbot.service.location.private_dir`)."""
    if not location.socket.exists():
        return None
    private_dir(location.folder)
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.settimeout(timeout_s)
    try:
        sock.connect(str(location.socket))
    except OSError:
        sock.close()
        return None
    _, uid, _ = protocol.peer_credentials(sock)
    if uid != os.geteuid():
        sock.close()
        raise UsageError(f"the socket {location.socket} is served by user id {uid}, not by you",
                         f"remove {location.folder} and run the command again, or use --no-service")
    return sock


def _rotate(log: Path) -> None:
    try:
        if log.stat().st_size > LOG_ROTATE_BYTES:
            os.replace(log, log.with_name(log.name + ".1"))
    except OSError:
        pass


def _spawn(location: ServiceLocation, idle_s: float) -> subprocess.Popen:
    """Start the service process, detached: a session of its own, no terminal, its output appended to its log."""
    location.log.parent.mkdir(parents=True, exist_ok=True)
    _rotate(location.log)
    with open(location.log, "ab") as log:
        return subprocess.Popen(
            [sys.executable, "-m", "benchbot.service.daemon", "--key", location.key, "--idle-s", f"{idle_s:g}"],
            stdin=subprocess.DEVNULL, stdout=log, stderr=log, start_new_session=True, close_fds=True, cwd="/")


def _last_log_line(log: Path) -> str:
    try:
        lines = [line for line in log.read_text(errors="replace").splitlines() if line.strip()]
    except OSError:
        return ""
    return lines[-1].strip() if lines else ""


class ServiceBusy(BackendError):
    """The user's service runs for another installation or other settings (another key) and is serving an episode:
    it cannot be replaced now."""


def _status(sock: socket.socket) -> dict:
    """Ask the service on ``sock`` for its status (the first request of every connection).

    Raises:
        protocol.ConnectionLost: it went away first."""
    protocol.send(sock, {"op": "status"})
    return protocol.receive(sock)


def _answering(location: ServiceLocation) -> tuple[socket.socket | None, dict | None]:
    """``(connection, status)`` of the service answering at ``location``; ``(None, None)`` when none does."""
    sock = connect(location)
    if sock is None:
        return None, None
    try:
        return sock, _status(sock)
    except protocol.ConnectionLost:
        sock.close()
        return None, None


def _replace(location: ServiceLocation, sock: socket.socket, status: dict) -> None:
    """Stop the idle service on ``sock`` that serves another key, and wait until it is gone.

    Raises:
        ServiceBusy: it is serving an episode.
        BackendError: it did not stop within 15 s."""
    if status.get("episodes_running"):
        sock.close()
        raise ServiceBusy(f"the simulator service (pid {status.get('pid')}) runs another installation's code or "
                          "settings and is busy", "this command runs in its own process")
    try:
        protocol.send(sock, {"op": "stop"})
        protocol.receive(sock)
    except protocol.ConnectionLost:
        pass
    finally:
        sock.close()
    if not wait_until_gone(location, int(status.get("pid", 0))):
        raise BackendError(f"the simulator service (pid {status.get('pid')}) of another installation did not stop",
                           f"stop it (benchbot service stop, or kill {status.get('pid')}); {IN_PROCESS_HINT}")


def _spawn_and_wait(location: ServiceLocation, idle_s: float, timeout_s: float) -> tuple[socket.socket, int]:
    """Start the service and wait until it answers; ``(connection, its pid)``.

    Raises:
        BackendError: it exited first or did not answer within ``timeout_s`` (its log's last line says why)."""
    process = _spawn(location, idle_s)
    deadline = time.monotonic() + timeout_s
    while True:
        sock, status = _answering(location)
        if sock is not None and status.get("key") == location.key:
            return sock, process.pid
        if sock is not None:
            sock.close()
        if process.poll() is not None:
            raise BackendError(f"the simulator service exited as it started (status {process.returncode}): "
                               f"{_last_log_line(location.log)}", f"its log: {location.log}; {IN_PROCESS_HINT}")
        if time.monotonic() > deadline:
            raise BackendError(f"the simulator service did not answer within {timeout_s:g} s of starting",
                               f"its log: {location.log}; {IN_PROCESS_HINT}")
        time.sleep(0.05)


def start(location: ServiceLocation, *, say: Callable[[str], None] | None = None,
          starting: Callable[[], None] | None = None, timeout_s: float = START_TIMEOUT_S) -> socket.socket:
    """A connection to the user's service serving ``location.key`` (its status already asked), starting it when none
    answers and replacing an idle one that serves another key, under the lock file (commands starting together
    start one). ``starting()`` is called before a service is started (a stage for a progress line); ``say(line)``
    once after this call started one.

    Raises:
        UsageError: the service folder is not private, or ``BENCHBOT_SERVICE_IDLE_S`` is invalid.
        ServiceBusy: the service serves another key and is busy (run in-process instead).
        BackendError: the service did not answer within ``timeout_s`` seconds or exited first (its log's last line
            says why), or another key's service did not stop."""
    sock, status = _answering(location)
    if sock is not None and status.get("key") == location.key:
        return sock
    if sock is not None:
        sock.close()
    idle_s = idle_seconds()
    location.folder.mkdir(mode=0o700, parents=True, exist_ok=True)
    private_dir(location.folder)
    with open(location.lock, "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        sock, status = _answering(location)
        if sock is not None and status.get("key") == location.key:
            return sock
        replaced = sock is not None
        if replaced:
            _replace(location, sock, status)
        if starting is not None:
            starting()
        sock, pid = _spawn_and_wait(location, idle_s, timeout_s)
    if say is not None:
        what = "replaced the simulator service (other code or settings)" if replaced else \
            "started the simulator service"
        say(f"{what}, pid {pid}: it keeps the simulator loaded between commands and stops after {idle_s:g} s idle; "
            "`benchbot service stop` stops it, --no-service or BENCHBOT_SERVICE=off runs in-process "
            "(docs/service.md)")
    return sock


def ask(location: ServiceLocation, op: str, timeout_s: float = ANSWER_TIMEOUT_S) -> dict | None:
    """Send ``{op}`` (``status`` or ``stop``) to the user's service (whatever its key); its answer, or None when none
    answers.

    Raises:
        UsageError: the service folder is not private.
        BackendError: it answered with an error, or not within ``timeout_s``."""
    sock = connect(location, timeout_s)
    if sock is None:
        return None
    try:
        protocol.send(sock, {"op": op})
        answer = protocol.receive(sock)
    except (protocol.ConnectionLost, socket.timeout) as exc:
        raise BackendError(f"the simulator service at {location.socket} did not answer: {exc}",
                           f"its log: {location.log}") from None
    finally:
        sock.close()
    if answer.get("event") == "error":
        raise error_from(answer)
    return answer


def _alive(pid: int) -> bool:
    """Whether process ``pid`` runs (a zombie, exited but not yet reaped by its parent, does not)."""
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        return False


def wait_until_gone(location: ServiceLocation, pid: int, timeout_s: float = 15.0) -> bool:
    """Wait until the service process ``pid`` (told to stop) has exited and no service answers at ``location``;
    whether that happened within ``timeout_s`` seconds."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if not _alive(pid):
            sock = connect(location, 1.0)
            if sock is None:
                return True
            sock.close()
        time.sleep(0.05)
    return False
