"""``RUN_DIR/progress.json``: the live step counts of a batch's running episodes, for views in any process.

:func:`benchbot.batch.runner.run_batch` writes it (:class:`ProgressFile`) from the executors' ``start``/``step``/
``end`` events; the batch view (:mod:`benchbot.tui.batch_app`) reads it (:func:`read_progress`) alongside the
manifest, whether it runs in the batch's process (``benchbot batch`` in a terminal) or in another one
(``benchbot tui RUN_DIR``). The format (docs/tui.md)::

    {"episodes": {"<index>": {"state": "running" | "ended" | "interrupted", "step": <steps so far>, "started": <Unix s>,
                              "stage": <what its backend is doing while it starts, e.g. "building the BVH"; "">}}}

An episode's expected steps are not in it: the view takes them from ``config.json``
(:func:`benchbot.batch.plan.expected_steps`).
"""

from __future__ import annotations

import json
import threading
import time
import weakref
from pathlib import Path

from benchbot.core import atomic

PROGRESS = "progress.json"

#: Seconds :func:`mark_interrupted` waits for a writer's write in progress (one atomic replace of a small file).
LOCK_WAIT_S = 1.0
#: The writers alive in this process, by their file's resolved path: :func:`mark_interrupted` stops one before marking.
_WRITERS: "weakref.WeakValueDictionary[str, ProgressFile]" = weakref.WeakValueDictionary()


class ProgressFile:
    """The writer of ``RUN_DIR/progress.json``: replaced atomically on every episode start and end, and at most
    ``max_rate_hz`` times a second on steps (each step still updates the count it writes next). Once
    :func:`mark_interrupted` has marked its run directory it writes nothing more, so that an episode thread still
    running after Ctrl-C (a backend busy in a kernel compile) cannot put ``running`` back.

    Args:
        run_dir: the run directory.
        max_rate_hz: the most writes per second on steps (Hz).
    """

    def __init__(self, run_dir: Path, max_rate_hz: float = 4.0) -> None:
        self.path = run_dir / PROGRESS
        self.episodes: dict[str, dict] = {}
        self.min_interval, self.written_at = 1.0 / max_rate_hz, 0.0
        self.lock = threading.Lock()
        self.stopped = False
        _WRITERS[str(self.path.resolve())] = self

    def event(self, kind: str, index: int, info: dict | None) -> None:
        """An executor event: ``("start", index, None)``, ``("stage", index, {"stage": text})``, ``("step", index,
        {"step": n, ...})`` or ``("end", index, None)``; others are ignored.

        Raises:
            OSError: the file cannot be written.
        """
        with self.lock:
            if self.stopped:
                return
            key = str(index)
            if kind == "start":
                self.episodes[key] = {"state": "running", "step": 0, "started": time.time(), "stage": ""}
            elif kind == "stage" and key in self.episodes:
                self.episodes[key]["stage"] = str(info.get("stage", ""))
            elif kind == "step" and key in self.episodes:
                self.episodes[key]["step"] = info["step"]
                if time.monotonic() - self.written_at < self.min_interval:
                    return
            elif kind == "end" and key in self.episodes:
                self.episodes[key].update(state="ended", stage="")
            else:
                return
            atomic.write_json(self.path, {"episodes": self.episodes})
            self.written_at = time.monotonic()


def mark_interrupted(run_dir: Path) -> int:
    """After Ctrl-C: the episodes ``run_dir``'s ``progress.json`` still calls ``running`` become ``interrupted``
    (replaced atomically; nothing is written when none runs or the file is missing). A :class:`ProgressFile` of
    this process writing that file is stopped first, under its lock, so no later event of it undoes the mark.
    Returns how many.

    Raises:
        OSError: the file cannot be written.
    """
    writer = _WRITERS.get(str((Path(run_dir) / PROGRESS).resolve()))
    if writer is None:
        return _mark_running_interrupted(Path(run_dir))
    locked = writer.lock.acquire(timeout=LOCK_WAIT_S)  # a stop is bounded: never wait long on a stuck write
    try:
        writer.stopped = True
        return _mark_running_interrupted(Path(run_dir))
    finally:
        if locked:
            writer.lock.release()


def _mark_running_interrupted(run_dir: Path) -> int:
    episodes = read_progress(run_dir)
    running = [e for e in episodes.values() if isinstance(e, dict) and e.get("state") == "running"]
    for e in running:
        e.update(state="interrupted", stage="")
    if running:
        atomic.write_json(run_dir / PROGRESS, {"episodes": episodes})
    return len(running)


def read_progress(run_dir: Path) -> dict[str, dict]:
    """``{episode index as a string: {state, step, started}}`` from ``run_dir``'s ``progress.json``; ``{}`` when it
    is missing, unreadable or of another shape (it is replaced atomically, so never read half-written)."""
    try:
        progress = json.loads((run_dir / PROGRESS).read_text())
    except (OSError, ValueError):
        return {}
    episodes = progress.get("episodes") if isinstance(progress, dict) else None
    return episodes if isinstance(episodes, dict) else {}
