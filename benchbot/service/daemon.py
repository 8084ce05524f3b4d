"""The simulator service process: ``python -m benchbot.service.daemon --key KEY`` (a command starts it through
:func:`benchbot.service.client.start`, detached, in a session of its own, its output in its log file).

It builds the registry once, then serves episodes on its Unix socket (:mod:`benchbot.service.protocol`), each on a
thread of its own, every backend on the process's one backend thread (:func:`benchbot.server.service.backend_worker`):
Taichi is initialised once, its kernels compiled once, and scenes stay shared as the simulator shares them. For an
episode it builds the backend (:func:`benchbot.core.session.start_service`) and serves it with the same app as a
command would (:func:`benchbot.server.build_app`) on a free 127.0.0.1 port and, for a sandboxed solution, on the
Unix socket the command names (in the command's private folder); it reports the backend's stages and every step to
the command, and when the command says the solution is done it closes the episode and sends its final state and
backend facts. A command that goes away (killed, Ctrl-C) has its episode closed at once.

It stops when asked (``benchbot service stop``, SIGTERM) and by itself after ``idle_s`` seconds in which it served
no episode (``BENCHBOT_SERVICE_IDLE_S``).
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import os
import signal
import socket
import sys
import threading
import time
import traceback
from pathlib import Path

from benchbot.core.errors import BenchbotError
from benchbot.service import protocol, set_resident
from benchbot.service.location import ServiceLocation, listen_private, locate, private_dir
from benchbot.service.pool import WorkerPool, serve_pooled

log = logging.getLogger("benchbot.service")

#: Seconds between two looks at the idle clock (and at a stop request) while no client connects.
POLL_S = 0.5
#: Seconds a stopping service gives its running episodes to close their servers and backends.
STOP_WAIT_S = 10.0


class ServiceDaemon:
    """The service's state: its registry, its clients and its idle clock.

    Args:
        location: its files (:func:`benchbot.service.location.locate`).
        idle_s: seconds without an episode after which it stops by itself (> 0).
        registry: the registry its episodes use (built once, before it listens).
    """

    def __init__(self, location: ServiceLocation, idle_s: float, registry) -> None:
        self.location, self.idle_s, self.registry = location, float(idle_s), registry
        self.started = time.time()
        self.stopping = threading.Event()
        self._lock = threading.Lock()
        self._episodes: dict[int, socket.socket] = {}  # running episodes: thread id -> its client's connection
        self._served = 0
        self._last_episode_end = time.monotonic()
        self.pool = WorkerPool(location.folder, location.log)

    # ---------------------------------------------------------------------------------------------- the clock
    def idle_for(self) -> float:
        """Seconds since the last episode ended (0 while one runs)."""
        with self._lock:
            return 0.0 if self._episodes else time.monotonic() - self._last_episode_end

    def status(self) -> dict:
        """``{event: "status", pid, key, started (Unix time), uptime_s, idle_s, idle_for_s, episodes_served,
        episodes_running, python, log, rss_bytes, pool (its warm workers: pid, busy, served, threads, gpu),
        pool_limit}``."""
        with self._lock:
            running, served = len(self._episodes), self._served
        return {"event": "status", "pid": os.getpid(), "key": self.location.key, "started": self.started,
                "uptime_s": round(time.time() - self.started, 1), "idle_s": self.idle_s,
                "idle_for_s": round(self.idle_for(), 1), "episodes_served": served, "episodes_running": running,
                "python": sys.executable, "log": str(self.location.log), "rss_bytes": _rss_bytes(),
                "pool": self.pool.facts(), "pool_limit": self.pool.limit}

    # ---------------------------------------------------------------------------------------------- serving
    def serve(self, listener: socket.socket) -> None:
        """Accept clients until asked to stop or idle for :attr:`idle_s`; then close the running episodes' connections
        (their commands report the service gone) and wait up to :data:`STOP_WAIT_S` for them to close."""
        listener.settimeout(POLL_S)
        while not self.stopping.is_set():
            if self.idle_for() > self.idle_s:
                log.info("idle for %.0f s (BENCHBOT_SERVICE_IDLE_S=%g): stopping", self.idle_for(), self.idle_s)
                break
            try:
                conn, _ = listener.accept()
            except socket.timeout:
                continue
            except OSError as exc:
                log.error("accept failed: %s", exc)
                time.sleep(POLL_S)
                continue
            conn.settimeout(None)
            threading.Thread(target=self._client, args=(conn,), name="benchbot-service-client", daemon=True).start()
        self.stopping.set()
        with self._lock:
            running = list(self._episodes.values())
        for conn in running:
            _shut(conn)
        deadline = time.monotonic() + STOP_WAIT_S
        while time.monotonic() < deadline:
            with self._lock:
                if not self._episodes:
                    break
            time.sleep(0.05)

    def _client(self, conn: socket.socket) -> None:
        """One client: check who it is, then answer its requests (``status``, ``stop``, ``episode``) one after
        another until it closes the connection."""
        try:
            problem = protocol.peer_problem(conn)
            if problem:
                log.warning(problem)
                return
            while True:
                try:
                    request = protocol.receive(conn)
                except protocol.ConnectionLost:
                    return  # the client is done (or went away between requests)
                if not self._answer(conn, request):
                    return
        except protocol.ConnectionLost as exc:
            log.info("a client went away: %s", exc.message)
        except Exception:  # noqa: BLE001 - a client's failure never stops the service
            log.error("a client's request failed:\n%s", traceback.format_exc())
        finally:
            conn.close()

    def _answer(self, conn: socket.socket, request: dict) -> bool:
        """Answer one request; whether the connection may carry another (not after ``stop`` or an episode)."""
        op = request.get("op")
        if op == "status":
            protocol.send(conn, self.status())
            return True
        if op == "stop":
            log.info("asked to stop (by pid %s)", protocol.peer_credentials(conn)[0])
            protocol.send(conn, {"event": "stopping", "pid": os.getpid()})
            self.stopping.set()
        elif op == "episode":
            self._episode(conn, request)
        else:
            protocol.send(conn, {"event": "error", "message": f"unknown request {op!r}", "hint": "", "exit_code": 1})
        return False

    def _episode(self, conn: socket.socket, request: dict) -> None:
        """Serve one episode to ``conn`` (:mod:`benchbot.service.protocol`'s ``episode`` request)."""
        me = threading.get_ident()
        with self._lock:
            if self.stopping.is_set():
                protocol.send(conn, error_event(BenchbotError("the simulator service is stopping",
                                                              "run the command again: a new service starts")))
                return
            self._episodes[me] = conn
        listener = None
        try:
            if request.get("tcp"):  # benchbot run: its listening socket follows the request
                listener = protocol.receive_listener(conn)
            if request.get("pool"):  # on a warm worker process of the pool (benchbot.service.pool)
                serve_pooled(self.pool, conn, request, listener)
            else:
                serve_episode(self.registry, conn, request, listener)
        finally:
            if listener is not None:
                listener.close()
            with self._lock:
                self._episodes.pop(me, None)
                self._served += 1
                self._last_episode_end = time.monotonic()


def error_event(exc: BaseException) -> dict:
    """The ``error`` message of ``exc``: a :class:`BenchbotError`'s message, hint and exit code; anything else as
    ``the simulator service failed: <type>: <text>`` (its traceback goes to the service's log)."""
    if isinstance(exc, BenchbotError):
        return {"event": "error", "message": exc.message, "hint": exc.hint, "exit_code": int(exc.exit_code)}
    return {"event": "error", "message": f"the simulator service failed: {type(exc).__name__}: {exc}",
            "hint": "its log says more (benchbot service status names it); --no-service runs in-process",
            "exit_code": 5}


class _Reporter:
    """Sends an episode's reports to its client from any thread; once the client is gone it sends nothing more."""

    def __init__(self, conn: socket.socket) -> None:
        self.conn, self.gone = conn, threading.Event()
        self._lock = threading.Lock()

    def send(self, message: dict) -> None:
        if self.gone.is_set():
            return
        try:
            with self._lock:
                protocol.send(self.conn, message)
        except protocol.ConnectionLost:
            self.gone.set()

    def step(self, info: dict) -> None:
        self.send({"event": "step", "info": info})

    def stage(self, event) -> None:
        self.send({"event": "stage", "stage": dataclasses.asdict(event)})


def episode_server(service, request: dict, listener: socket.socket | None):
    """The (not yet started) :class:`benchbot.server.ServerThread` of an episode's backend ``service``: with the
    request's ``tcp`` settings (``benchbot run``: host, token, action timeout, TLS files) on the command's
    ``listener``, else on a free 127.0.0.1 port and the request's ``unix_socket`` (a sandboxed solution's way in)."""
    from benchbot.server import ServerThread, build_app

    tcp = request.get("tcp")
    if tcp and listener is not None:
        app = build_app(service, token=tcp.get("token"), action_timeout_s=float(tcp["action_timeout_s"]))
        return ServerThread(app, host=str(tcp["host"]), port=int(listener.getsockname()[1]),
                            tls_cert=tcp.get("tls_cert"), tls_key=tcp.get("tls_key"), sock=listener)
    unix_socket = request.get("unix_socket")
    return ServerThread(build_app(service), unix_socket=Path(unix_socket) if unix_socket else None)


def serve_episode(registry, conn: socket.socket, request: dict, listener: socket.socket | None = None) -> None:
    """Build the requested episode's backend, serve it until the client says ``finish`` (or goes away), close it,
    and send the client its final state and backend facts (or the error that stopped it). ``listener``: the
    command's listening TCP socket of a ``tcp`` request (:func:`episode_server`), closed once its server stops. A
    request's ``live_state`` (a folder of the command's) gets the episode's live-view snapshots
    (:class:`benchbot.service.live_view.ServiceLiveView`)."""
    from benchbot.batch.provenance import backend_facts
    from benchbot.core.session import RunSpec, start_service

    reporter = _Reporter(conn)
    views: list = []  # the live view of a run's episode (its request's live_state folder)

    def on_step(info: dict) -> None:
        reporter.step(info)
        for view in views:
            view.step(info)

    try:
        run = RunSpec(**request["run"])
        service = start_service(registry, run, seed=int(request.get("seed", 0)), options=request.get("options") or {},
                                on_step=on_step, world_seed=request.get("world_seed"),
                                on_stage=reporter.stage)
    except BaseException as exc:  # noqa: BLE001 - the client hears why
        _log_unexpected(exc)
        reporter.send(error_event(exc))
        return
    finished: dict = {}
    try:
        if request.get("live_state"):
            from benchbot.service.live_view import ServiceLiveView

            views.append(ServiceLiveView(service, Path(request["live_state"])))
        server = episode_server(service, request, listener).start()
        try:
            reporter.send({"event": "ready", "address": server.address})
            _wait_for_finish(conn, reporter)
        finally:
            server.stop()
            if listener is not None:
                listener.close()  # the port is free before the client hears the end
        state = service.call(service.episode.state)
        finished = {"event": "finished", "state": {"step": int(state["step"]),
                                                   "is_collided": bool(state["is_collided"])},
                    "backend": backend_facts(registry, run.robot, run.environments)}
    except BaseException as exc:  # noqa: BLE001 - the client hears why
        _log_unexpected(exc)
        finished = error_event(exc)
    finally:
        for view in views:
            view.close()
        try:
            service.close()
        except BaseException as exc:  # noqa: BLE001
            _log_unexpected(exc)
            finished = error_event(exc)
    reporter.send(finished)


def _wait_for_finish(conn: socket.socket, reporter: _Reporter) -> None:
    """Block until the client sends ``{op: "finish"}``; return at once when it goes away."""
    while not reporter.gone.is_set():
        try:
            message = protocol.receive(conn)
        except protocol.ConnectionLost:
            reporter.gone.set()
            return
        if message.get("op") == "finish":
            return


def _log_unexpected(exc: BaseException) -> None:
    if isinstance(exc, BenchbotError):
        log.info("episode error: %s", exc.message)
    else:
        log.error("episode failed:\n%s", "".join(traceback.format_exception(exc)))


def _shut(conn: socket.socket) -> None:
    try:
        conn.shutdown(socket.SHUT_RDWR)
    except OSError:
        pass


def _rss_bytes() -> int:
    """This process's resident memory in bytes (0 where ``/proc`` cannot tell)."""
    try:
        with open("/proc/self/statm") as statm:
            return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def bind(location: ServiceLocation) -> socket.socket | None:
    """A listening socket at ``location.socket`` (mode 0600), replacing a stale file no service answers on; None when
    a live service already answers there."""
    private_dir(location.folder)
    path = str(location.socket)
    if os.path.exists(path):
        probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            probe.connect(path)
            return None  # another service is alive
        except OSError:
            os.unlink(path)
        finally:
            probe.close()
    return listen_private(path, backlog=64)


def _unlink_if_ours(path: Path, inode: int) -> None:
    try:
        if os.stat(path).st_ino == inode:
            os.unlink(path)
    except OSError:
        pass


def main(argv: list[str] | None = None) -> int:
    """Run the service for ``--key`` until it stops; returns the exit status (0; 1 when it could not start)."""
    parser = argparse.ArgumentParser(prog="python -m benchbot.service.daemon")
    parser.add_argument("--key", required=True, help="the installation key (benchbot.service.location)")
    parser.add_argument("--idle-s", type=float, required=True, help="stop after this many seconds without episodes")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, stream=sys.stderr,
                        format=f"%(asctime)s service[{os.getpid()}] %(levelname)s %(message)s")
    os.chdir("/")
    set_resident()
    location = locate(args.key)
    try:
        from benchbot.core.registry import get_registry

        registry = get_registry()
        listener = bind(location)
    except BenchbotError as exc:
        log.error("cannot start: %s (%s)", exc.message, exc.hint)
        return 1
    if listener is None:
        log.info("another service already answers at %s", location.socket)
        return 0
    inode = os.stat(location.socket).st_ino
    daemon = ServiceDaemon(location, args.idle_s, registry)
    signal.signal(signal.SIGTERM, lambda *_: daemon.stopping.set())
    signal.signal(signal.SIGINT, lambda *_: daemon.stopping.set())
    log.info("serving at %s (key %s, stops after %g s idle)", location.socket, location.key, args.idle_s)
    try:
        daemon.serve(listener)
    finally:
        listener.close()
        daemon.pool.close()
        _unlink_if_ours(location.socket, inode)
        log.info("stopped after %d episodes", daemon.status()["episodes_served"])
        logging.shutdown()
    return 0


if __name__ == "__main__":
    # exit without running the simulator's own teardown at exit: the service's backends are closed already
    code = main()
    sys.stderr.flush()
    os._exit(code)
