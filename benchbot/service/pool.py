"""The service's pool of warm simulator workers: what serves ``benchbot batch --workers N`` (and every batch on a GPU).

Each worker is a process of its own (:mod:`benchbot.service.worker`: Taichi needs one thread per process, so N
episodes at once need N processes), started on demand and kept while the service lives: a second sweep finds
Taichi initialised in each, its kernels compiled and its last scenes loaded. A worker has a profile: its Taichi
threads (``BENCHBOT_TAICHI_THREADS``, the cores / workers share a batch's own workers get) and its GPU
(``CUDA_VISIBLE_DEVICES`` set to one GPU's UUID before Taichi starts, :mod:`benchbot.batch.gpus`); an episode is
served by a free worker of its profile. There are at most :data:`POOL_LIMIT` workers; a request finding none free
starts one when there is room, else replaces an idle worker of another profile, else waits for one to be free. A
worker that dies (killed, a crash) is dropped: its episode ends with a one-line error and the next starts a fresh
one.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from benchbot.service import protocol

#: The most workers a service keeps: twice the machine's cores, at least 4, at most 64 (docs/service.md).
POOL_LIMIT = max(4, min(64, 2 * (os.cpu_count() or 1)))
#: Seconds a worker is given to exit after SIGTERM before it is killed.
STOP_WAIT_S = 5.0
#: Seconds a new worker may take to accept the service's connection (it binds its socket first thing).
CONNECT_TIMEOUT_S = 60.0
#: Worlds remembered per worker: as many scenes as a resident simulator keeps loaded
#: (``benchbot_sim_taichi.loaded_scenes`` keeps three).
WORLDS_KEPT = 3
#: Thread-count variables a worker gets (unless the service's environment sets them), as a batch's own workers do
#: (:data:`benchbot.batch.executors.THREAD_VARIABLES`).
THREAD_VARIABLES = ("BENCHBOT_TAICHI_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


@dataclass
class PoolWorker:
    """One warm worker process.

    Attributes:
        process: the worker (``python -m benchbot.service.worker``). socket: where it listens.
        threads: its Taichi threads. gpu: its GPU (``{"index", "name", "uuid"}``) or None (CPU episodes).
        busy: serving an episode now. served: episodes it served. worlds: the worlds (robot, environment, world
            seed, options) of its last :data:`WORLDS_KEPT` episodes, the latest first: the scenes it likely keeps
            loaded.
    """

    process: subprocess.Popen
    socket: Path
    threads: int
    gpu: dict | None
    busy: bool = False
    served: int = 0
    started: float = field(default_factory=time.time)
    worlds: list = field(default_factory=list)  # the worlds of its last episodes, the latest first

    def matches(self, threads: int, gpus: list[dict]) -> bool:
        """Whether it may serve an episode wanting ``threads`` Taichi threads on one of ``gpus`` (``[]``: the
        CPU)."""
        if self.threads != threads:
            return False
        return self.gpu is None if not gpus else self.gpu is not None and self.gpu["uuid"] in {g["uuid"] for g in gpus}

    def alive(self) -> bool:
        """Whether the worker's process is still running (it has not exited nor been killed)."""
        return self.process.poll() is None

    def stop(self) -> None:
        """SIGTERM, then SIGKILL after :data:`STOP_WAIT_S`; its socket file removed."""
        if self.alive():
            self.process.terminate()
            try:
                self.process.wait(STOP_WAIT_S)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self.socket.unlink(missing_ok=True)

    def facts(self) -> dict:
        """``{pid, busy, served, threads, gpu}`` for ``benchbot service status``."""
        return {"pid": self.process.pid, "busy": self.busy, "served": self.served, "threads": self.threads,
                "gpu": {"index": self.gpu["index"], "name": self.gpu["name"]} if self.gpu else None}


