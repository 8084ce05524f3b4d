"""Executors: where a batch's episodes run. Every executor runs
:func:`~benchbot.batch.episode_runner.run_episode`, reports the same events and returns the same records, so results
do not depend on the executor.

``local``: ``workers == 1`` runs episodes one after another in this process (the simulator starts once);
``workers > 1`` runs them in that many worker processes (spawned; each has its own simulator thread and its own
backend on a free loopback port; each worker's simulator and solutions get cores / workers threads). ``ray``:
episodes are Ray tasks on a local or existing Ray cluster.
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.connection
import os
import queue
import signal
import threading
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Callable

from benchbot.batch.episode_runner import run_episode
from benchbot.batch.plan import EpisodeRecord, EpisodeSpec
from benchbot.core.errors import UsageError
from benchbot.core.session import RunSpec

EventHandler = Callable[[str, int, dict | None], None]
#: An episode to run: its spec and its combination, resolved once by the batch process.
Episode = tuple[EpisodeSpec, RunSpec]


def _drain(events: "queue.Queue | object", on_event: EventHandler, stop: threading.Event) -> None:
    while True:
        try:
            kind, index, info = events.get(timeout=0.1)
        except queue.Empty:
            if stop.is_set():
                return
            continue
        except (EOFError, OSError):  # the manager went away
            return
        on_event(kind, index, info)


#: Thread-count variables a worker sets (unless already set) for its simulator and for the solution processes it
#: starts (NumPy's BLAS and OpenMP read them when they load).
THREAD_VARIABLES = ("BENCHBOT_TAICHI_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


_events = None  # in a worker process: the batch's event queue (set by _init_worker)
_parent_gone = threading.Event()  # in a worker process: the batch process has died


def _init_worker(threads: int, events: "multiprocessing.Queue") -> None:
    """Worker initialiser: cap each worker's simulator threads and its solutions' BLAS/OpenMP threads to the
    worker's share of the cores (unless the user set them), so N workers do not each start one thread per core —
    oversubscribed BLAS threads spin and slow every episode down; keep the event queue; :func:`_end_with_parent`."""
    global _events
    for name in THREAD_VARIABLES:
        os.environ.setdefault(name, str(threads))
    _events = events
    _end_with_parent()


#: Seconds a worker whose batch process died has to stop its episode (solution group, server, backend) before it
#: exits regardless; longer than the solution's SIGTERM grace.
ORPHAN_EXIT_S = 15.0


def _end_with_parent() -> None:
    """In a worker process: when the batch process dies (``kill -9`` included), interrupt the episode in progress
    as Ctrl-C would (its solution's group is stopped, its server and backend closed; :func:`_worker_episode` then
    exits), and exit after at most :data:`ORPHAN_EXIT_S` seconds in any case. Without it a worker would run its
    episode to the end for nobody and stay."""
    parent = multiprocessing.parent_process()
    if parent is None:
        return
    signal.signal(signal.SIGINT, signal.default_int_handler)  # even if the batch was started with SIGINT ignored

    def watch() -> None:
        multiprocessing.connection.wait([parent.sentinel])
        _parent_gone.set()
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(ORPHAN_EXIT_S)
        os._exit(1)

    threading.Thread(target=watch, name="benchbot-parent-watch", daemon=True).start()


def _worker_episode(spec: EpisodeSpec, run: RunSpec, run_dir: str) -> EpisodeRecord:
    """:func:`run_episode` in a worker process, reporting to the batch's event queue; exits the worker at once
    when its batch process has died (once the episode has cleaned up)."""
    try:
        return run_episode(spec, run, run_dir, _events)
    except KeyboardInterrupt:
        if _parent_gone.is_set():
            os._exit(1)
        raise


def run_local(
    episodes: list[Episode], run_dir: str, *, workers: int, on_event: EventHandler,
    on_record: Callable[[EpisodeRecord], None],
) -> None:
    """Run ``episodes`` (at least one) with ``workers`` parallel episodes; ``on_record`` is called (in this
    thread) as each ends. Worker processes end with the batch process, even when it is killed
    (:func:`_end_with_parent`)."""
    stop = threading.Event()
    if workers <= 1:
        events: queue.Queue = queue.Queue()
        drainer = threading.Thread(target=_drain, args=(events, on_event, stop), daemon=True)
        drainer.start()
        try:
            for spec, run in episodes:
                on_record(run_episode(spec, run, run_dir, events))
        finally:
            stop.set()
            drainer.join()
        return
    context = multiprocessing.get_context("spawn")
    events = context.Queue()  # no manager process: it would outlive a killed batch
    drainer = threading.Thread(target=_drain, args=(events, on_event, stop), daemon=True)
    drainer.start()
    try:
        threads = max(1, (os.cpu_count() or 1) // min(workers, len(episodes)))
        with ProcessPoolExecutor(max_workers=workers, mp_context=context, initializer=_init_worker,
                                 initargs=(threads, events)) as pool:
            futures = [pool.submit(_worker_episode, spec, run, run_dir) for spec, run in episodes]
            for future in as_completed(futures):
                on_record(future.result())
    finally:
        stop.set()
        drainer.join()
        events.close()


def run_ray(
    episodes: list[Episode], run_dir: str, *, address: str | None, workers: int, on_event: EventHandler,
    on_record: Callable[[EpisodeRecord], None],
) -> None:
    """Run ``episodes`` as Ray tasks (one CPU each) and call ``on_record`` as each ends.

    Args:
        address: an existing cluster's address (``ray://host:10001`` or ``host:6379``); None starts a local Ray
            with ``workers`` CPUs for this batch (and shuts it down afterwards).

    On a cluster, every node needs BenchBot and the plugins installed, and the run directory and the submission's
    folder must be on a filesystem all nodes share (each episode writes its results and log there).

    Raises:
        UsageError: Ray is not installed.
    """
    # Under `uv run`, Ray would copy the working directory and run workers from that copy (paths in specs and
    # results would differ from a local run); workers use the installed BenchBot instead. Ray reads this at import.
    os.environ["RAY_ENABLE_UV_RUN_RUNTIME_ENV"] = "0"
    try:
        import ray
        from ray.util.queue import Queue
    except ImportError:
        raise UsageError("--executor ray needs Ray", "install it: uv pip install 'benchbot[ray]'") from None
    started_here = not ray.is_initialized()
    if started_here:
        kwargs = {"address": address} if address else {"num_cpus": workers}
        # Ray's workers do not inherit this process's environment: pass BenchBot's settings (plugins to load or
        # skip, data directory, Taichi arch) so every episode sees the same registry as a local run would.
        env_vars = {k: v for k, v in os.environ.items() if k.startswith(("BENCHBOT_", "TI_", "CYCLONEDDS_"))}
        ray.init(include_dashboard=False, log_to_driver=False, configure_logging=False,
                 runtime_env={"env_vars": env_vars}, **kwargs)
    stop = threading.Event()
    events = Queue()
    drainer = threading.Thread(target=_drain, args=(events, on_event, stop), daemon=True)
    drainer.start()
    try:
        remote_episode = ray.remote(num_cpus=1, max_retries=0)(run_episode)
        pending = [remote_episode.remote(spec, run, run_dir, events) for spec, run in episodes]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            on_record(ray.get(done[0]))
    finally:
        stop.set()
        drainer.join()
        if started_here:
            ray.shutdown()
