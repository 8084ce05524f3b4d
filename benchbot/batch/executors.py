"""Executors: where a batch's episodes run. Every executor runs
:func:`~benchbot.batch.episode_runner.run_episode`, reports the same events and returns the same records, so results
do not depend on the executor.

``local``: ``workers == 1`` runs episodes one after another in this process (the simulator starts once);
``workers > 1`` runs them in that many worker processes (spawned; each has its own simulator thread and its own
backend on a free loopback port; each worker's simulator and solutions get cores / workers threads). ``batched``:
``workers`` episodes at a time in this process (:func:`run_batched`): one simulator, kernels compiled once, the
episodes of one world sharing its scene, each with its own backend, endpoint and solution process. ``ray``:
episodes are Ray tasks on an existing Ray cluster or on a local Ray started for the batch (:func:`connect_ray`,
:func:`run_ray`; docs/cluster.md): each reserves a CPU for its whole life, runs in a run directory of its node's
own and sends its files back through Ray, and is run again elsewhere when its node dies.
"""

from __future__ import annotations

import contextlib
import importlib.metadata as md
import importlib.util
import logging
import multiprocessing
import multiprocessing.connection
import os
import queue
import shutil
import signal
import socket
import sys
import tempfile
import threading
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Callable

from benchbot.batch import provenance
from benchbot.batch.gpus import on_cpu, pin, recorded, visible_gpus, wants_gpu
from benchbot.batch.episode_runner import run_episode
from benchbot.batch.plan import EpisodeRecord, EpisodeSpec, new_record
from benchbot.core import atomic
from benchbot.core.errors import UsageError
from benchbot.core.session import RunSpec

if TYPE_CHECKING:
    from benchbot.service.location import ServiceLocation

EventHandler = Callable[[str, int, dict | None], None]
#: The executors a batch can run its episodes with (module docstring).
EXECUTORS = ("local", "batched", "ray")
#: An episode to run: its spec and its combination, resolved once by the batch process.
Episode = tuple[EpisodeSpec, RunSpec]


def _drain(events: "queue.Queue | multiprocessing.Queue", on_event: EventHandler, stop: threading.Event) -> None:
    """Call ``on_event(kind, index, info)`` for every event put on ``events`` until ``stop`` is set and the queue
    is empty (or the queue is closed)."""
    while True:
        try:
            kind, index, info = events.get(timeout=0.1)
        except queue.Empty:
            if stop.is_set():
                return
            continue
        except (EOFError, OSError):  # the queue was closed
            return
        on_event(kind, index, info)


