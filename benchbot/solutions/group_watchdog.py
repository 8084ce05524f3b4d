"""A solution's watchdog: stops the solution's whole process group when the process that started it dies.

Run as a script (``python -I -S group_watchdog.py PGID GRACE_S``, standard library only, so it starts in
milliseconds) with the read end of a pipe as its stdin; the starting process keeps the write end. Two outcomes:

* the starter writes one byte: the episode ended and the starter stopped the group itself; the watchdog exits;
* the pipe reaches end-of-file without a byte: the starter died (``kill -9``, a crash, its worker lost): the
  watchdog sends SIGTERM to the group, waits up to ``GRACE_S`` seconds for it to end, then sends SIGKILL.

The watchdog runs in its own session, so neither Ctrl-C in the terminal nor a signal to the starter's process group
reaches it. :func:`group_running`, :func:`group_members` and :func:`process_groups` are also used by
:mod:`benchbot.solutions.process_group`.
"""

from __future__ import annotations

import os
import signal
import sys
import time
from collections.abc import Iterator


def _live_processes() -> Iterator[tuple[int, int]]:
    """``(pid, pgid)`` of every process that is not a zombie, as ``/proc/*/stat`` gives them (Linux; the caller
    checks that ``/proc`` exists). A process that ends while it is read is left out."""
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat", "rb") as f:
                stat = f.read()
        except OSError:  # it ended meanwhile
            continue
        fields = stat[stat.rfind(b")") + 2:].split()  # after "pid (comm) ": state ppid pgrp ...
        if len(fields) >= 3 and fields[0] not in (b"Z", b"X"):
            yield int(name), int(fields[2])


def group_members(pgid: int) -> Iterator[int]:
    """The process ids of group ``pgid``'s members that are not zombies, as ``/proc/*/stat`` gives them (Linux; the
    caller checks that ``/proc`` exists). A process that ends while it is read is left out."""
    return (pid for pid, group in _live_processes() if group == pgid)


def process_groups() -> dict[int, list[int]]:
    """``{pgid: [pid, ...]}`` of every process that is not a zombie, from one reading of ``/proc`` (Linux; the caller
    checks that ``/proc`` exists)."""
    groups: dict[int, list[int]] = {}
    for pid, group in _live_processes():
        groups.setdefault(group, []).append(pid)
    return groups


def group_running(pgid: int) -> bool:
    """Whether process group ``pgid`` has a member that is not a zombie.

    ``killpg(pgid, 0)`` alone also counts zombies, and orphaned zombies stay until the system's init reaps them
    (some container inits never do); on Linux the members' states are read from ``/proc`` (:func:`group_members`).
    """
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # a member we may not signal (it changed its user): still running
        return True
    if not os.path.isdir("/proc/self"):
        return True
    return next(group_members(pgid), None) is not None


def stop_group(pgid: int, grace_s: float) -> None:
    """SIGTERM to group ``pgid``, up to ``grace_s`` seconds for it to end, then SIGKILL (no error if it is gone)."""
    try:
        os.killpg(pgid, signal.SIGTERM)
    except OSError:
        return
    deadline = time.monotonic() + grace_s
    while time.monotonic() < deadline and group_running(pgid):
        time.sleep(0.05)
    try:
        os.killpg(pgid, signal.SIGKILL)
    except OSError:
        pass


def main(argv: list[str]) -> int:
    """The script's entry point; waits on stdin as described in the module docstring.

    Args:
        argv: ``[PGID, GRACE_S]``: the process group to stop (an integer) and its grace in seconds (a float).

    Returns:
        The exit status: always 0.

    Raises:
        ValueError, IndexError: ``argv`` is not two numbers (the starter always passes them).
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    pgid, grace_s = int(argv[0]), float(argv[1])
    try:
        told = os.read(0, 1)
    except OSError:
        told = b""
    if not told:  # the starter is gone without saying the episode ended
        stop_group(pgid, grace_s)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
