"""``benchbot run``: serve one task/robot/environment on 127.0.0.1 (by default) until Ctrl-C, episode after
episode: each new client's start resets the episode."""

from __future__ import annotations

import errno
import secrets
import shutil
import socket
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Optional

import typer

from benchbot.cli.common import backend_options, err, handle_errors, registry, showing_stages, writing
from benchbot.cli.options import at_most, check_count
from benchbot.core.errors import UsageError
from benchbot.core.limits import DEFAULT_ACTION_TIMEOUT_S, MAX_SEED
from benchbot.protocol.shared_frames import is_loopback

DEFAULT_TASK = "semantic_slam:passive:ground_truth"
DEFAULT_ROBOT = "carter"
#: Connections the reserved port queues while the backend starts (uvicorn's default).
LISTEN_BACKLOG = 2048


def register(app: typer.Typer) -> None:
    @app.command("run")
    @handle_errors
    def run(
        env: str = typer.Option(..., "--env", "--environment", "-e", help="Environment, e.g. miniroom:1 (scene change detection: miniroom:1:2)."),
        task: str = typer.Option(DEFAULT_TASK, "--task", "-t", help="Task name (`benchbot list tasks`)."),
        robot: str = typer.Option(DEFAULT_ROBOT, "--robot", "-r", help="Robot name (`benchbot list robots`)."),
        port: int = typer.Option(10000, "--port", min=0, max=65535, help="TCP port (0: any free port)."),
        host: str = typer.Option("127.0.0.1", "--host", help="Bind address. Anything but loopback requires a token (--token, else one is generated and printed)."),
        token: Optional[str] = typer.Option(None, "--token", envvar="BENCHBOT_TOKEN", help="Clients must send it (X-BenchBot-Token header; BENCHBOT_TOKEN for the API)."),
        action_timeout: float = typer.Option(DEFAULT_ACTION_TIMEOUT_S, "--action-timeout", min=0.1, help="Seconds after which an action answers 504 (the episode stays usable)."),
        seed: int = typer.Option(0, "--seed", help=f"Seed of the scene and of sensor/odometry noise ({at_most(MAX_SEED)})."),
        arch: str = typer.Option("auto", "--arch", help="Simulator device: auto (a GPU when an NVIDIA device is present, else the CPU), cpu or gpu."),
        camera_size: Optional[str] = typer.Option(None, "--camera-size", help="Camera resolution WIDTHxHEIGHT (default: the robot's, 640x480 for carter)."),
        record: Optional[Path] = typer.Option(None, "--record", help="Record the episode as MCAP (ROS 2 messages) to this file; `benchbot replay` serves it."),
        tui: Optional[bool] = typer.Option(None, "--tui/--no-tui", help="Live view (state, pose, camera preview, log); default: when stderr is a terminal."),
        tls_cert: Optional[Path] = typer.Option(None, "--tls-cert", help="Serve HTTPS with this PEM certificate (chain); clients trust its authority through BENCHBOT_CA_FILE or the system's store."),
        tls_key: Optional[Path] = typer.Option(None, "--tls-key", help="The certificate's PEM private key (default: in the --tls-cert file)."),
        no_service: bool = typer.Option(False, "--no-service", help="Build the simulator in this process instead of the resident simulator service (which keeps Taichi, its kernels and scenes loaded between commands; BENCHBOT_SERVICE=off does the same; --record always runs in this process; docs/service.md)."),
    ) -> None:
        """Start a backend for one task, robot and environment on 127.0.0.1, validating the combination first.

        A solution then connects with `benchbot submit` (or BenchBot(supervisor_address=...)). Ctrl-C (or SIGTERM) stops it.
        """
        # every check of the input comes before the simulator is built (seconds), cheapest first
        check_count("--seed", seed, MAX_SEED)
        if token is not None and not token.strip():
            raise UsageError("--token is empty", "give a non-empty token or leave it out")
        if tls_key is not None and tls_cert is None:
            raise UsageError("--tls-key needs --tls-cert", "give the certificate with --tls-cert")
        if tls_cert is not None:
            check_tls_files(tls_cert, tls_key)
        # the server and the session are imported here, not with the module: ``benchbot --help`` (which imports
        # every command) does not load the web stack
        from benchbot.core.session import resolve_run

        options = backend_options(arch, camera_size)
        if record is not None:
            check_record_path(record)
        in_service = wants_service(no_service, record)
        live_view = sys.stderr.isatty() if tui is None else tui
        sock = reserve_port(host, port)
        try:
            reg = registry()
            spec = resolve_run(reg, task, robot, env)
            if not is_loopback(host) and not token:
                token = secrets.token_urlsafe(24)
                err.print(f"serving beyond loopback: clients must send the token [bold]{token}[/] (export BENCHBOT_TOKEN={token})")
            err.print(f"task {task} | robot {robot} | environment {env} | results format {spec.task.get('results_format') or 'none'}")
            tcp = {"host": host, "token": token, "action_timeout_s": action_timeout,
                   "tls_cert": str(tls_cert.resolve()) if tls_cert else None,
                   "tls_key": str(tls_key.resolve()) if tls_key else None}
            state_dir = Path(tempfile.mkdtemp(prefix="benchbot-live-")) if in_service and live_view else None
            served = serve_in_service(spec, sock, tcp, seed=seed, options=options,
                                      live_state=state_dir) if in_service else None
        except BaseException:
            sock.close()
            raise
        if served is None and state_dir is not None:
            shutil.rmtree(state_dir, ignore_errors=True)  # served here: the view's observers make their own
        if served is not None:
            sock.close()  # the service serves on its own descriptor of the port
            err.print(f"[green]backend ready[/] at {served.address}  (BENCHBOT_SUPERVISOR_ADDRESS={served.address}); Ctrl-C stops it")
            try:
                if state_dir is not None:
                    show_live_view(served, state_dir)
                else:
                    served.wait()  # until Ctrl-C (or the service goes away: one line)
            finally:
                served.end()  # the service closes the episode and frees the port
                if state_dir is not None:
                    shutil.rmtree(state_dir, ignore_errors=True)
            return
        serve_here(reg, spec, sock, tcp, seed=seed, options=options, record=record, tui=tui)


