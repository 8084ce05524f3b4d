"""An episode's served backend, in this process or in the simulator service, behind one interface.

:func:`open_episode` builds the backend of a run (task, robot, scenes) with its seeds and options and serves it with
the backend server's app on a free 127.0.0.1 port (and, for a sandboxed solution, on a Unix socket): in this process
(:class:`InProcessEpisode`, as every command did before the service) or in the user's simulator service
(:class:`ServiceEpisode`, :mod:`benchbot.service.daemon`). Either way the caller gets the address to give its
solution, hears the backend's stages and every step, and after the solution :meth:`finish` gives the episode's
final state and backend facts; :meth:`close` frees it. What the solution observes is the same either way.
"""

from __future__ import annotations

import dataclasses
import socket
import threading
from pathlib import Path
from typing import Any, Callable

from benchbot.core import stages
from benchbot.core.errors import BackendError, BenchbotError
from benchbot.service import client, protocol
from benchbot.service.location import ServiceLocation, locate


@dataclasses.dataclass
class EpisodeEnd:
    """What a served episode ended with.

    Attributes:
        steps: actions executed. collided: whether the robot collided. backend: the record's ``backend`` facts
            (:func:`benchbot.batch.provenance.backend_facts`, told by the process that ran the backend).
        node: where the backend ran, for the record's ``node``: ``{"gpu": {"index", "name"}}`` when a worker of
            the service's pool pinned to a GPU served it (:mod:`benchbot.service.pool`), else ``{}``.
    """

    steps: int
    collided: bool
    backend: dict
    node: dict = dataclasses.field(default_factory=dict)


class InProcessEpisode:
    """The backend built in this process (:func:`benchbot.core.session.start_service`), recorded when ``recording``
    is given (:func:`benchbot.plugins.recorder.attach_recorder`), served by a :class:`benchbot.server.ServerThread`.

    Raises:
        BenchbotError: the backend, its first scene, the recorder or the server cannot be started (what was started
            is closed again)."""

    def __init__(self, registry, run, *, seed: int, options: dict, world_seed: int | None,
                 on_step: Callable[[dict], None], on_stage: Callable[[Any], None],
                 unix_socket: Path | None = None, recording: Path | None = None) -> None:
        from benchbot.core.session import start_service
        from benchbot.server import ServerThread, build_app

        self.registry, self.run = registry, run
        self.recorder = self.server = None
        self._stopped = self._closed = False
        self.service = start_service(registry, run, seed=seed, options=options, on_step=on_step,
                                     world_seed=world_seed, on_stage=on_stage)
        try:
            if recording is not None:
                from benchbot.plugins.recorder import attach_recorder

                self.recorder = attach_recorder(registry, self.service, run, recording, seed=seed, options=options)
            self.server = ServerThread(build_app(self.service), unix_socket=unix_socket)
            self.server.start()
        except BaseException:
            self._stopped = self.server is None or not self.server.thread.is_alive()
            self.close()
            raise

    @property
    def address(self) -> str:
        """``http://127.0.0.1:<port>/``: where a solution that is not sandboxed reaches the backend."""
        return self.server.address

    def _stop_server(self) -> None:
        if not self._stopped and self.server is not None:
            self._stopped = True
            self.server.stop()

    def finish(self) -> EpisodeEnd:
        """Stop serving and tell the episode's final state and backend facts."""
        from benchbot.batch.provenance import backend_facts

        self._stop_server()
        state = self.service.call(self.service.episode.state)
        return EpisodeEnd(int(state["step"]), bool(state["is_collided"]),
                          backend_facts(self.registry, self.run.robot, self.run.environments))

    def close(self) -> None:
        """Stop serving (if still serving), finish the recording, close the backend. Once; later calls do nothing.

        Raises:
            whatever the recorder's or the backend's close raises (the backend closes either way)."""
        if self._closed:
            return
        self._closed = True
        self._stop_server()
        try:
            if self.recorder is not None:
                from benchbot.plugins.recorder import detach_recorder

                detach_recorder(self.registry, self.service, self.recorder)
        finally:
            self.service.close()


