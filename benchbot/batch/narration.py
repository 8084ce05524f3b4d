"""What a batch is doing, as plain lines, when nothing live shows it: a batch into a log (``> log 2>&1``: no
terminal) and a batch whose live view was closed with ``q``.

:class:`Narrator` takes the executor's events (``start``, ``stage``, ``step``, ``end``, ``lost``) and prints, for each
running episode, a line when it starts a new stage (``[1/2] miniroom:1  building the scene (miniroom) …``) or when
its solution starts (``[1/2] miniroom:1  the backend is ready; the solution runs …``), and whenever nothing was
printed for :data:`QUIET_S` seconds a line per running episode saying what it waits for (``[1/2] miniroom:1  step
12 of 48, 0:31``). Lines carry no colour or other escape sequences.
"""

from __future__ import annotations

import threading
import time
from typing import Callable

#: Seconds without a line after which a line per running episode says what it is doing.
QUIET_S = 10.0


def format_seconds(seconds: float | None) -> str:
    """``m:ss`` (``h:mm:ss`` past an hour); ``""`` for None. Here, not in the live view's module, so that a batch
    that prints lines does not import Textual for it."""
    if seconds is None:
        return ""
    s = int(round(seconds))
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}" if s >= 3600 else f"{s // 60}:{s % 60:02d}"


def _clock(seconds: float) -> str:
    s = int(seconds)
    return f"{s // 60}:{s % 60:02d}"


class Narrator:
    """Plain progress lines for a batch (module docstring).

    Args:
        say: prints one line. labels: ``{index: "[1/2] miniroom:1"}``. expected: ``{index: expected steps or
            None}``. speaking: print from the start (False: only track until :meth:`speak`).
        quiet_s: :data:`QUIET_S`. muted: True once nothing more should be said (the batch is being stopped).
    """

    def __init__(self, say: Callable[[str], None], labels: dict[int, str],
                 expected: dict[int, int | None] | None = None, *, speaking: bool = True, quiet_s: float = QUIET_S,
                 muted: Callable[[], bool] = lambda: False) -> None:
        self.say, self.labels, self.expected, self.muted = say, labels, expected or {}, muted
        self.quiet_s = quiet_s
        self.running: dict[int, dict] = {}  # index -> {"since", "stage", "step"}
        self.speaking = speaking
        self.last_line = time.monotonic()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    # events -------------------------------------------------------------------------------------------------------
    def event(self, kind: str, index: int, info: dict | None) -> None:
        """An executor event (:func:`benchbot.batch.runner.run_batch`'s ``on_event``)."""
        with self._lock:
            label = self.labels.get(index, f"[{index + 1}]")
            if kind == "start":
                self.running[index] = {"since": time.monotonic(), "stage": "", "step": 0, "said_stage": ""}
                self._line(f"{label}  starting …")
            elif kind == "stage" and index in self.running:
                ep = self.running[index]
                text = str((info or {}).get("stage", ""))
                ep["stage"] = text
                name = text.split(" (")[0]
                if text and name != ep["said_stage"]:
                    ep["said_stage"] = name
                    self._line(f"{label}  {text} …")
            elif kind == "step" and index in self.running:
                ep = self.running[index]
                if ep["step"] == 0:
                    ep["stage"] = ""
                    self._line(f"{label}  the backend is ready; the solution runs …")
                ep["step"] = int((info or {}).get("step", 0))
            elif kind == "end":
                self.running.pop(index, None)

    def status(self, index: int) -> str:
        """What episode ``index`` is doing now, in words."""
        ep = self.running[index]
        took = _clock(time.monotonic() - ep["since"])
        if ep["stage"]:
            return f"{ep['stage']} …, {took}"
        if ep["step"]:
            total = self.expected.get(index)
            return f"step {ep['step']}" + (f" of {total}" if total else "") + f" (the solution runs), {took}"
        if ep["said_stage"]:
            return f"the backend is starting (done: {ep['said_stage']}), {took}"
        return f"starting, {took}"

    def speak(self) -> None:
        """Start printing (the live view closed): one line per running episode now, then as above."""
        with self._lock:
            self.speaking = True
            if not self.running:
                return
            for index in sorted(self.running):
                self._line(f"{self.labels.get(index, index)}  {self.status(index)}")

    def _line(self, text: str) -> None:
        if self.speaking and not self.muted():  # muted: the batch is being stopped (its backend may still talk)
            self.say(text)
            self.last_line = time.monotonic()

    # the quiet-time lines -----------------------------------------------------------------------------------------
    def _watch(self) -> None:
        while not self._stop.wait(min(1.0, self.quiet_s / 4)):
            with self._lock:
                if not self.speaking or not self.running or time.monotonic() - self.last_line < self.quiet_s:
                    continue
                for index in sorted(self.running):
                    self._line(f"{self.labels.get(index, index)}  {self.status(index)}")

    def __enter__(self) -> "Narrator":
        self._thread = threading.Thread(target=self._watch, name="benchbot-narrator", daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(2.0)