class WorkerPool:
    """The service's workers (module docstring). Thread-safe: each of the service's clients leases from it.

    Args:
        folder: the service's private folder (the workers' sockets go there). log: the file their output is
            appended to (the service's log). limit: the most workers kept.
    """

    def __init__(self, folder: Path, log: Path, limit: int = POOL_LIMIT) -> None:
        self.folder, self.log, self.limit = Path(folder), Path(log), int(limit)
        self._workers: list[PoolWorker] = []
        self._cond = threading.Condition()
        self._count = 0
        self._closed = False

    def _spawn(self, threads: int, gpu: dict | None) -> PoolWorker:
        """Start a worker of that profile (called with the lock held: starting a process takes milliseconds)."""
        from benchbot.batch.gpus import pin

        self._count += 1
        path = self.folder / f"worker-{os.getpid()}-{self._count}.sock"  # at most location.LONGEST_SOCKET_NAME long
        env = dict(os.environ)
        for name in THREAD_VARIABLES:
            env.setdefault(name, str(threads))
        pin(gpu, env)
        with open(self.log, "ab") as log:
            process = subprocess.Popen(
                [sys.executable, "-m", "benchbot.service.worker", "--socket", str(path), "--parent", str(os.getpid())],
                stdin=subprocess.DEVNULL, stdout=log, stderr=log, close_fds=True, cwd="/", env=env)
        worker = PoolWorker(process, path, threads, gpu)
        self._workers.append(worker)
        return worker

    def _least_used_gpu(self, gpus: list[dict], workers: list[PoolWorker], busy_only: bool) -> str | None:
        """The UUID of the GPU of ``gpus`` with the fewest of ``workers`` (busy ones only, or all) on it."""
        if not gpus:
            return None
        load = {g["uuid"]: 0 for g in gpus}
        for w in workers:
            if w.gpu is not None and w.gpu["uuid"] in load and (w.busy or not busy_only):
                load[w.gpu["uuid"]] += 1
        return min(load, key=lambda uuid: (load[uuid], list(load).index(uuid)))

    def lease(self, threads: int, gpus: list[dict], timeout_s: float | None = None, world: str = "") -> PoolWorker:
        """A worker of the profile (``threads``, one of ``gpus``; ``[]`` for the CPU), marked busy: a free one on
        the GPU least busy (of those, one that served ``world`` lately, whose scene it likely keeps loaded), else a
        new one (on the GPU with the fewest workers), waiting while the pool is full of busy workers.

        Raises:
            TimeoutError: none was free within ``timeout_s`` seconds (None: wait as long as it takes).
            RuntimeError: the pool is closed (the service is stopping)."""
        deadline = None if timeout_s is None else time.monotonic() + timeout_s
        with self._cond:
            while True:
                if self._closed:
                    raise RuntimeError("the simulator service is stopping")
                self._workers = [w for w in self._workers if w.alive() or w.busy]
                mine = [w for w in self._workers if w.matches(threads, gpus)]
                free = [w for w in mine if not w.busy]
                if free:
                    best = self._least_used_gpu(gpus, mine, busy_only=True)
                    there = [w for w in free if w.gpu is not None and w.gpu["uuid"] == best] or free
                    worker = min(there, key=lambda w: w.worlds.index(world) if world in w.worlds else WORLDS_KEPT)
                else:
                    idle_other = [w for w in self._workers if not w.busy and not w.matches(threads, gpus)]
                    if len(self._workers) >= self.limit and idle_other:
                        idle_other[0].stop()
                        self._workers.remove(idle_other[0])
                    if len(self._workers) < self.limit:
                        uuid = self._least_used_gpu(gpus, mine, busy_only=False)
                        worker = self._spawn(threads, next((g for g in gpus if g["uuid"] == uuid), None))
                    else:
                        left = None if deadline is None else deadline - time.monotonic()
                        if left is not None and left <= 0:
                            raise TimeoutError("no simulator worker was free")
                        self._cond.wait(0.5 if left is None else min(0.5, left))
                        continue
                worker.busy = True
                if world:
                    worker.worlds = [world, *[w for w in worker.worlds if w != world]][:WORLDS_KEPT]
                return worker

    def release(self, worker: PoolWorker, *, broken: bool = False) -> None:
        """Give ``worker`` back after an episode; ``broken`` (it stopped answering mid-episode): stop and drop it,
        so the next episode gets a fresh one."""
        with self._cond:
            worker.busy = False
            worker.served += 1
            if broken or not worker.alive():
                worker.stop()
                if worker in self._workers:
                    self._workers.remove(worker)
            self._cond.notify_all()

    def facts(self) -> list[dict]:
        """Every worker's :meth:`PoolWorker.facts`."""
        with self._cond:
            return [w.facts() for w in self._workers if w.alive()]

    def close(self) -> None:
        """Stop every worker (the service is stopping); later leases fail."""
        with self._cond:
            self._closed = True
            workers, self._workers = list(self._workers), []
            self._cond.notify_all()
        for worker in workers:
            worker.stop()


