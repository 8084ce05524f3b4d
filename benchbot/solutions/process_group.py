"""Child processes that end with their episode: their own process group, stopped whole, watched, with a capped log.

:func:`run_child` starts a command in a new session (so it leads a new process group that its forked children
join), and, whatever way the run ends — the command exits, the timeout passes, the caller is interrupted — stops
every process still in that group: SIGTERM, up to :data:`~benchbot.core.limits.STOP_GRACE_S` seconds, then
SIGKILL. A watchdog process (:mod:`benchbot.solutions.group_watchdog`) does the same if the calling process dies without
doing it (``kill -9``). A process that leaves the group on purpose (``setsid``) escapes both.

With a ``log``, the command's stdout and stderr go through a pipe that is always drained (the command never blocks
on a full pipe); the first :data:`~benchbot.core.limits.MAX_LOG_BYTES` bytes are kept and the rest counted and
dropped, with a last line saying so.

Standard input: ``stdin="inherit"`` passes the caller's through (``benchbot submit``: the terminal, so an interactive
solution can be typed to; the terminal's modes are put back and its unread input dropped when the child ends, see
:func:`_terminal_guard`); the child still runs in a session of its own, so the terminal is not its controlling
terminal and the kernel refuses it ``TIOCSTI`` (typing into your shell) and ``TIOCSCTTY`` unless it holds
``CAP_SYS_ADMIN`` (a sandboxed child never does; docs/security.md). ``stdin="none"`` (batches) gives it an empty
pipe and watches it (:class:`_StdinWatch`): the first time a process of the group blocks reading it, one line says so
(in the log, else on stderr), :attr:`ChildOutcome.read_stdin` is set and the pipe is closed, so that read and every
later one get end-of-file.
"""

from __future__ import annotations

import os
import platform
import select
import signal
import subprocess
import sys
import termios
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Callable

from benchbot.solutions import group_watchdog
from benchbot.core.limits import MAX_LOG_BYTES, STOP_GRACE_S

FINAL_DRAIN_S = 2.0
"""Seconds spent reading output still buffered in the pipe after the group has been stopped (bounded, in case a
process that left the group keeps the pipe open)."""

_CHUNK = 1 << 20


@dataclass
class ChildOutcome:
    """How a child ended.

    Attributes:
        returncode: its exit status (negative: the signal that ended it).
        timed_out: it was stopped because the timeout passed.
        output_bytes: bytes it wrote to the log pipe (0 without a log).
        log_truncated: the log kept only the first ``MAX_LOG_BYTES`` of them.
        read_stdin: with ``stdin="none"``, a process of its group read its standard input (and got end-of-file).
        stopped: why ``stop_when`` stopped it (its one-line reason), ``""`` when it did not.
    """

    returncode: int
    timed_out: bool = False
    output_bytes: int = 0
    log_truncated: bool = False
    read_stdin: bool = False
    stopped: str = ""


#: Seconds between two calls of :func:`run_child`'s ``stop_when``.
STOP_WHEN_PERIOD_S = 0.25

#: Seconds between two looks at whether a group being stopped has ended (:func:`_stop`). A sandboxed solution's group
#: is still ending (its relay, bubblewrap) when its leader has exited; looking every 0.05 s left README command 1
#: waiting 0.05-0.1 s for it on the 2-core CPU, where the group had ended within a few milliseconds.
STOP_POLL_S = 0.005


class _Watchdog:
    """The watchdog process of one child's group; :meth:`release` tells it the group was stopped here."""

    def __init__(self, pgid: int, grace_s: float) -> None:
        read_end, self.write_end = os.pipe()  # both close-on-exec: no other child inherits the write end
        try:
            self.process = subprocess.Popen(
                [sys.executable, "-I", "-S", str(Path(group_watchdog.__file__)), str(pgid), str(grace_s)],
                stdin=read_end, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True,
            )
        except BaseException:
            os.close(self.write_end)
            raise
        finally:
            os.close(read_end)

    def release(self) -> None:
        try:
            os.write(self.write_end, b"x")
        except OSError:  # it is gone already
            pass
        os.close(self.write_end)
        try:
            self.process.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()


