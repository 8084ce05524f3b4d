"""The stages of long work inside BenchBot and its plugins (building a scene, compiling kernels, baking light), told to
whoever shows them: the CLI's status line, a batch's progress file, a log.

A plugin marks a stage where it does the work::

    from benchbot.core import stages

    with stages.stage("building the BVH", detail="599k triangles"):
        ...
    with stages.stage("baking light", total=29) as progress:
        for lamp in lamps:
            ...
            progress.advance()

and a command listens while it waits (:func:`listening`): each listener is called with a :class:`StageEvent` when a
stage starts, advances and ends. Listeners are process-wide (the work often runs on another thread, such as a
backend's; :func:`listening_here` hears one thread's work only), called on the thread doing the work, and must return quickly; an exception in a listener is dropped (the
work never fails because its progress could not be shown). Without a listener a stage costs a few microseconds.
"""

from __future__ import annotations

import contextlib
import threading
import time
from dataclasses import dataclass
from typing import Callable, Iterator

#: Seconds between two "advance" events of one stage that listeners are told of (the last one always is).
ADVANCE_INTERVAL_S = 0.1


@dataclass(frozen=True)
class StageEvent:
    """One moment of a stage.

    Attributes:
        kind: ``"start"``, ``"advance"`` or ``"end"``.
        name: what is being done, lower case, as the middle of a sentence ("building the BVH").
        detail: more about it ("599k triangles", "once per machine: Taichi caches them"), or "".
        done, total: units done and in all when the work is measurable (``total`` None otherwise).
        elapsed_s: seconds since the stage started (0 at ``start``).
    """

    kind: str
    name: str
    detail: str = ""
    done: int = 0
    total: int | None = None
    elapsed_s: float = 0.0

    def text(self) -> str:
        """One line for people: ``building the BVH (599k triangles)``, with ``12/29`` when measurable."""
        parts = [self.detail] if self.detail else []
        if self.total:
            parts.append(f"{self.done}/{self.total}")
        return self.name + (f" ({', '.join(parts)})" if parts else "")


Listener = Callable[[StageEvent], None]
_listeners: list[Listener] = []
_lock = threading.Lock()
_here = threading.local()  # .listeners: the listeners of :func:`listening_here` on this thread


def _tell(event: StageEvent) -> None:
    with _lock:
        listeners = list(_listeners)
    listeners += getattr(_here, "listeners", [])
    for listener in listeners:
        try:
            listener(event)
        except Exception:  # noqa: BLE001 - showing progress must never break the work
            pass


class Stage:
    """A running stage (from :func:`stage`): :meth:`advance` reports progress of measurable work."""

    def __init__(self, name: str, detail: str, total: int | None) -> None:
        self.name, self.detail, self.total = name, detail, total
        self.done = 0
        self.start = time.monotonic()
        self._told = 0.0

    def _event(self, kind: str) -> StageEvent:
        return StageEvent(kind, self.name, self.detail, self.done, self.total, time.monotonic() - self.start)

    def advance(self, units: int = 1) -> None:
        """``units`` more are done (listeners hear of it at most every :data:`ADVANCE_INTERVAL_S`)."""
        self.done += units
        now = time.monotonic()
        if now - self._told >= ADVANCE_INTERVAL_S or (self.total is not None and self.done >= self.total):
            self._told = now
            _tell(self._event("advance"))


@contextlib.contextmanager
def stage(name: str, *, detail: str = "", total: int | None = None) -> Iterator[Stage]:
    """Mark the work inside the ``with`` block as the stage ``name`` (see the module docstring).

    Args:
        name: what is done, lower case ("compiling kernels").
        detail: more about it, shown in brackets.
        total: how many units the work has, when it is measurable (then call ``advance``).
    """
    current = Stage(name, detail, total)
    _tell(current._event("start"))
    try:
        yield current
    finally:
        _tell(current._event("end"))


def relay(event: StageEvent) -> None:
    """Tell this process's listeners (those of :func:`listening`, and this thread's of :func:`listening_here`) of a
    stage of work done in another process (the simulator service builds a command's backend: its stages arrive
    as events and are told here, as if the work ran here). Never raises."""
    _tell(event)


@contextlib.contextmanager
def listening(listener: Listener) -> Iterator[None]:
    """Call ``listener`` with every :class:`StageEvent` of this process while the block runs."""
    with _lock:
        _listeners.append(listener)
    try:
        yield
    finally:
        with _lock:
            _listeners.remove(listener)


@contextlib.contextmanager
def listening_here(listener: Listener) -> Iterator[None]:
    """Call ``listener`` with the :class:`StageEvent` s of the work this thread does while the block runs, and of no
    other thread's: where several pieces of work share a process (a batch's episodes run together build their
    backends one after another on the backend thread), each hears only its own."""
    listeners = _here.__dict__.setdefault("listeners", [])
    listeners.append(listener)
    try:
        yield
    finally:
        listeners.remove(listener)