def _connect(worker: PoolWorker) -> socket.socket | None:
    """A connection to ``worker``'s socket, waiting (up to :data:`CONNECT_TIMEOUT_S`) for a new worker to bind it;
    None when the worker exited first or never listened."""
    deadline = time.monotonic() + CONNECT_TIMEOUT_S
    while worker.alive() and time.monotonic() < deadline:
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            sock.connect(str(worker.socket))
            return sock
        except OSError:
            sock.close()
            time.sleep(0.02)
    return None


def _lives_on(worker: PoolWorker, wait_s: float = 0.5) -> bool:
    """Whether ``worker``, which ended an episode without its end (its client left, or it crashed), is still
    running after ``wait_s`` seconds: a crashed one has exited by then."""
    try:
        worker.process.wait(wait_s)
    except subprocess.TimeoutExpired:
        return True
    return False


def worker_lost_error(worker: PoolWorker, log: Path) -> dict:
    """The ``error`` message of an episode whose worker went away (killed, a crash): one line with the log's path."""
    from benchbot.service.client import IN_PROCESS_HINT

    return {"event": "error", "exit_code": 4, "hint": IN_PROCESS_HINT,
            "message": f"the simulator service's worker (pid {worker.process.pid}) stopped during the episode (killed "
                       f"or crashed; its log: {log})"}


def serve_pooled(pool: WorkerPool, conn: socket.socket, request: dict, listener: socket.socket | None = None) -> None:
    """Serve ``request`` (an ``episode`` with ``pool: {threads, gpus, world}``) on a worker of ``pool``: lease one,
    pass the request on, and relay its messages (stages, ready, steps, the end) to the client and the client's
    ``finish`` to it. The ``ready`` message gets ``node`` (the worker's GPU, :func:`benchbot.batch.gpus.recorded`).
    A worker that goes away before the episode's end is dropped and the client told in one line
    (:func:`worker_lost_error`); a client that goes away has its episode closed by the worker (its connection
    shut). ``listener``: the command's listening TCP socket of a ``tcp`` request (``benchbot run``), passed on to
    the worker (and closed here once passed on)."""
    from benchbot.batch.gpus import recorded

    wanted = request.get("pool") or {}
    worker = pool.lease(int(wanted.get("threads") or 1), list(wanted.get("gpus") or []),
                        world=str(wanted.get("world") or ""))
    upstream = _connect(worker)
    if upstream is None:
        pool.release(worker, broken=True)
        protocol.send(conn, worker_lost_error(worker, pool.log))
        return
    ended = threading.Event()

    def down() -> None:  # the worker's messages to the client, until the episode's end
        try:
            while True:
                message = protocol.receive(upstream)
                if message.get("event") == "ready":
                    message["node"] = recorded(worker.gpu)
                if message.get("event") in ("finished", "error"):
                    ended.set()
                protocol.send(conn, message)
                if ended.is_set():
                    return
        except protocol.ConnectionLost:
            return

    reader = threading.Thread(target=down, name="benchbot-pool-relay", daemon=True)
    try:
        protocol.send(upstream, {k: v for k, v in request.items() if k != "pool"})
        if listener is not None:
            protocol.send_listener(upstream, listener)
            listener.close()  # the worker has its own: the port is freed when the worker's server stops
        reader.start()
        while reader.is_alive():  # the client's messages (its "finish") to the worker
            message = protocol.receive(conn)
            protocol.send(upstream, message)
    except protocol.ConnectionLost:
        pass
    finally:
        try:
            upstream.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        reader.join()
        upstream.close()
        lost = not ended.is_set() and not _lives_on(worker)
        if lost:
            try:
                protocol.send(conn, worker_lost_error(worker, pool.log))
            except protocol.ConnectionLost:
                pass
        pool.release(worker, broken=lost)