#: Thread-count variables a worker sets (unless already set) for its simulator and for the solution processes it
#: starts (NumPy's BLAS and OpenMP read them when they load).
THREAD_VARIABLES = ("BENCHBOT_TAICHI_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


_events = None  # in a worker process: the batch's event queue (set by _init_worker)
_gpu: dict | None = None  # in a worker process: its GPU (set by _init_worker), None on the CPU
_parent_gone = threading.Event()  # in a worker process: the batch process has died


def _init_worker(threads: int, events: "multiprocessing.Queue", gpus: list[dict] = (), counter=None) -> None:
    """Worker initialiser: cap each worker's simulator threads and its solutions' BLAS/OpenMP threads to the
    worker's share of the cores (unless the user set them), so N workers do not each start one thread per core —
    oversubscribed BLAS threads spin and slow every episode down; with ``gpus`` (a GPU batch), worker k (its number
    from the shared ``counter``) gets GPU k mod G alone (:func:`benchbot.batch.gpus.pin`, before Taichi starts);
    keep the event queue; :func:`_end_with_parent`."""
    global _events, _gpu
    for name in THREAD_VARIABLES:
        os.environ.setdefault(name, str(threads))
    if gpus and counter is not None:
        with counter.get_lock():
            k, counter.value = counter.value, counter.value + 1
        _gpu = gpus[k % len(gpus)]
        pin(_gpu)
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
    """:func:`run_episode` in a worker process, reporting to the batch's event queue, its GPU in the record's
    ``node``; exits the worker at once when its batch process has died (once the episode has cleaned up)."""
    try:
        record = run_episode(spec, run, run_dir, _events)
    except KeyboardInterrupt:
        if _parent_gone.is_set():
            os._exit(1)
        raise
    if wants_gpu(spec.options):
        record.node = {**record.node, **recorded(_gpu)}
    return record


def batch_gpus(episodes: list[Episode]) -> list[dict]:
    """The GPUs a batch's workers are spread over: this process's visible GPUs
    (:func:`benchbot.batch.gpus.visible_gpus`) when any episode renders on a GPU, else ``[]``."""
    return visible_gpus() if any(wants_gpu(spec.options) for spec, _ in episodes) else []


def thread_share(workers: int, episodes: int) -> int:
    """The threads each of ``workers`` parallel episodes gets (of ``episodes``): the cores over the episodes that
    run at once, at least 1."""
    return max(1, (os.cpu_count() or 1) // max(1, min(workers, episodes)))


def run_local(
    episodes: list[Episode], run_dir: str, *, workers: int, on_event: EventHandler,
    on_record: Callable[[EpisodeRecord], None], service: "bool | ServiceLocation" = False,
) -> None:
    """Run ``episodes`` (at least one) with ``workers`` parallel episodes; ``on_record`` is called (in this
    thread) as each ends. Each record says it ran here (``executor`` ``local``; ``node`` this host's name only
    with ``BENCHBOT_MANIFEST_LOCAL=1``, and the GPU it rendered on, ``gpu: {index, name}``, for a GPU arch).

    Where the backends are built and served:

    * ``service`` and one worker, on the CPU: by the user's simulator service (:mod:`benchbot.service`), on its
      own backend thread;
    * ``service`` with several workers, or on a GPU: by warm worker processes of the service's pool
      (:mod:`benchbot.service.pool`: kept between commands, each with its Taichi threads and its GPU), ``workers``
      episodes at a time, each episode's solution a child of this process (:func:`_run_in_threads`); recorded
      episodes (their recorder observes the episode in the process that serves it) run as without the service;
    * otherwise, one worker: in this process, one episode after another; several: in that many worker processes
      of this batch (spawned; each with its own simulator, its share of the cores, and GPU k mod G for worker k;
      they end with the batch process, even when it is killed: :func:`_end_with_parent`).

    ``service``: False, True, or the service's location the command found already
    (:func:`benchbot.service.location.locate`, which hashes the installation's files: once per command).
    """
    here = provenance.local_node()  # no host name unless BENCHBOT_MANIFEST_LOCAL=1
    gpus = batch_gpus(episodes)
    threads = thread_share(workers, len(episodes))

    def done(record: EpisodeRecord) -> None:
        record.executor, record.node = "local", on_cpu({**here, **record.node}, record.backend)
        on_record(record)

    if service:  # found once: finding it hashes the installation's files (20-30 ms; more with 16 threads at once)
        from benchbot.service.location import ServiceLocation, locate

        location = service if isinstance(service, ServiceLocation) else locate()
    if service and (workers > 1 or gpus) and not any(spec.record for spec, _ in episodes):
        def pooled(spec: EpisodeSpec, run: RunSpec, events) -> EpisodeRecord:
            world = repr((spec.robot, spec.env, spec.world_seed, sorted(spec.options.items()), spec.noise))
            pool = {"threads": threads, "gpus": gpus if wants_gpu(spec.options) else [], "world": world}
            return run_episode(spec, run, run_dir, events, in_service=True, pool=pool, service_location=location)

        from benchbot.service.pool import POOL_LIMIT

        # no more at once than the pool holds workers: the others would only wait in the service for a free one
        _run_in_threads(episodes, workers=min(workers, POOL_LIMIT), threads=threads, on_event=on_event,
                        on_record=done, run_one=pooled)
        return
    context = multiprocessing.get_context("spawn") if workers > 1 else None
    # between processes a plain multiprocessing queue: a manager process would outlive a killed batch
    events = context.Queue() if context is not None else queue.Queue()
    stop = threading.Event()
    drainer = threading.Thread(target=_drain, args=(events, on_event, stop), daemon=True)
    drainer.start()
    try:
        if context is None:
            for spec, run in episodes:
                record = run_episode(spec, run, run_dir, events, in_service=bool(service),
                                     service_location=location if service else None)
                if wants_gpu(spec.options) and not record.node:  # this process's CUDA device 0
                    record.node = recorded(gpus[0] if gpus else None)
                done(record)
            return
        with ProcessPoolExecutor(max_workers=workers, mp_context=context, initializer=_init_worker,
                                 initargs=(threads, events, gpus, context.Value("i", 0))) as pool:
            futures = [pool.submit(_worker_episode, spec, run, run_dir) for spec, run in episodes]
            for future in as_completed(futures):
                done(future.result())
    finally:
        stop.set()
        drainer.join()
        if context is not None:
            events.close()


#: Seconds an interrupted ``batched`` executor waits for its episodes to stop (solution group, server, backend).
BATCHED_STOP_WAIT_S = 30.0


def world_order(episodes: list[Episode]) -> list[Episode]:
    """``episodes`` with those of one world (robot, environment, world seed and simulator options) next to each
    other, in the order each world first appears: what :func:`run_batched` starts together shares one scene."""
    groups: dict[tuple, list[Episode]] = {}
    for spec, run in episodes:
        world = (spec.robot, spec.env, spec.world_seed, repr(sorted(spec.options.items())), spec.noise)
        groups.setdefault(world, []).append((spec, run))
    return [episode for group in groups.values() for episode in group]


def _run_in_threads(
    todo: list[Episode], *, workers: int, threads: int, on_event: EventHandler,
    on_record: Callable[[EpisodeRecord], None], run_one: Callable[[EpisodeSpec, RunSpec, queue.Queue], EpisodeRecord],
) -> None:
    """Run ``todo`` in this process, ``workers`` at a time, each in a thread of its own (``run_one(spec, run,
    events)``, whose solution is a child of this process); ``on_record`` in this thread as each ends. When several
    episodes run at once, solutions' BLAS/OpenMP threads are capped to ``threads`` (unless set; the variables are
    taken back afterwards); one at a time, they are left as the user has them, so a solution's own default applies
    (the example ``semslam_geometric`` takes one BLAS thread: given every core's, README command 1 on a GPU host ran
    its solution with one BLAS thread per core).

    Ctrl-C (KeyboardInterrupt in this thread): every running solution's group is stopped
    (:func:`benchbot.solutions.process_group.interrupt_children`), the episodes are given :data:`BATCHED_STOP_WAIT_S`
    seconds to close their servers and backends, and the interrupt is re-raised; episodes not started never start.
    """
    from benchbot.solutions import process_group

    several = min(workers, len(todo)) > 1
    added = [name for name in THREAD_VARIABLES[1:] if several and name not in os.environ]
    for name in added:  # the solutions' libraries; taken back at the end
        os.environ[name] = str(threads)
    events: queue.Queue = queue.Queue()
    finished: queue.Queue = queue.Queue()  # (index in todo, record or the exception it raised)
    claim = threading.Lock()
    stop = threading.Event()
    next_one = [0]

    def work() -> None:
        while not stop.is_set():
            with claim:
                k = next_one[0]
                if k >= len(todo):
                    return
                next_one[0] += 1
            spec, run = todo[k]
            try:
                finished.put((k, run_one(spec, run, events)))
            except BaseException as exc:  # KeyboardInterrupt from interrupt_children, or a bug: the caller says
                finished.put((k, exc))

    drained = threading.Event()
    drainer = threading.Thread(target=_drain, args=(events, on_event, drained), daemon=True)
    drainer.start()
    pool = [threading.Thread(target=work, name=f"benchbot-episode-{i}", daemon=True)
            for i in range(min(workers, len(todo)))]
    for thread in pool:
        thread.start()
    try:
        for _ in range(len(todo)):
            while True:
                try:
                    _, outcome = finished.get(timeout=0.2)  # a timed wait: Ctrl-C is seen at once
                    break
                except queue.Empty:
                    continue
            if isinstance(outcome, BaseException):
                raise outcome
            on_record(outcome)
    except BaseException:
        stop.set()
        process_group.interrupt_children()
        deadline = time.monotonic() + BATCHED_STOP_WAIT_S
        for thread in pool:
            thread.join(max(0.0, deadline - time.monotonic()))
        raise
    finally:
        process_group.interrupt_children(False)
        drained.set()
        drainer.join()
        for name in added:
            os.environ.pop(name, None)


def run_batched(
    episodes: list[Episode], run_dir: str, *, workers: int, on_event: EventHandler,
    on_record: Callable[[EpisodeRecord], None],
) -> None:
    """Run ``episodes`` together in THIS process, ``workers`` at a time: each episode in a thread of its own with
    its own backend, API endpoint and solution process (as :func:`run_episode` runs it), all backends on the
    process's one backend thread, so the simulator starts and compiles its kernels once. Episodes of one world run
    together (:func:`world_order`) and share its loaded scene where the simulator shares scenes (``sim_taichi``:
    :mod:`benchbot_sim_taichi.loaded_scenes`: one upload, one copy in GPU memory); what each episode observes, its
    results and its record are what it would get alone. With several at once, solutions' BLAS/OpenMP threads are
    capped to ``cores / workers`` (unless set; the variables are taken back afterwards: :func:`_run_in_threads`).
    Each record says it ran here (``executor`` ``batched``, ``node`` this host, and this process's GPU for a GPU
    arch). Ctrl-C: as
    :func:`_run_in_threads`.
    """
    here = provenance.local_node()  # no host name unless BENCHBOT_MANIFEST_LOCAL=1
    gpus = batch_gpus(episodes)

    def done(record: EpisodeRecord) -> None:
        spec_gpu = recorded(gpus[0] if gpus else None) if record.index in gpu_episodes else {}
        record.executor, record.node = "batched", on_cpu({**here, **spec_gpu}, record.backend)
        on_record(record)

    gpu_episodes = {spec.index for spec, _ in episodes if wants_gpu(spec.options)}
    _run_in_threads(world_order(episodes), workers=workers, threads=thread_share(workers, len(episodes)),
                    on_event=on_event, on_record=done,
                    run_one=lambda spec, run, events: run_episode(spec, run, run_dir, events))


# ------------------------------------------------------------------------------------------------------------ Ray
#: Seconds ``ray.init`` may take to attach to a cluster (or to start a local Ray) before the batch gives up.
RAY_CONNECT_TIMEOUT_S = 60.0
#: Seconds a plain TCP connection to the cluster's address may take: a wrong address fails here, at once.
RAY_PROBE_TIMEOUT_S = 5.0
#: Times an episode lost with its Ray node or worker process (the node died, its raylet was killed) is run again on
#: another node before it ends as ``error``; the other episodes go on meanwhile.
RAY_LOST_RETRIES = 3
#: CPUs an episode reserves on its Ray node for its whole life. Its task never waits on Ray (its events are sent
#: without waiting for a reply), so Ray never lends the CPU to another task while the episode runs.
RAY_EPISODE_CPUS = 1
#: The setting of the share of a GPU an episode on a GPU reserves on its Ray node (:func:`ray_gpus_per_episode`).
RAY_GPUS_SETTING = "BENCHBOT_RAY_GPUS_PER_EPISODE"


def ray_gpus_per_episode() -> float:
    """``BENCHBOT_RAY_GPUS_PER_EPISODE`` (default 0.0625: sixteen episodes share a GPU, as many as a one-GPU host
    runs at once with profit, docs/cluster.md): the ``num_gpus`` an episode on a GPU requests from Ray.

    Raises:
        UsageError: not a share of a GPU (:func:`benchbot.core.settings.gpu_share`: from 0.0001, Ray's finest
            share, to 1, or a whole number above 1, Ray's rule), one line naming the variable and the fix."""
    from benchbot.core import settings

    return settings.value(RAY_GPUS_SETTING)


#: Seconds an interrupted Ray batch waits for its cancelled episodes to stop (solution, server, backend).
STOP_WAIT_S = 10.0
#: Ray Client's default port (``ray://HOST`` without one).
RAY_CLIENT_PORT = 10001
#: Where Ray's own messages go while a batch is attached, relative to the run directory.
RAY_LOG = "logs/ray.log"
RAY_INSTALL_HINT = "install it: uv pip install 'benchbot[ray]' (Ray with Ray Client)"
#: Variables passed to every Ray worker (Ray's workers do not inherit the batch's environment): BenchBot's
#: settings (plugins to load or skip, data directory, Taichi arch), so every episode sees the registry a local run
#: would.
RAY_PASSED_PREFIXES = ("BENCHBOT_", "TI_", "CYCLONEDDS_")


@dataclass
class RayCluster:
    """This process's connection to Ray for one batch (:func:`connect_ray`). While it is open, Ray's own messages
    (its log lines, the errors it reports, such as a node's raylet dying) go to the log file :func:`connect_ray` was
    given, never to the terminal (where they would break the live table and ``--json``'s output).

    Attributes:
        address: the cluster's address as given or found (``HOST:PORT``, ``ray://HOST:PORT``, ``auto``); None for a
            Ray started for this batch.
        source: how it was chosen (:func:`connect_ray`): ``--ray-address``, ``RAY_ADDRESS``, ``ray start on this
            machine``, ``started for this batch`` or ``already connected``.
        started_here: a local Ray was started for this batch; :meth:`close` stops it.
        owned: :meth:`close` disconnects (False when this process was connected to Ray before).
    """

    address: str | None
    source: str
    started_here: bool = False
    owned: bool = True
    _undo: list = field(default_factory=list, repr=False)
    _handler: logging.Handler | None = field(default=None, repr=False)

    def nodes(self) -> list[dict]:
        """The cluster's live nodes: ``[{id, cpus, gpus}]``, with ``address`` and ``hostname`` only where
        ``BENCHBOT_MANIFEST_LOCAL=1`` keeps hosts in manifests (``[]`` when Ray cannot say)."""
        import ray

        try:
            nodes = ray.nodes()
        except Exception:  # noqa: BLE001 - facts for the manifest; never fail a batch over them
            return []
        local = provenance.keep_paths()
        return [{"id": n.get("NodeID", ""), "cpus": n.get("Resources", {}).get("CPU", 0),
                 "gpus": n.get("Resources", {}).get("GPU", 0),
                 **({"address": n.get("NodeManagerAddress", ""), "hostname": n.get("NodeManagerHostname", "")}
                    if local else {})} for n in nodes if n.get("Alive")]

    def facts(self) -> dict:
        """The manifest's ``executor`` entry: ``{name: "ray", ray: version, address, source, started_here, nodes}``;
        the cluster's address only when it names no host (``auto``, None) or ``BENCHBOT_MANIFEST_LOCAL=1``."""
        import ray

        address = self.address if self.address in (None, "auto") or provenance.keep_paths() else "not recorded"
        return {"name": "ray", "ray": ray.__version__, "address": address, "source": self.source,
                "started_here": self.started_here, "nodes": self.nodes()}

    def describe(self) -> str:
        """One line: where the episodes run, how many nodes and CPUs, what an episode reserves."""
        nodes = self.nodes()
        cpus = sum(n["cpus"] for n in nodes)
        where = ("a local Ray started for this batch" if self.started_here
                 else f"the Ray cluster at {self.address} ({self.source})" if self.address
                 else f"the Ray this process was connected to ({self.source})")
        return (f"Ray: {where}: {len(nodes)} node{'s' if len(nodes) != 1 else ''}, {cpus:g} CPUs; each episode "
                f"reserves {RAY_EPISODE_CPUS} CPU")

    def close(self) -> None:
        """Disconnect (stopping a Ray started for the batch) and give Ray's messages back their old place."""
        import ray

        try:
            if self.owned:
                ray.shutdown()
        except Exception:  # noqa: BLE001 - disconnecting from a cluster that is gone
            pass
        finally:
            for undo in reversed(self._undo):
                undo()
            self._undo.clear()


def _ray_target(address: str | None) -> tuple[str | None, str]:
    """``(address to connect to or None to start a local Ray, how it was chosen)``, as ``ray.init`` chooses:
    ``--ray-address``, else ``$RAY_ADDRESS``, else the cluster ``ray start`` last started on this machine (Ray's
    ``ray_current_cluster`` file), else a new local Ray. ``local`` means a new local Ray wherever it is given."""
    if address:
        return (None if address == "local" else address), "--ray-address"
    env = os.environ.get("RAY_ADDRESS", "").strip()
    if env:
        return (None if env == "local" else env), "RAY_ADDRESS"
    try:
        from ray._private.services import find_bootstrap_address

        found = find_bootstrap_address(None)
    except Exception:  # noqa: BLE001 - Ray moved it: ray.init's own search still applies (address "auto" not given)
        found = None
    if found:
        return found, "ray start on this machine"
    return None, "started for this batch"


#: The fix when Ray Client's server accepts a connection but gives it no session in time. Its proxy starts one
#: session server per connection, forking from a multithreaded process, and that server sometimes dies as it starts
#: (Ray 2.60); the proxy says so only after its grace period (30 s or more), and a batch asks again
#: (:data:`RAY_CLIENT_SESSION_TRIES`) while its timeout allows.
RAY_CLIENT_NO_SESSION_HINT = ("run the batch again (a session server that dies as it starts is a transient Ray Client "
                              "failure); the head's ray_client_server*.err (its session's logs folder, "
                              "/tmp/ray/session_latest/logs by default) says why")


#: How many times in all a batch asks Ray Client for a session when the head reports that the session server died as
#: it started (:func:`_session_died_starting`; the transient failure of :data:`RAY_CLIENT_NO_SESSION_HINT`).
RAY_CLIENT_SESSION_TRIES = 3
#: What Ray 2.60's Ray Client proxy says, in the error ``ray.init`` raises, when this connection's session server
#: died as it started.
RAY_CLIENT_SESSION_DIED_MARKS = ("psutil.ZombieProcess", "Starting Ray client server failed",
                                 "Proxy failed to Connect to backend")


def _unreachable_hint(source: str) -> str:
    if source == "--ray-address":
        return ("check the head's address and port (`ray status` on the head prints them), or leave --ray-address "
                "out to start a local Ray for this batch")
    if source == "RAY_ADDRESS":
        return "check RAY_ADDRESS, or unset it to start a local Ray for this batch"
    return ("start that cluster again (ray start --head), or run `ray stop` on this machine to forget it (the batch "
            "then starts a local Ray)")


def _probe_ray(target: str, source: str) -> None:
    """Open and close a TCP connection to ``target``'s host and port, so that a wrong address fails at once
    (``ray.init`` waits minutes on one, deaf to Ctrl-C).

    Raises:
        UsageError: ``target`` is not ``[ray://]HOST:PORT``, or nothing accepts connections there.
    """
    client = target.startswith("ray://")
    hostport = target.removeprefix("ray://").rstrip("/")
    host, sep, port = hostport.rpartition(":")
    if client and (not sep or not port.isdigit()):
        host, port = hostport, str(RAY_CLIENT_PORT)
    elif not sep or not port.isdigit() or not host:
        raise UsageError(f"Ray address '{target}' ({source}) is not HOST:PORT",
                         "e.g. --ray-address 10.0.0.5:6379 (the head's GCS port), or ray://10.0.0.5:10001 "
                         "(Ray Client)")
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=RAY_PROBE_TIMEOUT_S).close()
    except OSError as exc:
        why = exc.strerror or str(exc) or type(exc).__name__
        raise UsageError(f"no Ray cluster answers at {target} ({source}): {why}", _unreachable_hint(source)) \
            from None


def _first_line(text: str, limit: int = 240) -> str:
    """The first sentence of ``text`` on one line, at most ``limit`` characters."""
    text = " ".join(str(text).split())  # one line: a sentence now ends at ". "
    if ". " in text:
        text = text[:text.index(". ") + 1]
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _init_problem(exc: BaseException, target: str | None, source: str) -> UsageError:
    """One line (and the fix) for a failed ``ray.init``."""
    where = f"the Ray cluster at {target} ({source})" if target else "a local Ray"
    name = type(exc).__name__
    text = str(exc)
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    if any(line.startswith("Traceback (most recent call last)") for line in lines):
        text = lines[-1]  # a server's traceback (Ray Client's): what it raised
    if name == "AuthenticationError" or "InvalidAuthToken" in text:
        return UsageError(f"{where} refused this process's authentication token",
                          "give it the cluster's token: RAY_AUTH_MODE=token with RAY_AUTH_TOKEN, RAY_AUTH_TOKEN_PATH "
                          "or ~/.ray/auth_token (docs/cluster.md)")
    if "version" in text.lower() and "mismatch" in text.lower():
        return UsageError(f"cannot attach to {where}: {_first_line(text)}",
                          "install the same Ray and Python on this machine as on the cluster")
    hint = _unreachable_hint(source) if target else "see the log of Ray's messages (logs/ray.log)"
    if target and not target.startswith("ray://"):
        hint += "; from a machine outside the cluster, attach through Ray Client: ray://HEAD:10001"
    elif target:
        hint = ("the head's Ray Client server says why in ray_client_server*.err (its session's logs folder, "
                "/tmp/ray/session_latest/logs by default)")
    return UsageError(f"cannot attach to {where}: {name}: {_first_line(text)}" if target
                      else f"cannot start a local Ray: {name}: {_first_line(text)}", hint)


def connect_ray(address: str | None = None, *, workers: int = 1, log: Path | None = None,
                timeout_s: float = RAY_CONNECT_TIMEOUT_S) -> RayCluster:
    """Connect this process to Ray for a batch, choosing the cluster as ``ray.init`` does (docs/cluster.md):
    ``address`` (``--ray-address``: the head's ``HOST:PORT``, ``ray://HOST:PORT`` through Ray Client, ``auto``, or
    ``local`` for a new local Ray), else ``$RAY_ADDRESS``, else the cluster ``ray start`` last started on this
    machine, else a new local Ray with ``workers`` CPUs, started for this batch (:meth:`RayCluster.close` stops it).
    An address is first tried with a plain TCP connection, and attaching to it (``ray.init``) runs in a helper
    thread for at most ``timeout_s`` seconds a try (through Ray Client, up to :data:`RAY_CLIENT_SESSION_TRIES`
    tries: :func:`_init_with_timeout`), so a wrong address fails in one line and Ctrl-C works while it waits (a
    local Ray is started in this thread, without that limit: its processes are tied to the thread that starts them).
    Ray's messages go to ``log`` (appended) from here on; a process already connected to Ray keeps its connection.

    Raises:
        UsageError: a Ray setting has no valid value (:func:`ray_gpus_per_episode`: checked before any Ray starts);
            Ray is not installed (or, for ``ray://``, Ray Client); the address is not ``HOST:PORT``, refuses
            connections, does not answer within ``timeout_s``, or refuses this process's token; through Ray Client,
            the head's session server died as it started :data:`RAY_CLIENT_SESSION_TRIES` times.
    """
    ray_gpus_per_episode()  # a mistyped setting is one line now, not after a local Ray has started (seconds)
    # Under `uv run`, Ray would copy the working directory to every worker and run from that copy (paths in specs
    # and results would differ from a local run); workers use the installed BenchBot instead. Read at import.
    os.environ["RAY_ENABLE_UV_RUN_RUNTIME_ENV"] = "0"
    try:
        import ray
    except ImportError:
        raise UsageError("--executor ray needs Ray, which is not installed", RAY_INSTALL_HINT) from None
    if ray.is_initialized():
        return RayCluster(address=None, source="already connected", owned=False)
    target, source = _ray_target(address)
    if target is not None and target.startswith("ray://") and importlib.util.find_spec("grpc") is None:
        raise UsageError(f"{target} ({source}) is a Ray Client address, and Ray Client (ray[client]: grpcio) is "
                         "not installed", RAY_INSTALL_HINT)
    if target not in (None, "auto"):
        _probe_ray(target, source)
    cluster = RayCluster(address=target, source=source, started_here=target is None)
    _send_ray_messages_to(cluster, log)
    env_vars = {k: v for k, v in os.environ.items() if k.startswith(RAY_PASSED_PREFIXES)}
    # Ray Client's server on the head would otherwise run the batch's job as `uv run` when the head was started
    # with `uv run ray start`, and its workers would fail to set up that environment.
    env_vars["RAY_ENABLE_UV_RUN_RUNTIME_ENV"] = "0"
    kwargs: dict = {"runtime_env": {"env_vars": env_vars}, "log_to_driver": False}
    if target is None:
        kwargs.update(address="local", num_cpus=workers, include_dashboard=False, configure_logging=False)
        # Ray runs workers at nice 15 by default: a Ray started for this batch runs its episodes at the batch's own
        # priority, as the local executor does (a user's RAY_worker_niceness wins; docs/cluster.md).
        os.environ.setdefault("RAY_worker_niceness", "0")
    elif target.startswith("ray://"):
        kwargs.update(address=target)
    else:
        kwargs.update(address=target, configure_logging=False)
    try:
        with _stderr_to(log):  # Ray's C++ core writes to stderr before its log files exist
            if target is None:  # a local Ray: in this thread, which its processes' lives are tied to
                _init_local(ray, kwargs)
            else:
                _init_with_timeout(ray, kwargs, timeout_s, target, source)
    except BaseException:
        cluster.owned = False  # nothing to disconnect
        cluster.close()
        raise
    logging.getLogger("ray").handlers = [cluster._handler]  # ray.init cleared them
    return cluster


def _init_local(ray, kwargs: dict) -> None:
    """``ray.init(**kwargs)`` starting a local Ray, in the calling thread: Ray ties the processes it starts (its
    GCS, raylet) to the thread that starts them (they get a death signal when it ends), so a helper thread, as
    :func:`_init_with_timeout` uses, would leave a Ray whose GCS is gone a moment later.

    Raises:
        UsageError: ``ray.init`` failed (:func:`_init_problem`).
    """
    try:
        ray.init(**kwargs)
    except Exception as exc:  # noqa: BLE001 - reported in one line
        raise _init_problem(exc, None, "started for this batch") from None


def _init_with_timeout(ray, kwargs: dict, timeout_s: float, target: str, source: str) -> None:
    """``ray.init(**kwargs)`` in a helper thread; this thread waits (Ctrl-C interrupts the wait) at most
    ``timeout_s`` seconds. Through Ray Client, a session server that the head reports dead as it started
    (:func:`_session_died_starting`) is asked for again, up to :data:`RAY_CLIENT_SESSION_TRIES` times in all, each
    try with its own ``timeout_s``; each retry is logged to Ray's log (``logs/ray.log``).

    Raises:
        UsageError: ``ray.init`` failed or did not return in time.
    """
    for attempt in range(1, RAY_CLIENT_SESSION_TRIES + 1):
        error = _init_in_thread(ray, kwargs, timeout_s, target, source)
        if error is None:
            return
        if attempt < RAY_CLIENT_SESSION_TRIES and target.startswith("ray://") and _session_died_starting(error):
            logging.getLogger("ray").warning(
                "the head's Ray Client session server died as it started (%s); asking for another (try %d of %d)",
                _first_line(str(error).splitlines()[-1]), attempt + 1, RAY_CLIENT_SESSION_TRIES)
            continue
        raise _init_problem(error, target, source) from None


def _session_died_starting(error: BaseException) -> bool:
    """Whether a failed Ray Client ``ray.init`` says that the head's proxy could not start this connection's session
    server (it died as it started): Ray 2.60's proxy answers ``ConnectionAbortedError`` with its own traceback,
    ending in ``psutil.ZombieProcess`` (the server exited while the proxy read its command line) or in one of the
    proxy's own messages for a server that did not start (``ray/util/client/server/proxier.py``)."""
    text = str(error)
    return isinstance(error, ConnectionAbortedError) and any(mark in text for mark in RAY_CLIENT_SESSION_DIED_MARKS)


def _init_in_thread(ray, kwargs: dict, timeout_s: float, target: str, source: str) -> BaseException | None:
    """One ``ray.init(**kwargs)`` in a helper thread, waited for at most ``timeout_s`` seconds: what it raised, or
    None.

    Raises:
        UsageError: ``ray.init`` did not return in time.
    """
    outcome: dict = {}

    def init() -> None:
        try:
            ray.init(**kwargs)
        except BaseException as exc:  # noqa: BLE001 - reported by the waiting thread
            outcome["error"] = exc

    thread = threading.Thread(target=init, name="benchbot-ray-init", daemon=True)
    thread.start()
    thread.join(timeout_s)
    if thread.is_alive() and target.startswith("ray://"):  # the probe reached its server: no session came
        raise UsageError(f"the Ray Client server at {target} ({source}) accepted the connection but started no "
                         f"session for this batch within {timeout_s:g} s", RAY_CLIENT_NO_SESSION_HINT)
    if thread.is_alive():
        raise UsageError(f"the Ray cluster at {target} ({source}) did not answer within {timeout_s:g} s",
                         _unreachable_hint(source))
    return outcome.get("error")


@contextlib.contextmanager
def _stderr_to(log: Path | None):
    """File descriptor 2 of this process goes to ``log`` (or nowhere) inside the block."""
    sys.stderr.flush()
    target = open(log, "a") if log is not None else open(os.devnull, "w")  # noqa: SIM115
    saved = os.dup(2)
    try:
        os.dup2(target.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        target.close()


def _send_ray_messages_to(cluster: RayCluster, log: Path | None) -> None:
    """Point Ray's logger, and the errors its driver prints (a raylet that died, ...), at ``log`` until
    ``cluster`` closes (its undo list puts them back)."""
    import ray._private.worker as ray_worker

    if log is not None:
        log.parent.mkdir(parents=True, exist_ok=True)
        handler: logging.Handler = logging.FileHandler(log)
        handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
    else:
        handler = logging.NullHandler()
    ray_logger = logging.getLogger("ray")
    saved_handlers, saved_propagate = ray_logger.handlers[:], ray_logger.propagate
    ray_logger.handlers, ray_logger.propagate = [handler], False
    cluster._handler = handler

    def restore_logger() -> None:
        ray_logger.handlers, ray_logger.propagate = saved_handlers, saved_propagate
        handler.close()

    cluster._undo.append(restore_logger)
    printer = getattr(ray_worker, "print_to_stdstream", None)
    if printer is not None:  # the driver's thread that prints cluster errors to stdout and stderr
        def to_log(data: dict, *args, **kwargs) -> None:
            for line in data.get("lines", []):
                ray_logger.warning("(%s) %s", data.get("pid", "ray"), line)

        ray_worker.print_to_stdstream = to_log
        cluster._undo.append(lambda: setattr(ray_worker, "print_to_stdstream", printer))


class _EventBuffer:
    """A Ray actor, on the batch's own node, keeping the episodes' events until the batch process takes them."""

    def __init__(self) -> None:
        self.items: list = []

    def put(self, item: tuple) -> None:
        self.items.append(item)

    def take(self) -> list:
        items, self.items = self.items, []
        return items


class _ActorSink:
    """The ``events`` of :func:`run_episode` on a Ray node: ``put`` sends an event to the batch's
    :class:`_EventBuffer` without waiting for the reply (a task that waits on Ray lends its CPU to other tasks)."""

    def __init__(self, actor) -> None:
        self.actor = actor

    def put(self, item: tuple) -> None:
        try:
            self.actor.put.remote(item)
        except Exception:  # noqa: BLE001 - the batch process is gone: the episode ends on its own
            pass


def _node_facts() -> dict:
    """Where a Ray task runs: ``{id, niceness}`` (its node's id, as `ray status` and Ray's dashboard show it, and the
    worker's nice value: Ray's default is 15, docs/cluster.md); its IP
    ``address`` and ``hostname`` too only with ``BENCHBOT_MANIFEST_LOCAL=1`` (manifests name no host by default)."""
    import ray

    here = {"id": ray.get_runtime_context().get_node_id(), "niceness": os.nice(0)}
    if provenance.keep_paths():
        here["address"] = ray.util.get_node_ip_address()
    return {**here, **provenance.local_node()}


def node_name(node: dict) -> str:
    """A Ray node in a few words, from a record's ``node`` (:func:`_node_facts`): the start of its id,
    ``3f2a1b2c``, after its address where recorded, ``10.0.0.7 (3f2a1b2c)``; ``an unknown node`` when ``node`` is
    empty."""
    if not node:
        return "an unknown node"
    short = str(node.get("id", ""))[:8] or "?"
    return f"{node['address']} ({short})" if node.get("address") else short


def distribution_versions() -> dict[str, str]:
    """``{distribution: version}`` of BenchBot and of every installed plugin distribution (entry-point group
    ``benchbot``): what every Ray node must have, the same (:func:`_node_problem`)."""
    out = {}
    try:
        out["benchbot"] = md.version("benchbot")
    except md.PackageNotFoundError:
        pass
    for entry in md.entry_points(group="benchbot"):
        if entry.dist is not None:
            out[entry.dist.name] = entry.dist.version
    return out


def _node_problem(spec: EpisodeSpec, versions: dict[str, str]) -> str:
    """Why this node cannot run ``spec`` as the batch's machine would ("" when it can): another version of
    BenchBot or of a plugin, or the solution's folder or program missing (every node needs them at the same
    path)."""
    for dist, wanted in sorted(versions.items()):
        try:
            have = md.version(dist)
        except md.PackageNotFoundError:
            have = None
        if have != wanted:
            here = "is not installed here" if have is None else f"is {have} here"
            return (f"{dist} {here}, {wanted} on the batch's machine: every node needs the same BenchBot and "
                    "plugins (docs/cluster.md)")
    folder = Path(spec.container["context"]) if spec.container else Path(spec.cwd)
    if not folder.is_dir():
        return (f"the solution's folder {folder} is not on this node: every node needs it at the same path (a "
                "shared file system, or the same copy; docs/cluster.md)")
    program = spec.argv[0] if spec.argv and not spec.container else ""
    if os.path.isabs(program) and not os.path.exists(program):
        return (f"the solution's program {program} is not on this node: install BenchBot at the same path on every "
                "node (docs/cluster.md)")
    return ""


def _shared_run_dirs(run_dir: str) -> tuple:
    """The batch's run directory and those beside it, where this node sees them (a shared file system): hidden
    from a sandboxed solution, as on the batch's machine."""
    from benchbot.batch.episode_runner import run_directories

    try:
        return tuple(run_directories(Path(run_dir))) if Path(run_dir).parent.is_dir() else ()
    except OSError:
        return ()


def _collect(folder: Path, log: str) -> tuple[dict[str, bytes], str]:
    """``({path relative to folder: content}, "")`` of every regular file under ``folder``, with ``{path + "/":
    b""}`` of every folder in it (links are left out); when the files take more than
    :data:`~benchbot.core.limits.RAY_EPISODE_BYTES`, nothing is read but the file ``log`` (relative to ``folder``),
    and the second item says why in one line."""
    from benchbot.core.limits import RAY_EPISODE_BYTES

    folders, regular = [], []
    for root, dirs, names in os.walk(folder):
        folders += [Path(root, name) for name in dirs if not Path(root, name).is_symlink()]
        regular += [Path(root, name) for name in names
                    if Path(root, name).is_file() and not Path(root, name).is_symlink()]
    total, limit = sum(path.stat().st_size for path in regular), RAY_EPISODE_BYTES.value()
    if total > limit:
        kept = folder / log
        files = {log: kept.read_bytes()} if kept.is_file() and not kept.is_symlink() else {}
        return files, (f"its files take {total} bytes on its node, more than {RAY_EPISODE_BYTES.describe(limit)}; "
                       f"only its log was sent back ({RAY_EPISODE_BYTES.raise_hint()})")
    files = {path.relative_to(folder).as_posix() + "/": b"" for path in folders}
    files |= {path.relative_to(folder).as_posix(): path.read_bytes() for path in regular}
    return files, ""


def _ray_episode(spec: EpisodeSpec, run: RunSpec, run_dir: str, events, versions: dict[str, str]
                 ) -> tuple[EpisodeRecord, dict[str, bytes]]:
    """A Ray task: run ``spec`` in a run directory of this node's own (a temporary folder) and return its record
    and the files it wrote there (``{path relative to the run directory: bytes}``), which the batch process writes
    into the run directory (:func:`_unpack`): the nodes need no shared file system for results, logs, outputs,
    trajectories or recordings. A problem of this node (:func:`_node_problem`, or anything
    :func:`run_episode` does not record itself) ends the episode as ``error`` in one line naming the node."""
    node = _node_facts()
    sink = _ActorSink(events)
    sink.put(("node", spec.index, node))
    files: dict[str, bytes] = {}
    try:
        problem = _node_problem(spec, versions)
        if problem:
            record = new_record(spec)
            record.status, record.error = "error", problem
        else:
            with tempfile.TemporaryDirectory(prefix="benchbot-ray-") as tmp:
                local = Path(tmp, Path(run_dir).name)
                local.mkdir()
                record = run_episode(spec, run, str(local), sink, hide=_shared_run_dirs(run_dir))
                files, too_large = _collect(local, spec.log)
                if too_large:
                    record.status = "error"
                    record.error = f"{record.error}; {too_large}" if record.error else too_large
    except Exception as exc:  # noqa: BLE001 - not the episode's own failure (run_episode records those)
        record = new_record(spec)
        record.status, record.error = "error", f"{type(exc).__name__}: {_first_line(exc)}"
    record.executor, record.node = "ray", node
    if wants_gpu(spec.options):  # the GPU Ray gave the task (CUDA_VISIBLE_DEVICES), or this node's first
        record.node = on_cpu({**node, **recorded(next(iter(visible_gpus()), None))}, record.backend)
    if record.status == "error":
        record.error = f"on node {node_name(node)}: {record.error}"
    return record, files


def _unpack(run_dir: Path, spec: EpisodeSpec, files: dict[str, bytes]) -> str:
    """Write the files an episode made on its node into the run directory, after removing what its previous
    attempt left (its results file and outputs folder), as :func:`run_episode` does locally. Returns "" or the
    problem (one line)."""
    root = Path(run_dir).resolve()
    try:
        stale = root / spec.results
        if stale.is_symlink() or stale.is_file():
            stale.unlink()
        shutil.rmtree(root / spec.outputs, ignore_errors=True)
        for rel, data in files.items():
            path = root / rel
            if Path(rel).is_absolute() or ".." in Path(rel).parts or not path.resolve().is_relative_to(root):
                return f"the node sent a file outside the run directory ({rel}): refused"
            if rel.endswith("/"):
                path.mkdir(parents=True, exist_ok=True)
            else:
                atomic.write_bytes(path, data)
    except OSError as exc:
        return f"cannot write the episode's files into {root}: {exc.strerror or exc}"
    return ""


def _lost_reason(exc: BaseException) -> str:
    """Why Ray lost an episode, in a few words ("" when ``exc`` is no loss but a failure: a runtime environment
    that cannot be set up, say, which would fail again anywhere)."""
    import ray.exceptions as rex

    if isinstance(exc, rex.NodeDiedError):
        return "its node died"
    if isinstance(exc, (rex.WorkerCrashedError, getattr(rex, "LocalRayletDiedError", rex.WorkerCrashedError))):
        return "its worker process died"
    if isinstance(exc, rex.ObjectLostError):  # OwnerDiedError, ObjectReconstructionFailedError, ... among them
        return "its result was lost"
    return ""


def _drain_actor(ray, actor, on_event: EventHandler, stop: threading.Event) -> None:
    """Take the episodes' events from the :class:`_EventBuffer` a few times a second until ``stop``; one last
    time after it."""
    while True:
        final = stop.is_set()
        try:
            items = ray.get(actor.take.remote(), timeout=10)
        except Exception:  # noqa: BLE001 - a slow or gone buffer: progress waits, records still arrive
            items = []
        for kind, index, info in items:
            on_event(kind, index, info)
        if final:
            return
        stop.wait(0.1)


def run_ray(episodes: list[Episode], run_dir: str | Path, *, on_event: EventHandler,
            on_record: Callable[[EpisodeRecord], None], lost_retries: int = RAY_LOST_RETRIES) -> None:
    """Run ``episodes`` as Ray tasks on the cluster this process is connected to (:func:`connect_ray`; the caller
    closes it) and call ``on_record`` (in this thread) as each ends (docs/cluster.md).

    Each episode reserves :data:`RAY_EPISODE_CPUS` CPU on its node for its whole life, and an episode on a GPU
    (``--arch cuda``) :func:`ray_gpus_per_episode` of a GPU where the cluster has GPUs (Ray then places episodes by
    GPU and gives each task its GPU in ``CUDA_VISIBLE_DEVICES``; the record's ``node`` says which, ``gpu``); it runs
    in a run directory
    of the node's own; what it wrote comes back through Ray's object store and this process writes it into
    ``run_dir`` (:func:`_ray_episode`): no shared file system is needed for the run directory. The solution's
    folder, and BenchBot with the same plugins, must be at the same paths on every node. An episode lost with its
    node or worker process is run again on another node (up to ``lost_retries`` times; the others go on) and the
    lost attempts are in its record's ``lost``. Events: those of :func:`run_episode`, and ``("lost", index, {node,
    error, again})``. A problem of one episode (its node, its files) ends that episode as ``error``; Ctrl-C cancels
    the running episodes, waits up to :data:`STOP_WAIT_S` for them, and is raised again.
    """
    import ray
    import ray.exceptions as rex
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    run_dir = Path(run_dir)
    here = ray.get_runtime_context().get_node_id()  # the events wait here: a worker node may die
    buffer = ray.remote(num_cpus=0, max_restarts=0)(_EventBuffer).options(
        scheduling_strategy=NodeAffinitySchedulingStrategy(here, soft=True)).remote()
    remote_episode = ray.remote(num_cpus=RAY_EPISODE_CPUS, max_retries=0)(_ray_episode)
    versions = distribution_versions()
    node_of: dict[int, dict] = {}

    def forward(kind: str, index: int, info: dict | None) -> None:
        if kind == "node":
            node_of[index] = info or {}
        else:
            on_event(kind, index, info)

    stop = threading.Event()
    drainer = threading.Thread(target=_drain_actor, args=(ray, buffer, forward, stop), daemon=True,
                               name="benchbot-ray-events")
    drainer.start()
    lost: dict[int, list[dict]] = {spec.index: [] for spec, _ in episodes}
    running: dict = {}

    gpu_share = ray_gpus_per_episode() if ray.cluster_resources().get("GPU", 0) > 0 else 0.0

    def submit(episode: Episode) -> None:
        task = remote_episode  # an episode on a GPU also reserves its share of one, so Ray places it by GPU
        if gpu_share and wants_gpu(episode[0].options):
            task = remote_episode.options(num_gpus=gpu_share)
        running[task.remote(episode[0], episode[1], str(run_dir), buffer, versions)] = episode

    try:
        for episode in episodes:
            submit(episode)
        while running:
            done, _ = ray.wait(list(running), num_returns=1, timeout=0.5)  # short: Ctrl-C reaches this thread
            for ref in done:
                spec, run = running.pop(ref)
                files: dict[str, bytes] = {}
                try:
                    record, files = ray.get(ref)
                except rex.RayTaskError as exc:  # the task could not even start its episode (an import, say)
                    record = new_record(spec)
                    cause = exc.cause if getattr(exc, "cause", None) is not None else exc
                    record.status, record.executor, record.node = "error", "ray", node_of.get(spec.index, {})
                    record.error = (f"on node {node_name(record.node)}: {type(cause).__name__}: "
                                    f"{_first_line(cause)}")
                except rex.RayError as exc:
                    reason = _lost_reason(exc)
                    if reason:  # its node or worker died: the episode was lost, not failed
                        what = {"node": node_of.get(spec.index, {}), "error": reason}
                        lost[spec.index].append(what)
                        forward("end", spec.index, None)
                        again = len(lost[spec.index]) <= lost_retries
                        forward("lost", spec.index, {**what, "again": again})
                        if again:  # elsewhere: Ray schedules nothing on a dead node
                            submit((spec, run))
                            continue
                    record = new_record(spec)
                    record.status, record.executor = "error", "ray"
                    if reason:
                        record.node = what["node"]
                        record.error = (f"lost {len(lost[spec.index])} times with its Ray node or worker (last: "
                                        f"{reason} on node {node_name(what['node'])})")
                    else:  # Ray could not run it at all (its runtime environment, say): it would fail anywhere
                        record.error = f"Ray could not run the episode: {type(exc).__name__}: {_first_line(exc)}"
                if files:
                    problem = _unpack(run_dir, spec, files)
                    if problem:
                        record.status, record.error = "error", problem
                record.lost = lost[spec.index]
                record.attempts = 1 + len(record.lost)
                forward("end", spec.index, None)  # in case the episode's own end is still on its way
                on_record(record)
    except BaseException:
        for ref in running:  # stop the episodes still running (their solutions too) before disconnecting
            try:
                ray.cancel(ref)
            except Exception:  # noqa: BLE001
                pass
        if running:
            ray.wait(list(running), num_returns=len(running), timeout=STOP_WAIT_S)
        raise
    finally:
        stop.set()
        drainer.join()
        try:
            ray.kill(buffer)
        except Exception:  # noqa: BLE001 - gone with its node or the cluster
            pass