def wants_service(no_service: bool, record: Path | None) -> bool:
    """Whether ``benchbot run`` serves its backend through the simulator service (docs/service.md): unless
    ``--no-service`` or ``BENCHBOT_SERVICE=off``, and not when recording (the recorder observes the episode in this
    process).

    Raises:
        UsageError: ``BENCHBOT_SERVICE`` is invalid."""
    from benchbot.service import client

    return record is None and client.wanted(no_service)


def show_live_view(served, state_dir: Path) -> None:
    """The live view (:class:`benchbot.tui.run_app.RunApp`) of the episode the service serves, reading the snapshots
    the service writes to ``state_dir``, in the foreground until it is quit (q); it closes when the service stops
    serving.

    Raises:
        KeyboardInterrupt: Ctrl-C in the view. BackendError: the service went away (one line)."""
    from benchbot.tui.run_app import RunApp

    app = RunApp(state_dir, address=served.address)
    shown = threading.Event()

    def close_when_the_service_stops() -> None:
        while served.serving() and not shown.is_set():
            time.sleep(0.2)
        while not shown.is_set():  # the view may not run yet: try until it takes the request
            try:
                app.call_from_thread(app.exit)
                return
            except Exception:  # noqa: BLE001 - not running (yet, or any more)
                time.sleep(0.1)

    threading.Thread(target=close_when_the_service_stops, name="benchbot-run-view-watch", daemon=True).start()
    try:
        app.run()
    finally:
        shown.set()
    if app.interrupted:  # Ctrl-C in the view: stop as Ctrl-C without it does
        raise KeyboardInterrupt
    if not served.serving():
        served.wait()  # raises why the service stopped


def serve_in_service(spec, sock, tcp: dict, *, seed: int, options: dict, live_state: Path | None = None):
    """Have the user's simulator service (started first when none answers, said in one line) build ``spec``'s
    backend and serve it on the reserved ``sock`` with ``tcp``'s settings (:class:`ServiceEpisode`); the stages
    show as if it ran here; ``live_state``: where the service writes the live view's snapshots. None when the service runs other code or settings and is busy (said in one line): the
    caller serves it in this process.

    Raises:
        BenchbotError: the backend cannot be built, or the service cannot be started or goes away (one line)."""
    from benchbot.service import client
    from benchbot.service.episodes import ServiceEpisode

    try:
        with showing_stages():
            return ServiceEpisode(spec, seed=seed, options=options, world_seed=None, on_step=lambda info: None,
                                  on_stage=lambda event: None, say=lambda line: err.print(line, highlight=False),
                                  pool=gpu_pool(spec, options), tcp=tcp, listener=sock, live_state=live_state)
    except client.ServiceBusy as exc:
        err.print(f"{exc.message}: {exc.hint}", highlight=False)
        return None


def gpu_pool(spec, options: dict) -> dict | None:
    """``ServiceEpisode``'s ``pool`` for a backend on a GPU: a warm worker of the service's pool with this machine's
    cores on one of the visible GPUs (as ``benchbot batch`` serves a GPU episode, :mod:`benchbot.service.pool`);
    None on the CPU (the service's own backend thread)."""
    import os

    from benchbot.batch.gpus import visible_gpus, wants_gpu

    gpus = visible_gpus() if wants_gpu(options) else []
    if not gpus:
        return None
    world = repr((spec.robot.get("name"), spec.env_string, None, sorted(options.items()), "none"))
    return {"threads": os.cpu_count() or 1, "gpus": gpus, "world": world}