class _LogPump:
    """Copies a pipe to a log file, keeping the first ``cap`` bytes (0: all) and counting the rest."""

    def __init__(self, pipe: IO[bytes], log: IO, cap: int) -> None:
        self.pipe, self.cap = pipe, cap
        self.fd = pipe.fileno()
        os.set_blocking(self.fd, False)
        log.flush()
        self.out = log.fileno()
        self.kept = self.total = 0
        self.eof = False
        self.poller = select.poll()
        self.poller.register(self.fd, select.POLLIN | select.POLLHUP)

    def pump(self, wait_s: float) -> None:
        """Copy what the pipe holds, waiting up to ``wait_s`` seconds for something to arrive."""
        if self.eof:
            time.sleep(wait_s)
            return
        if not self.poller.poll(max(0, int(wait_s * 1000))):
            return
        for _ in range(64):  # bounded, so that the caller's timeout is checked even under a flood of output
            try:
                chunk = os.read(self.fd, _CHUNK)
            except BlockingIOError:
                return
            if not chunk:
                self.eof = True
                return
            self.total += len(chunk)
            room = len(chunk) if not self.cap else max(0, self.cap - self.kept)
            if room:
                self._write(chunk[:room])
                self.kept += min(room, len(chunk))

    def finish(self, within_s: float) -> None:
        """Read until end-of-file (at most ``within_s`` seconds), add the truncation note, close the pipe."""
        deadline = time.monotonic() + within_s
        while not self.eof and time.monotonic() < deadline:
            self.pump(min(0.05, max(0.0, deadline - time.monotonic())))
        if self.truncated:
            self._write(f"\n[log truncated at {self.cap} bytes ({self.total} written): raise with "
                        f"{MAX_LOG_BYTES.env}]\n".encode())
        self.pipe.close()

    @property
    def truncated(self) -> bool:
        return self.total > self.kept

    def _write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            view = view[os.write(self.out, view):]


#: The line a child that reads standard input it was not given gets in its log (``stdin="none"``: batches).
STDIN_NOTICE = ("[benchbot] the solution read its standard input: a batch gives it none, so it got end-of-file "
                "(run an interactive solution with `benchbot submit`, which passes your terminal through)")
#: Seconds between two looks for a process of the group blocked reading the empty stdin pipe.
STDIN_WATCH_PERIOD_S = 0.25
#: ``read``-family system call numbers (``read``, ``pread64``, ``readv``, ``preadv``, ``preadv2``) by machine, as
#: ``/proc/PID/task/TID/syscall`` reports them.
_READ_SYSCALLS = {"x86_64": {0, 17, 19, 295, 327}, "aarch64": {63, 65, 67, 69, 286}}


_groups_lock = threading.Lock()
_groups_read: list = [float("-inf"), {}]  # [when /proc was last read (monotonic s), its {pgid: [pid, ...]}]


def _recent_group_members(pgid: int, max_age_s: float) -> list[int]:
    """The members of group ``pgid`` as ``/proc`` gave them at most ``max_age_s`` seconds ago: one reading serves
    every watcher of this process (the ``batched`` executor of a batch watches many solutions at once, and reading
    every process's ``/proc`` entry once per watcher and look held the interpreter for most of a step)."""
    with _groups_lock:
        now = time.monotonic()
        if now - _groups_read[0] > max_age_s:
            _groups_read[:] = [now, group_watchdog.process_groups()]
        return list(_groups_read[1].get(pgid, ()))


class _StdinWatch:
    """A child's standard input when it is given none: the read end of a pipe that nothing is written to, and a
    way to see a process of the child's group blocked reading it (Linux: ``/proc/PID/task/TID/syscall`` names the
    system call and its first argument, the file descriptor; ``/proc/PID/fd/N`` names the pipe). Once one is seen,
    or where this cannot be watched (another system, a process whose ``/proc`` files cannot be read), the write end
    is closed: reads get end-of-file, as from ``/dev/null``."""

    def __init__(self) -> None:
        self.read_end, self.write_end = os.pipe()
        self.link = f"pipe:[{os.fstat(self.read_end).st_ino}]"
        self.seen = False
        self.next_look = 0.0
        self.calls = _READ_SYSCALLS.get(platform.machine())
        if self.calls is None or not os.path.exists(f"/proc/self/task/{os.getpid()}/syscall"):
            self.close()

    def close(self) -> None:
        if self.write_end is not None:
            os.close(self.write_end)
            self.write_end = None

    def look(self, pgid: int) -> bool:
        """True the first time a process of group ``pgid`` is seen blocked reading the pipe (then closed)."""
        if self.write_end is None or time.monotonic() < self.next_look:
            return False
        self.next_look = time.monotonic() + STDIN_WATCH_PERIOD_S
        for pid in _recent_group_members(pgid, STDIN_WATCH_PERIOD_S):
            try:
                tasks = os.listdir(f"/proc/{pid}/task")
            except OSError:  # it ended meanwhile
                continue
            for tid in tasks:
                try:
                    with open(f"/proc/{pid}/task/{tid}/syscall") as f:
                        fields = f.read().split()
                except FileNotFoundError:
                    continue
                except OSError:  # not ours to read: it cannot be watched, so it must not wait for us
                    self.close()
                    return False
                if len(fields) < 2 or not fields[0].isdigit() or int(fields[0]) not in self.calls:
                    continue
                try:
                    if os.readlink(f"/proc/{pid}/fd/{int(fields[1], 16)}") == self.link:
                        self.seen = True
                        self.close()
                        return True
                except (OSError, ValueError):
                    continue
        return False


