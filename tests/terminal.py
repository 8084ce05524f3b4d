"""A real pseudo-terminal for tests: run a command as a person would in a terminal, read its screen output, press
keys (Ctrl-C is the byte 0x03, sent through the terminal's line discipline as a key press is)."""

from __future__ import annotations

import fcntl
import os
import re
import signal
import struct
import subprocess
import termios
import threading
import time

ANSI = re.compile(rb"\x1b\[[0-9;?<>=]*[ -/]*[@-~]|\x1b\][^\x07\x1b]*(\x07|\x1b\\)|\x1b[()][0-9A-Za-z]|\x1b[=>78]")


class Terminal:
    """``argv`` running on a new pseudo-terminal of ``columns`` × ``rows`` (its stdin, stdout and stderr, and its
    controlling terminal, in a session of its own).

    Args:
        argv: the command. env: its environment (default: this process's). columns, rows: the terminal's size.
    """

    def __init__(self, argv: list[str], *, env: dict | None = None, cwd: str | None = None, columns: int = 160,
                 rows: int = 48) -> None:
        master, slave = os.openpty()
        fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", rows, columns, 0, 0))
        env = dict(os.environ if env is None else env, TERM="xterm-256color", COLUMNS=str(columns), LINES=str(rows))
        self.proc = subprocess.Popen(argv, stdin=slave, stdout=slave, stderr=slave, env=env, cwd=cwd,
                                     start_new_session=True, preexec_fn=_take_terminal, close_fds=True)
        os.close(slave)
        self.master, self._raw, self._lock = master, bytearray(), threading.Lock()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        while True:
            try:
                chunk = os.read(self.master, 65536)
            except OSError:  # EIO: every process holding the terminal has closed it
                return
            if not chunk:
                return
            with self._lock:
                self._raw.extend(chunk)

    @property
    def text(self) -> str:
        """Everything written to the terminal so far, escape sequences removed."""
        with self._lock:
            raw = bytes(self._raw)
        return ANSI.sub(b"", raw).decode("utf-8", errors="replace")

    def wait_for(self, pattern: str, timeout: float) -> bool:
        """True once ``pattern`` (a regular expression) appears in :attr:`text` within ``timeout`` seconds."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if re.search(pattern, self.text):
                return True
            if self.proc.poll() is not None:
                time.sleep(0.2)  # let the reader catch up with the last output
                return bool(re.search(pattern, self.text))
            time.sleep(0.1)
        return False

    def press(self, keys: bytes) -> None:
        """Type ``keys`` (b"q", b"\\x03" for Ctrl-C, b"\\r" for Enter)."""
        os.write(self.master, keys)

    def wait(self, timeout: float) -> int | None:
        """The exit status, or None when the command is still running after ``timeout`` seconds."""
        try:
            return self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            return None

    def close(self) -> None:
        """Kill the command's whole session if it still runs, and close the terminal."""
        if self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            self.proc.wait(timeout=10)
        self._reader.join(timeout=5)
        os.close(self.master)

    def __enter__(self) -> "Terminal":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _take_terminal() -> None:
    fcntl.ioctl(0, termios.TIOCSCTTY, 0)  # the pty becomes the session's controlling terminal
