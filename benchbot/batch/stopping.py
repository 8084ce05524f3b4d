"""Ctrl-C of a batch, bounded by construction: the command is gone :data:`STOP_BOUND_S` seconds after the first
Ctrl-C (or SIGTERM), whatever its episodes are doing.

At the interrupt (:func:`StopDeadline.arm`, time 0):

1. every solution this process started (:func:`benchbot.solutions.process_group.run_child`, on any thread) has its
   group stopped: SIGTERM, ``BENCHBOT_STOP_GRACE_S`` (5 s), SIGKILL (:func:`~benchbot.solutions.process_group.
   interrupt_children`); worker processes of ``--workers N`` get SIGINT when the terminal did not send it to them
   (a live view reads Ctrl-C as a key), and stop their episodes the same way;
2. the batch's own clean-up runs as before (servers stopped, backends closed); whatever solution group or worker
   process is still there after it is SIGKILLed (:meth:`StopDeadline.finish`) and the command exits 130 with its
   ``--resume`` line;
3. if it has not exited by :data:`STOP_BOUND_S` − :data:`KILL_MARGIN_S`, a deadline thread SIGKILLs every solution
   group still running and every worker process, marks ``progress.json`` interrupted, prints the ``--resume`` line
   (unless printed) and ends the process (``os._exit(130)``): a backend busy compiling kernels or building a
   scene (which no Python exception interrupts, and which interpreter exit would wait for) cannot hold it.

A second Ctrl-C jumps to step 3 at once.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
import threading
import time
from pathlib import Path
from typing import Callable

from benchbot.solutions import process_group

#: Seconds from the first Ctrl-C to the batch command's exit, at most (what the screen promises).
STOP_BOUND_S = 10.0
#: Seconds before the bound at which the deadline kills what is left (SIGKILL and exit take well under this, even
#: with every core busy).
KILL_MARGIN_S = 2.0
#: The exit status of an interrupted command (``ExitCode.INTERRUPTED``).
INTERRUPTED_STATUS = 130


def resume_line(run_dir: Path) -> str:
    """The closing line of an interrupted batch."""
    return f"interrupted; finish the batch with:\n  benchbot batch --resume {run_dir}"  # a line to copy whole


class StopDeadline:
    """The bound on stopping one batch (module docstring). ``say`` prints a line (stderr); ``bound_s`` is
    :data:`STOP_BOUND_S`."""

    def __init__(self, run_dir: Path, say: Callable[[str], None], bound_s: float = STOP_BOUND_S) -> None:
        self.run_dir, self.say, self.bound_s = Path(run_dir), say, bound_s
        self.armed_at: float | None = None
        self.resume_said = self.announced = False
        self.view_open = False  # a full-screen view owns the terminal (the deadline gives it back before exiting)
        self._now = threading.Event()
        self._lock = threading.Lock()
        self._terminal = _terminal_modes()

    def arm(self, *, signal_sent: bool, quiet: bool = False) -> bool:
        """Start stopping (idempotent; True the first time). ``signal_sent``: the terminal or a ``kill`` already
        sent the signal to the worker processes too (otherwise they get SIGINT here). ``quiet``: say nothing yet
        (a live view owns the screen; :meth:`announce` once it is gone)."""
        with self._lock:
            if self.armed_at is not None:
                return False
            self.armed_at = time.monotonic()
        process_group.interrupt_children()
        if not signal_sent:
            for child in multiprocessing.active_children():
                _signal(child.pid, signal.SIGINT)
        threading.Thread(target=self._expire, name="benchbot-stop-deadline", daemon=True).start()
        if not quiet:
            self.announce()
        return True

    def announce(self) -> None:
        """The line saying the batch is stopping (once)."""
        if not self.announced:
            self.announced = True
            self.say(f"stopping the batch (at most {self.bound_s:.0f} s; Ctrl-C again stops it at once) …")

    def left_s(self) -> float:
        """Seconds until the deadline kills what is left (0 when not armed or past)."""
        if self.armed_at is None:
            return 0.0
        return max(0.0, self.armed_at + self.bound_s - KILL_MARGIN_S - time.monotonic())

    def finish(self) -> None:
        """The batch's clean-up is over (or given up on): wait for worker processes until the deadline, then SIGKILL
        every solution group and worker still there. (A KeyboardInterrupt raised into the batch thread can cut a
        group's SIGTERM grace short, before its SIGKILL: the group is still registered, and ends here.)"""
        for child in multiprocessing.active_children():
            child.join(self.left_s())
        kill_everything_left()

    def now(self) -> None:
        """A second Ctrl-C: kill what is left and exit at once."""
        if self.armed_at is None:
            self.arm(signal_sent=True)
        self._now.set()

    def said_resume(self) -> None:
        """The normal path printed the ``--resume`` line (the deadline does not print it again)."""
        self.resume_said = True

    def _expire(self) -> None:
        self._now.wait(max(0.0, self.bound_s - KILL_MARGIN_S))
        kill_everything_left()
        if self.view_open:  # the view never got to close: give the terminal back as it was
            _restore_terminal(self._terminal)
        try:
            from benchbot.batch.progress import mark_interrupted

            mark_interrupted(self.run_dir)
        except Exception:  # a marker only: the manifest and the episodes' records say what ran
            pass
        try:
            if not self.resume_said:
                self.say(resume_line(self.run_dir))
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(INTERRUPTED_STATUS)


def _terminal_modes() -> list | None:
    """The terminal's modes now (standard input's), or None when it is not a terminal."""
    try:
        import termios

        return termios.tcgetattr(0) if os.isatty(0) else None
    except (ImportError, OSError):
        return None


#: Leave the alternate screen, show the cursor, stop mouse reports: what a full-screen view undoes as it closes.
_VIEW_OFF = b"\x1b[?1000l\x1b[?1002l\x1b[?1003l\x1b[?1006l\x1b[?2004l\x1b[?1049l\x1b[?25h"


def _restore_terminal(modes: list | None) -> None:
    try:
        import termios

        for fd in (2, 1):
            if os.isatty(fd):
                os.write(fd, _VIEW_OFF)
                break
        if modes is not None:
            termios.tcsetattr(0, termios.TCSANOW, modes)
    except (ImportError, OSError):
        pass


def kill_everything_left() -> None:
    """SIGKILL every solution group still running and every worker process (and their own groups' leaders)."""
    process_group.kill_live_groups()
    for child in multiprocessing.active_children():
        _signal(child.pid, signal.SIGKILL)


def _signal(pid: int, sig: int) -> None:
    try:
        os.kill(pid, sig)
    except OSError:
        pass


class interrupts_arm:
    """Within it (main thread only), SIGINT and SIGTERM arm ``deadline`` (:meth:`StopDeadline.arm`) before raising
    KeyboardInterrupt, so the bound starts at the key press, not after the clean-up; a second one calls
    :meth:`StopDeadline.now`. The previous handlers are put back on leaving."""

    def __init__(self, deadline: StopDeadline) -> None:
        self.deadline = deadline
        self.previous: dict[int, object] = {}

    def _handler(self, signum: int, frame: object) -> None:
        if not self.deadline.arm(signal_sent=True):
            self.deadline.now()
            return
        raise KeyboardInterrupt

    def __enter__(self) -> "interrupts_arm":
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self.previous[sig] = signal.signal(sig, self._handler)
        return self

    def __exit__(self, *exc: object) -> None:
        if self.deadline.armed_at is not None:
            return  # stopping: a second Ctrl-C during the clean-up and the exit still ends it at once
        for sig, handler in self.previous.items():
            signal.signal(sig, handler)