class _terminal_guard:
    """Around a child given this process's terminal (``stdin="inherit"``): the terminal's modes as they were before
    are put back afterwards and input it left unread is dropped (``tcsetattr(TCSAFLUSH)``), so that a solution that
    turned echo off, left the terminal raw or made the terminal answer a query leaves nothing for your shell to read.
    Nothing is done when standard input is not a terminal or this process is not in its foreground."""

    def __enter__(self) -> "_terminal_guard":
        self.modes = None
        try:
            if os.isatty(0) and os.tcgetpgrp(0) == os.getpgrp():
                self.modes = termios.tcgetattr(0)
        except OSError:
            pass
        return self

    def __exit__(self, *exc: object) -> None:
        if self.modes is None:
            return
        try:
            if os.tcgetpgrp(0) == os.getpgrp():
                termios.tcsetattr(0, termios.TCSAFLUSH, self.modes)
        except (OSError, termios.error):
            pass


#: Set while this process is being interrupted: every :func:`run_child` waiting in it, on any thread, stops its
#: group and raises KeyboardInterrupt (Ctrl-C reaches only the main thread; the ``batched`` executor of a batch
#: waits for its episodes' solutions on threads of their own).
_interrupted = threading.Event()
#: The process groups of this process's :func:`run_child` calls not yet stopped (their leaders' pids).
_live_groups: set[int] = set()
_live_lock = threading.Lock()


def kill_live_groups() -> list[int]:
    """SIGKILL every process group a :func:`run_child` of this process started and has not stopped yet (the last
    resort of a bounded Ctrl-C, :mod:`benchbot.batch.stopping`); returns their ids. Never raises."""
    with _live_lock:
        groups = sorted(_live_groups)
    for pgid in groups:
        try:
            os.killpg(pgid, signal.SIGKILL)
        except OSError:
            pass
    return groups


def interrupt_children(on: bool = True) -> None:
    """Make every :func:`run_child` of this process, waiting or about to start, stop its child's group and raise
    KeyboardInterrupt (``on``); ``on=False`` lets them run again. Never raises."""
    if on:
        _interrupted.set()
    else:
        _interrupted.clear()