def lost_error(location: ServiceLocation, when: str) -> BackendError:
    """The one-line error of a service that went away ``when`` (``during the episode``, ``as the episode
    started``)."""
    return BackendError(f"the simulator service stopped {when} (killed or crashed; its log: {location.log})",
                        client.IN_PROCESS_HINT)


class ServiceEpisode:
    """The backend built and served by the user's simulator service (started first when none answers,
    :func:`benchbot.service.client.start`; ``say`` hears the one line saying so). Stages and steps arrive on a reader
    thread of this process and go to ``on_stage`` (and this process's stage listeners) and ``on_step``.

    ``tcp`` (``{host, token, action_timeout_s, tls_cert, tls_key}``, TLS files as absolute paths) with ``listener``
    (a listening TCP socket of this process, ``benchbot run``'s reserved port): the service serves the backend on
    that socket, passed to it (:func:`benchbot.service.protocol.send_listener`), with those settings, as
    ``benchbot run`` would in its own process; the caller may close its ``listener`` once this returns.
    ``live_state``: a folder where the service writes the episode's live-view snapshots (``benchbot run``'s view,
    :mod:`benchbot.service.live_view`).

    Raises:
        BenchbotError: what the service reports (a bad spec, a backend that cannot start), or
            :class:`~benchbot.core.errors.BackendError` when it cannot be started or goes away before the backend
            is ready (one line with its log's path)."""

    def __init__(self, run, *, seed: int, options: dict, world_seed: int | None,
                 on_step: Callable[[dict], None], on_stage: Callable[[Any], None],
                 unix_socket: Path | None = None, location: ServiceLocation | None = None,
                 say: Callable[[str], None] | None = None, pool: dict | None = None, tcp: dict | None = None,
                 listener: socket.socket | None = None, live_state: Path | None = None) -> None:
        self.location = location or locate()
        self.node: dict = {}
        self.on_step, self._on_stage = on_step, on_stage
        self._end: dict | None = None
        started: list[stages.StageEvent] = []

        def starting() -> None:
            started.append(stages.StageEvent("start", "starting the simulator service", "it stays up between commands"))
            self.on_stage(started[0])

        self.sock = client.start(self.location, say=say, starting=starting)
        if started:
            self.on_stage(stages.StageEvent("end", started[0].name, started[0].detail))
        try:
            protocol.send(self.sock, {"op": "episode", "run": dataclasses.asdict(run), "seed": seed,
                                      "options": options, "world_seed": world_seed,
                                      "unix_socket": str(unix_socket) if unix_socket is not None else None,
                                      "pool": pool, "tcp": tcp if listener is not None else None,
                                      "live_state": str(live_state) if live_state is not None else None})
            if tcp is not None and listener is not None:
                protocol.send_listener(self.sock, listener)
            self.address = self._until_ready()
        except protocol.ConnectionLost:
            self.close()
            raise lost_error(self.location, "as the episode started") from None
        except BaseException:
            self.close()
            raise
        self._reader = threading.Thread(target=self._read, name="benchbot-service-episode", daemon=True)
        self._reader.start()

    def on_stage(self, event: stages.StageEvent) -> None:
        """A stage of the backend's start, in the service: to ``on_stage`` and to this process's stage listeners
        (:func:`benchbot.core.stages.relay`), as if the work ran here."""
        self._on_stage(event)
        stages.relay(event)

    def _until_ready(self) -> str:
        """Read the service's stage reports until the backend is served; its address."""
        while True:
            message = protocol.receive(self.sock)
            event = message.get("event")
            if event == "stage":
                self.on_stage(stages.StageEvent(**message["stage"]))
            elif event == "ready":
                self.node = dict(message.get("node") or {})
                return str(message["address"])
            elif event == "error":
                raise client.error_from(message)

    def _read(self) -> None:
        """Hand every step to ``on_step`` until the episode's end (or the connection's)."""
        try:
            while True:
                message = protocol.receive(self.sock)
                event = message.get("event")
                if event == "step":
                    self.on_step(message["info"])
                elif event == "stage":
                    self.on_stage(stages.StageEvent(**message["stage"]))
                elif event in ("finished", "error"):
                    self._end = message
                    return
        except protocol.ConnectionLost:
            return

    def finish(self) -> EpisodeEnd:
        """Tell the service the solution is done; wait for the episode's final state and backend facts.

        Raises:
            BackendError: the service went away during the episode (one line with its log's path), or reported
                that closing the episode failed."""
        try:
            protocol.send(self.sock, {"op": "finish"})
        except protocol.ConnectionLost:
            pass  # the reader has seen (or will see) the end
        self._reader.join()
        end = self._end
        if end is None:
            raise lost_error(self.location, "during the episode")
        if end.get("event") == "error":
            raise client.error_from(end)
        state = end.get("state") or {}
        return EpisodeEnd(int(state.get("step", 0)), bool(state.get("is_collided", False)), end.get("backend") or {},
                          self.node)

    def serving(self) -> bool:
        """Whether the service still serves the episode (its reports still come)."""
        return self._reader.is_alive()

    def wait(self) -> None:
        """Block while the service serves the episode (``benchbot run``: until Ctrl-C raises KeyboardInterrupt here).

        Raises:
            BackendError: the service went away or ended the episode (one line with its log's path), or reported
                the error that ended it."""
        while self._reader.is_alive():
            self._reader.join(0.5)
        self.finish()
        raise lost_error(self.location, "during the episode")

    def end(self) -> None:
        """Finish the episode, ignoring how it ended, and close the connection: once this returns the service has
        closed the backend and its server (the port is free again). Never raises a :class:`BenchbotError`."""
        try:
            self.finish()
        except BenchbotError:
            pass
        finally:
            self.close()

    def close(self) -> None:
        """Close the connection (the service closes the episode if it still runs). Never raises."""
        try:
            self.sock.close()
        except OSError:
            pass


