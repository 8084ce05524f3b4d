"""Child processes that end with their episode: their own process group, stopped whole, watched, with a capped log.

:func:`run_child` starts a command in a new session (so it leads a new process group that its forked children
join), and, whatever way the run ends — the command exits, the timeout passes, the caller is interrupted — stops
every process still in that group: SIGTERM, up to :data:`~benchbot.core.limits.STOP_GRACE_S` seconds, then
SIGKILL. A watchdog process (:mod:`benchbot.core.group_watchdog`) does the same if the calling process dies without
doing it (``kill -9``). A process that leaves the group on purpose (``setsid``) escapes both.

With a ``log``, the command's stdout and stderr go through a pipe that is always drained (the command never blocks
on a full pipe); the first :data:`~benchbot.core.limits.MAX_LOG_BYTES` bytes are kept and the rest counted and
dropped, with a last line saying so.
"""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from benchbot.core import group_watchdog
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
    """

    returncode: int
    timed_out: bool = False
    output_bytes: int = 0
    log_truncated: bool = False


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


def run_child(
    argv: list[str], *, cwd: Path, env: dict[str, str], log: IO | None = None, timeout_s: float | None = None,
) -> ChildOutcome:
    """Run ``argv`` to completion in its own process group, then stop whatever is left of the group.

    Args:
        argv, cwd, env: the command, its folder and its whole environment.
        log: a file (opened for writing; its descriptor is used) for stdout and stderr, capped at
            :data:`~benchbot.core.limits.MAX_LOG_BYTES`; None: they are inherited.
        timeout_s: stop the group after this many seconds (``timed_out`` is then set).

    Raises:
        OSError: the command cannot be started. UsageError: a bad ``BENCHBOT_MAX_LOG_BYTES`` or
            ``BENCHBOT_STOP_GRACE_S``. Whatever interrupts the wait (KeyboardInterrupt) is re-raised after the group
            has been stopped.
    """
    grace, cap = STOP_GRACE_S.value(), MAX_LOG_BYTES.value()
    output = {"stdout": subprocess.PIPE, "stderr": subprocess.STDOUT} if log is not None else {}
    child = subprocess.Popen(argv, cwd=cwd, env=env, stdin=subprocess.DEVNULL, start_new_session=True, **output)
    pump = None
    try:
        watchdog = _Watchdog(child.pid, grace)
    except BaseException:
        _stop(child, 0.0, None)
        raise
    timed_out = False
    try:
        pump = _LogPump(child.stdout, log, cap) if log is not None else None
        deadline = None if timeout_s is None else time.monotonic() + timeout_s
        while child.poll() is None:
            remaining = None if deadline is None else deadline - time.monotonic()
            if remaining is not None and remaining <= 0:
                timed_out = True
                break
            step = 0.1 if remaining is None else min(0.1, remaining)
            if pump is not None:
                pump.pump(step)
            else:
                try:
                    child.wait(timeout=step if remaining is not None else None)
                except subprocess.TimeoutExpired:
                    pass
    finally:
        _stop(child, grace, pump)
        watchdog.release()
        if pump is not None:
            pump.finish(FINAL_DRAIN_S)
        elif child.stdout is not None:
            child.stdout.close()
    return ChildOutcome(child.returncode, timed_out, pump.total if pump else 0, bool(pump and pump.truncated))


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
            pump.pump(0.05)
        else:
            time.sleep(0.05)
    try:
        os.killpg(pgid, signal.SIGKILL)
    except OSError:
        pass
    child.wait()