def serve_here(reg, spec, sock, tcp: dict, *, seed: int, options: dict, record: Path | None,
               tui: bool | None) -> None:
    """Build ``spec``'s backend in this process and serve it on the reserved ``sock`` with ``tcp``'s settings,
    recorded and/or shown live as asked, until Ctrl-C; closes ``sock``.

    Raises:
        BenchbotError: the backend or its server cannot be started."""
    from benchbot.core.session import start_service
    from benchbot.server import ServerThread, build_app

    host, token, action_timeout = tcp["host"], tcp["token"], tcp["action_timeout_s"]
    tls_cert, tls_key = tcp["tls_cert"], tcp["tls_key"]
    try:
        with showing_stages():
            service = start_service(reg, spec, seed=seed, options=options)
    except BaseException:
        sock.close()
        raise
    try:
        server = ServerThread(build_app(service, token=token, action_timeout_s=action_timeout), host=host,
                              port=sock.getsockname()[1], tls_cert=tls_cert, tls_key=tls_key, sock=sock).start()
    except BaseException:
        sock.close()
        service.close()
        raise
    err.print(f"[green]backend ready[/] at {server.address}  (BENCHBOT_SUPERVISOR_ADDRESS={server.address}); Ctrl-C stops it")
    from benchbot.tui.run_support import RunObservers

    try:
        observers = RunObservers(reg, service, spec, record=record, tui=tui, seed=seed,
                                 options=options, address=server.address)
    except BaseException:
        server.stop()
        service.close()
        raise
    try:
        observers.wait()  # the live view in the foreground, or until Ctrl-C
    finally:
        observers.close()  # finishes the recording
        server.stop()
        service.close()


def reserve_port(host: str, port: int) -> socket.socket:
    """A TCP socket bound to ``host:port`` and listening, taken before the backend is built so that a taken port is
    said at once (clients that connect meanwhile wait until the backend serves). ``port`` 0 picks a free one.

    Raises:
        UsageError: the port is in use, needs privileges, or ``host`` is not an address of this machine (one line
            naming the port and host, and the fix).
    """
    try:
        family, kind, proto, _, sockaddr = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM,
                                                              flags=socket.AI_PASSIVE)[0]
    except (socket.gaierror, UnicodeError) as exc:
        raise UsageError(f"--host {host}: not a known address ({exc})", "e.g. --host 127.0.0.1") from None
    sock = socket.socket(family, kind, proto)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as uvicorn: a port in TIME_WAIT is free
        if family == socket.AF_INET6:
            sock.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_V6ONLY, 1)
        sock.bind(sockaddr)
        sock.listen(LISTEN_BACKLOG)
    except OSError as exc:
        sock.close()
        if exc.errno == errno.EADDRINUSE:
            raise UsageError(f"port {port} on {host} is in use",
                             "--port 0 picks a free one, or stop the other backend") from None
        if exc.errno == errno.EACCES:
            raise UsageError(f"port {port} on {host} needs privileges", "use a port of 1024 or more") from None
        raise UsageError(f"cannot listen on {host}:{port} ({exc.strerror or exc})",
                         "give an address of this machine with --host (default 127.0.0.1)") from None
    return sock


def check_record_path(record: Path) -> None:
    """Make sure the recording can be written to ``record`` (its folder is created), before anything starts.

    Raises:
        UsageError: ``record`` is a folder, or no file can be written where it lies.
    """
    if record.is_dir():
        raise UsageError(f"--record {record} is a folder", "give a file, e.g. --record episode.mcap")
    with writing(record, "--record"):
        record.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=record.parent, prefix=".benchbot-record-check-"):
            pass


def check_tls_files(cert: Path, key: Path | None) -> None:
    """Load ``cert`` (and ``key``) as a server certificate would be.

    Raises:
        UsageError: a file is missing, or is not a PEM certificate and its matching private key.
    """
    import ssl

    for path in (cert, key):
        if path is not None and not path.is_file():  # ssl's FileNotFoundError does not name the file
            raise UsageError(f"--tls-cert/--tls-key: no file {path}", "give PEM files that exist")
    try:
        ssl.create_default_context(ssl.Purpose.CLIENT_AUTH).load_cert_chain(str(cert), str(key) if key else None)
    except (ssl.SSLError, OSError) as exc:
        raise UsageError(f"--tls-cert {cert}: not a PEM certificate with its private key ({exc})",
                         "give the certificate chain with --tls-cert and its key with --tls-key") from None
