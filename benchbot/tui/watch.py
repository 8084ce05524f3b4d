"""Files turned into typed messages for the views: a :class:`FileWatcher` thread checks each watched file's stat
(size, modification time in ns, inode: one ``stat`` call, no read) every ``interval_s`` seconds; when a file's stat
changed, it reads the file on its own thread and posts the typed Textual message that the file's reader makes of
it to the view. The views keep what the messages carry and redraw from that; they never read or compare files.

The writers replace every file atomically (a new inode each time), so a changed file is never seen half-written,
and a replacement within the clock's resolution still shows as a change. Cheap stat polling, not inotify: it works
on every file system (a run directory on NFS, in a container's bind mount) and costs a few ``stat`` calls a second
while nothing changes.
"""

from __future__ import annotations

import json
import os
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

from textual.message import Message
from textual.message_pump import MessagePump

#: A file's stat as the watcher compares it: ``(st_mtime_ns, st_size, st_ino)``; ``None`` while it is missing.
Stamp = tuple[int, int, int] | None


def stamp(path: Path) -> Stamp:
    """``path``'s :data:`Stamp` (``None`` when it is missing or cannot be stat'ed)."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_mtime_ns, st.st_size, st.st_ino


def read_json(path: Path) -> Any:
    """``path``'s JSON, or None when it is missing or unreadable (files are replaced atomically: never half)."""
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


@dataclass(frozen=True)
class Watched:
    """One file to watch and the message it becomes.

    Attributes:
        path: the file.
        message: reads ``path`` (on the watcher's thread) and makes the message to post, or ``None`` to post
            nothing; called when the file's stat changed, and once at the start (missing files included, so the
            view can say what it waits for). It must not raise for a missing or malformed file.
    """

    path: Path
    message: Callable[[Path], Message | None]


class FileWatcher:
    """Posts a :class:`Watched` file's message to ``target`` whenever the file changes (module docstring).

    Args:
        target: the app or screen the messages go to (``post_message`` is thread-safe).
        watched: the files.
        interval_s: seconds between two checks of the files' stat.
    """

    def __init__(self, target: MessagePump, watched: Sequence[Watched], interval_s: float) -> None:
        self.target, self.watched, self.interval_s = target, list(watched), interval_s
        self._stamps: dict[Path, Stamp | str] = {w.path: "never" for w in self.watched}
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def scan(self) -> list[Message]:
        """The messages of the files whose stat changed since the last scan (the first scan: every file), read
        now, in the order of ``watched``. Call it from one thread at a time: the view's at the start (so its first
        frame shows the files), then the watcher's own."""
        messages = []
        for w in self.watched:
            now = stamp(w.path)
            if now == self._stamps[w.path]:
                continue
            self._stamps[w.path] = now
            message = w.message(w.path)
            if message is not None:
                messages.append(message)
        return messages

    def start(self) -> None:
        """Scan every ``interval_s`` seconds on a daemon thread, posting what changed, until :meth:`stop`."""
        self._thread = threading.Thread(target=self._run, name="benchbot-tui-watcher", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(self.interval_s):
            for message in self.scan():
                self.target.post_message(message)

    def stop(self) -> None:
        """End the thread (it finishes the scan it is in; returns within a second)."""
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=1.0)