def run_child(
    argv: list[str], *, cwd: Path, env: dict[str, str], log: IO | None = None, timeout_s: float | None = None,
    stdin: str = "none", stop_when: Callable[[], str] | None = None,
) -> ChildOutcome:
    """Run ``argv`` to completion in its own process group, then stop whatever is left of the group.

    Args:
        argv, cwd, env: the command, its folder and its whole environment.
        log: a file (opened for writing; its descriptor is used) for stdout and stderr, capped at
            :data:`~benchbot.core.limits.MAX_LOG_BYTES`; None: they are inherited.
        timeout_s: stop the group after this many seconds (``timed_out`` is then set).
        stdin: ``"none"``: an empty pipe, watched (a read of it is said once, in ``log`` or on stderr, and gets
            end-of-file); ``"inherit"``: this process's standard input (the terminal of ``benchbot submit``),
            restored afterwards (module docstring).
        stop_when: called every :data:`STOP_WHEN_PERIOD_S` while the child runs: a non-empty string (a one-line
            reason) stops the group, as a timeout does (``stopped`` is then that reason).

    Raises:
        OSError: the command cannot be started. UsageError: a bad ``BENCHBOT_MAX_LOG_BYTES`` or
            ``BENCHBOT_STOP_GRACE_S``. Whatever interrupts the wait (KeyboardInterrupt, also from
            :func:`interrupt_children`) is re-raised after the group has been stopped.
    """
    if stdin not in ("none", "inherit"):
        raise ValueError(f"stdin must be 'none' or 'inherit', not {stdin!r}")
    if _interrupted.is_set():
        raise KeyboardInterrupt
    grace, cap = STOP_GRACE_S.value(), MAX_LOG_BYTES.value()
    output = {"stdout": subprocess.PIPE, "stderr": subprocess.STDOUT} if log is not None else {}
    watch = _StdinWatch() if stdin == "none" else None
    terminal = _terminal_guard().__enter__() if stdin == "inherit" else None
    try:
        child = subprocess.Popen(argv, cwd=cwd, env=env, stdin=watch.read_end if watch else None,
                                 start_new_session=True, **output)
    except BaseException:
        _release(watch, terminal)
        raise
    finally:
        if watch is not None:
            os.close(watch.read_end)  # the child has its own copy
    pump = None
    with _live_lock:
        _live_groups.add(child.pid)
    try:
        watchdog = _Watchdog(child.pid, grace)
    except BaseException:
        _stop(child, 0.0, None)
        _forget(child.pid)
        _release(watch, terminal)
        raise
    timed_out, stopped, next_check = False, "", time.monotonic()
    try:
        pump = _LogPump(child.stdout, log, cap) if log is not None else None
        deadline = None if timeout_s is None else time.monotonic() + timeout_s
        while child.poll() is None:
            if _interrupted.is_set():
                raise KeyboardInterrupt
            remaining = None if deadline is None else deadline - time.monotonic()
            if remaining is not None and remaining <= 0:
                timed_out = True
                break
            if stop_when is not None and time.monotonic() >= next_check:
                next_check = time.monotonic() + STOP_WHEN_PERIOD_S
                stopped = stop_when()
                if stopped:
                    break
            step = 0.1 if remaining is None else min(0.1, remaining)
            if watch is not None and watch.look(child.pid):
                if pump is not None:
                    pump._write(f"\n{STDIN_NOTICE}\n".encode())
                else:
                    print(STDIN_NOTICE, file=sys.stderr, flush=True)
            if pump is not None:
                pump.pump(step)
            else:
                try:
                    watched = (watch is not None and watch.write_end is not None) or stop_when is not None
                    child.wait(timeout=step if remaining is not None or watched else None)
                except subprocess.TimeoutExpired:
                    pass
    finally:
        _stop(child, grace, pump)
        _forget(child.pid)
        watchdog.release()
        _release(watch, terminal)
        if pump is not None:
            pump.finish(FINAL_DRAIN_S)
        elif child.stdout is not None:
            child.stdout.close()
    return ChildOutcome(child.returncode, timed_out, pump.total if pump else 0, bool(pump and pump.truncated),
                        bool(watch and watch.seen), stopped)


def _forget(pgid: int) -> None:
    with _live_lock:
        _live_groups.discard(pgid)


def _release(watch: _StdinWatch | None, terminal: _terminal_guard | None) -> None:
    """Close the stdin pipe's write end and put the terminal back (whichever the child had)."""
    if watch is not None:
        watch.close()
    if terminal is not None:
        terminal.__exit__()


def _stop(child: subprocess.Popen, grace_s: float, pump: _LogPump | None) -> None:
    """End every process of ``child``'s group (SIGTERM, ``grace_s``, SIGKILL) and reap ``child``; output keeps
    being drained meanwhile."""
    pgid = child.pid
    if child.poll() is not None and not group_watchdog.group_running(pgid):
        return
    try:
        os.killpg(pgid, signal.SIGTERM)
    except OSError:
        pass
    deadline = time.monotonic() + grace_s
    while time.monotonic() < deadline:
        child.poll()  # reap the leader: a zombie leader would count as running
        if child.returncode is not None and not group_watchdog.group_running(pgid):
            return
        if pump is not None:
            pump.pump(STOP_POLL_S)
        else:
            time.sleep(STOP_POLL_S)
    try:
        os.killpg(pgid, signal.SIGKILL)
    except OSError:
        pass
    child.wait()
