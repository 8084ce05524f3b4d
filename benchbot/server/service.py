"""The one backend thread: :class:`BackendService` owns an episode and runs every call to it on that thread.

Taichi and other simulators need a single thread per process, so every service of the process shares one worker
(:func:`backend_worker`); nothing else touches the episode.
"""

from __future__ import annotations

import asyncio
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Callable

from benchbot.core.episode import Episode
from benchbot.server.redaction import ground_truth_strings

_WORKER: ThreadPoolExecutor | None = None
_WORKER_LOCK = threading.Lock()


def backend_worker() -> ThreadPoolExecutor:
    """The process-wide single thread on which every robot backend runs (Taichi needs one thread per process).

    Returns:
        A one-thread executor, made on the first call and the same one ever after (never raises).
    """
    global _WORKER
    with _WORKER_LOCK:
        if _WORKER is None:
            _WORKER = ThreadPoolExecutor(max_workers=1, thread_name_prefix="benchbot-backend")
        return _WORKER


class BackendService:
    """Owns an episode and runs every call to it on the process's backend thread (:func:`backend_worker`).

    Args:
        build_episode: called once, on the worker thread, to build the episode (and its backend).
        results_functions: ``{name: callable}`` of the task's results format.
        hidden: strings never to be served, e.g. the paths of the environments' ground-truth files (error
            messages have them blanked out); the environments' own ``map_path``/``_file_path`` and mesh paths are
            added.
        on_close: called once, on the worker thread, with the episode when the service closes (before the backend
            closes): :func:`benchbot.core.session.start_service` calls the ``benchbot_episode_finished`` hook there.

    Raises:
        BenchbotError: whatever ``build_episode`` raises.
    """

    def __init__(self, build_episode: Callable[[], Episode], results_functions: dict[str, Callable] | None = None,
                 hidden: set[str] | None = None, on_close: Callable[[Episode], None] | None = None):
        self.executor = backend_worker()
        self.results_functions = results_functions or {}
        self.episode: Episode = self.executor.submit(build_episode).result()
        self.hidden = set(hidden or ()) | ground_truth_strings(self.episode.environments)
        self._on_close, self._closed = on_close, False

    def call(self, fn: Callable, *args: Any) -> Any:
        """Run ``fn(*args)`` on the worker thread and wait for it; returns its value, raises what it raises."""
        return self.executor.submit(fn, *args).result()

    async def acall(self, fn: Callable, *args: Any) -> Any:
        """Await ``fn(*args)`` run on the worker thread; returns its value, raises what it raises."""
        return await asyncio.wrap_future(self.executor.submit(fn, *args))

    def close(self) -> None:
        """Call ``on_close`` (once), then close the robot backend, on the worker thread; the thread stays for the
        next service. Raises what ``on_close`` or the backend's ``close`` raises (the backend closes either way)."""
        if not self._closed and self._on_close is not None:
            self._closed = True
            try:
                self.call(self._on_close, self.episode)
            finally:
                self.call(self.episode.backend.close)
            return
        self._closed = True
        self.call(self.episode.backend.close)