def open_episode(registry, run, *, in_service: bool, seed: int, options: dict, world_seed: int | None,
                 on_step: Callable[[dict], None], on_stage: Callable[[Any], None],
                 unix_socket: Path | None = None, recording: Path | None = None,
                 say: Callable[[str], None] | None = None, pool: dict | None = None,
                 location: ServiceLocation | None = None):
    """The served backend of ``run``: in the simulator service when ``in_service`` and nothing needs it in this
    process (a recording does: its recorder observes the episode here), else in this process.

    ``pool``: ``{"threads", "gpus"}``: the service serves it on a warm worker process of its pool with that many
    Taichi threads on one of those GPUs (:mod:`benchbot.service.pool`; ``benchbot batch --workers N`` and GPU
    batches); None: on the service's own backend thread. ``location``: the service's, found once by the caller
    (None: found here, :func:`benchbot.service.location.locate`).

    The service serving another installation or other settings and busy with an episode
    (:class:`benchbot.service.client.ServiceBusy`) leaves the episode to this process.

    Returns:
        an :class:`InProcessEpisode` or a :class:`ServiceEpisode` (``address``, ``finish()``, ``close()``).

    Raises:
        BenchbotError: the backend cannot be built or served (see the two classes)."""
    if in_service and recording is None:
        try:
            return ServiceEpisode(run, seed=seed, options=options, world_seed=world_seed, on_step=on_step,
                                  on_stage=on_stage, unix_socket=unix_socket, say=say, pool=pool, location=location)
        except client.ServiceBusy:
            pass
    return InProcessEpisode(registry, run, seed=seed, options=options, world_seed=world_seed, on_step=on_step,
                            on_stage=on_stage, unix_socket=unix_socket, recording=recording)
