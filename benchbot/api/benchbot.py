"""The BenchBot client: talks to a backend (``benchbot run``/``batch``) over HTTP, or to one in the same process.

One step is one request (``POST /native/step``, MessagePack with raw arrays); configuration and scene changes use
the original supervisor's JSON routes. Every request has a timeout. The transport is pluggable:
:class:`HttpTransport` (the default) or :class:`InProcessTransport` (``BenchBot(backend=service)`` or
:func:`InProcessBenchBot`), which calls the backend's operations directly, without HTTP or serialisation, and gives
the same results.

Address: the ``supervisor_address`` argument, else ``$BENCHBOT_SUPERVISOR_ADDRESS`` (set by ``benchbot submit`` and
``benchbot batch``), else ``http://127.0.0.1:10000/``; ``https://`` addresses trust the authorities in
``$BENCHBOT_CA_FILE``, else the system's. Token (for backends served beyond loopback):
``$BENCHBOT_TOKEN``, sent as the ``X-BenchBot-Token`` header. Results location: ``$BENCHBOT_RESULT_LOCATION``, else
the original's ``/tmp/benchbot_result``.
"""

from __future__ import annotations

import atexit
import enum
import json
import http.client
import os
import secrets
import ssl
import threading
import urllib.parse
import time
import weakref
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

import httpx
import numpy as np

from benchbot.core import settings, shared_frames, wire
from benchbot.core.errors import BenchbotError

if TYPE_CHECKING:
    from benchbot.core.server import BackendService

RESULT_LOCATION = settings.get("BENCHBOT_RESULT_LOCATION")
DEFAULT_ADDRESS = settings.default("BENCHBOT_SUPERVISOR_ADDRESS")
TOKEN_HEADER = "X-BenchBot-Token"
#: The header naming this client to the backend (one client owns an episode at a time: docs/protocol.md).
CLIENT_HEADER = "X-BenchBot-Client"


class ActionResult(enum.Enum):
    """Outcome of an action: ``SUCCESS`` (ready for the next), ``FINISHED`` (passive trajectory used up),
    ``COLLISION`` (the robot collided; no more actions). Values are plain ints (the original's were 1-tuples)."""

    SUCCESS = 0
    FINISHED = 1
    COLLISION = 2


def tls_context(address: str, ca_file: str | None = None) -> ssl.SSLContext | None:
    """The TLS context a client uses for ``address``: None for ``http://``; for ``https://`` one that trusts the
    certificate authorities in ``ca_file``, else in ``$BENCHBOT_CA_FILE``, else the system's.

    Raises:
        ValueError: the authorities' file is missing or holds no PEM certificate (the message names it).
    """
    if urllib.parse.urlsplit(address).scheme != "https":
        return None
    source, path = ("ca_file", ca_file) if ca_file else ("BENCHBOT_CA_FILE", settings.get("BENCHBOT_CA_FILE"))
    try:
        return ssl.create_default_context(cafile=path)
    except (OSError, ssl.SSLError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
        raise ValueError(f"{source}={path} cannot be used as certificate authorities ({reason})") from None


class HttpTransport:
    """The client's HTTP transport (httpx, keep-alive, per-request timeouts).

    Args:
        address: ``http://host:port/``.
        timeout_s: per-request read timeout in seconds (an action may take this long); connect timeout 5 s.
        token: sent as ``X-BenchBot-Token`` when set.
        event_hooks: httpx event hooks (e.g. to count requests).
        shared_memory: receive a step's large arrays through a shared-memory file instead of the HTTP reply
            (:mod:`benchbot.core.shared_frames`; same results, fewer copies). ``None`` (default): when the backend
            is on loopback and ``/dev/shm`` is usable, unless ``$BENCHBOT_SHARED_MEMORY=0``. If this process cannot
            map the backend's segment (e.g. it runs in another container), the transport turns the path off and
            carries on inline; :attr:`shared_memory_error` says why.
        ca_file: for ``https://`` addresses (a backend behind a TLS proxy, or ``benchbot run --tls-cert``): a PEM
            file of the certificate authorities to trust, else ``$BENCHBOT_CA_FILE``, else the system's.

    Raises:
        ValueError: the address is not ``http://`` or ``https://``, or the authorities' file cannot be used.
    """

    def __init__(self, address: str, timeout_s: float = 120.0, token: str | None = None,
                 event_hooks: dict | None = None, shared_memory: bool | None = None,
                 ca_file: str | None = None) -> None:
        self.address = address
        self.timeout_s = timeout_s
        self.headers = {TOKEN_HEADER: token} if token else {}
        # the episode is this client's until close() releases it; a solution of several processes or connections
        # names itself once with BENCHBOT_CLIENT_ID (8-128 of A-Z a-z 0-9 _ . : -)
        self.client_id = settings.get("BENCHBOT_CLIENT_ID") or secrets.token_hex(16)
        self.headers[CLIENT_HEADER] = self.client_id
        url = urllib.parse.urlsplit(address)
        if url.scheme not in ("http", "https"):
            raise ValueError(f"backend address {address!r} must start with http:// or https://")
        self._tls = tls_context(address, ca_file)
        self.http = httpx.Client(base_url=address, timeout=httpx.Timeout(timeout_s, connect=5.0), headers=self.headers,
                                 event_hooks=event_hooks or {}, verify=self._tls or True)
        self.event_hooks = event_hooks or {}
        self._host, self._port = url.hostname or "127.0.0.1", url.port or (443 if self._tls else 80)
        self._base_path = url.path.rstrip("/")
        self._local = threading.local()
        if shared_memory is None:
            shared_memory = shared_frames.is_loopback(self._host) and shared_frames.available()
        self.shared_memory = bool(shared_memory)
        self.shared_memory_error: str | None = None
        self._mappings: list[shared_frames.ClientMapping] = []  # every thread's, to let go of them on close
        self._missed_maps = 0  # announced segments gone before this client could map them, in a row
        self._closed = False
        atexit.register(_release_at_exit, weakref.ref(self))  # a solution ended by Ctrl-C frees its episode too

    def _shm_offer(self) -> dict:
        """This thread's ``shm`` field: its client id (one segment per thread, as requests of two threads may
        overlap) and the segment it has mapped."""
        local = self._local
        if getattr(local, "shm_client", None) is None:
            local.shm_client, local.mapping = secrets.token_hex(16), None
        mapping = local.mapping
        return {"client": local.shm_client, "segment": mapping.name if mapping else None,
                "slot": mapping.free_slot() if mapping else 0}

    def _map(self, announced: Any) -> None:
        """Map the segment a reply announced (``shm_segment``), replacing this thread's (arrays read from the old
        one stay valid: :meth:`ClientMapping.close <benchbot.core.shared_frames.ClientMapping.close>`). If that
        fails, the backend cannot share memory with this process: turn the path off. A segment missing from
        ``/dev/shm`` may instead have been evicted by the backend (more clients than it keeps segments) between
        its reply and this call: the next step asks for a new one, up to
        :data:`~benchbot.core.shared_frames.MAP_ATTEMPTS` misses in a row."""
        old = self._local.mapping
        try:
            self._local.mapping = shared_frames.ClientMapping(announced.get("name"), announced.get("size"),
                                                              announced.get("slots", 1))
            self._mappings.append(self._local.mapping)
            self._missed_maps = 0
        except (OSError, BenchbotError, AttributeError) as exc:
            self._local.mapping = None
            self._missed_maps += 1
            if not isinstance(exc, FileNotFoundError) or self._missed_maps >= shared_frames.MAP_ATTEMPTS:
                self.shared_memory = False
                self.shared_memory_error = f"cannot map the backend's segment: {exc}"
        if old is not None:
            old.close()
            self._mappings.remove(old)

    def _check_open(self, route: str) -> None:
        if self._closed:
            raise ConnectionError(f"cannot send /{route}: this connection to {self.address} was closed "
                                  "(make a new BenchBot)")

    def _request(self, route: str, *, json_body: dict | None = None, content: bytes | None = None) -> httpx.Response:
        self._check_open(route)
        try:
            if content is not None:
                reply = self.http.post(route, content=content, headers={"content-type": wire.MSGPACK_TYPE})
            else:
                reply = self.http.post(route, json=json_body or {})
        except httpx.HTTPError as exc:
            raise ConnectionError(f"communication with the BenchBot backend at {self.address} failed on /{route}: {exc}") from None
        if reply.status_code >= 300:
            try:
                err = reply.json()
                detail = f"{err.get('error')} ({err.get('hint')})" if err.get("hint") else err.get("error")
            except Exception:
                detail = reply.text[:200]
            if reply.status_code == 409:
                raise ValueError(detail)
            raise ConnectionError(f"BenchBot backend refused /{route} ({reply.status_code}): {detail}")
        return reply

    def ping(self) -> bool:
        """True when the backend answers ``GET /``."""
        try:
            self.http.get("", timeout=2.0).raise_for_status()
            return True
        except httpx.HTTPError:
            return False

    def get(self, route: str, body: dict | None = None) -> Any:
        """The JSON reply of a JSON route (``config/...``, ``robot/...``, ``results_functions/...``)."""
        return self._request(route, json_body=body).json()

    def _post_binary(self, route: str, body: bytes) -> tuple[int, bytes]:
        """POST ``body`` on a kept-alive :mod:`http.client` connection (per thread; TLS for ``https://``): for
        multi-megabyte replies it is several times faster than httpx. Connect timeout 5 s, then ``timeout_s`` per
        socket operation."""
        headers = {"content-type": wire.MSGPACK_TYPE, **self.headers}
        for hook in self.event_hooks.get("request", []):
            hook(httpx.Request("POST", self.address + route, headers=headers))
        for attempt in (0, 1):
            conn = getattr(self._local, "conn", None)
            reused = conn is not None
            if conn is None:
                if self._tls is not None:
                    conn = http.client.HTTPSConnection(self._host, self._port, timeout=5.0, context=self._tls)
                else:
                    conn = http.client.HTTPConnection(self._host, self._port, timeout=5.0)
                conn.connect()
                conn.sock.settimeout(self.timeout_s)
                self._local.conn = conn
            try:
                conn.request("POST", f"{self._base_path}/{route}", body=body, headers=headers)
                reply = conn.getresponse()
                return reply.status, reply.read()
            except (http.client.RemoteDisconnected, BrokenPipeError, ConnectionResetError):
                conn.close()
                self._local.conn = None
                # Only a kept-alive connection that the server closed while idle is retried (once, on a fresh
                # one): the request never reached it. A fresh connection failing is an error, never re-sent, so an
                # action cannot run twice.
                if attempt or not reused:
                    raise
            except BaseException:
                conn.close()
                self._local.conn = None
                raise
        raise AssertionError("unreachable")

    def step(self, action: str | None, args: dict, observations: list[str] | None) -> dict:
        """One native step: ``{result, observations, state}``.

        Raises:
            ValueError: the action was refused (409). ConnectionError: any other failure or timeout.
        """
        self._check_open("native/step")
        request: dict = {"action": action, "args": args}
        if observations is not None:
            request["observations"] = observations
        mapping = None
        if self.shared_memory:
            request["shm"] = self._shm_offer()
            mapping = self._local.mapping
        route = "native/step"
        try:
            status, content = self._post_binary(route, wire.pack(request))
        except (OSError, http.client.HTTPException) as exc:
            raise ConnectionError(f"communication with the BenchBot backend at {self.address} failed on /{route}: {exc!r}") from None
        if status >= 300:
            try:
                err = json.loads(content)
                detail = f"{err.get('error')} ({err.get('hint')})" if err.get("hint") else err.get("error")
            except Exception:
                detail = content[:200].decode("utf-8", "replace")
            if status == 409:
                raise ValueError(detail)
            raise ConnectionError(f"BenchBot backend refused /{route} ({status}): {detail}")
        try:
            reply = wire.unpack(content, mapping.read if mapping is not None else None)
        except BenchbotError as exc:
            raise ConnectionError(f"the BenchBot backend at {self.address} sent a malformed /{route} reply: "
                                  f"{exc.message}") from None
        if "shm_segment" in reply:
            self._map(reply.pop("shm_segment"))
        if "shm_error" in reply:
            self.shared_memory, self.shared_memory_error = False, str(reply.pop("shm_error"))
        return reply

    def close(self) -> None:
        """Close the HTTP connections and let go of the shared-memory segments (idempotent). Arrays that earlier
        steps returned stay valid: a segment is unmapped when the last array read from it is gone. Later requests
        raise ConnectionError. The episode is released (``/robot/release``) so that another client may use it at
        once rather than after the backend's idle lease."""
        if self._closed:
            return
        try:
            self.http.post("robot/release", timeout=2.0)
        except (httpx.HTTPError, OSError):  # the backend is gone: nothing to release
            pass
        self._closed = True
        self.http.close()
        for mapping in self._mappings:
            mapping.close()
        self._mappings.clear()
        conn = getattr(self._local, "conn", None)
        if conn is not None:
            conn.close()


def _release_at_exit(ref: "weakref.ref[HttpTransport]") -> None:
    transport = ref()
    if transport is not None:
        transport.close()


def _read_only(obj: Any) -> Any:
    """``obj`` (nested dicts and lists) with every NumPy array replaced by a read-only view of it."""
    if isinstance(obj, dict):
        return {k: _read_only(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_read_only(v) for v in obj]
    if isinstance(obj, np.ndarray):
        view = obj.view()
        view.flags.writeable = False
        return view
    return obj


class InProcessTransport:
    """Calls a :class:`~benchbot.core.server.BackendService` in this process: no HTTP, no serialisation; episode
    calls run on the backend thread (``service.call``). Errors are raised as the HTTP transport raises them
    (``ValueError`` for a refused action, ``ConnectionError`` otherwise).

    Args:
        service: the backend service (``benchbot.core.session.start_service``).
    """

    def __init__(self, service: "BackendService") -> None:
        from benchbot.core.server import BackendApi

        self.service = service
        self.api = BackendApi(service)
        self.address = "in-process"

    def _call(self, route: str, fn: Callable, *args: Any) -> Any:
        from benchbot.core.errors import ActionError, BenchbotError
        from benchbot.core.server import status_of

        try:
            return fn(*args)
        except ActionError as exc:
            raise ValueError(f"{exc.message} ({exc.hint})" if exc.hint else exc.message) from None
        except BenchbotError as exc:
            detail = f"{exc.message} ({exc.hint})" if exc.hint else exc.message
            raise ConnectionError(f"BenchBot backend refused /{route} ({status_of(exc)}): {detail}") from None

    def ping(self) -> bool:
        """Always True: the service is in this process."""
        return True

    def get(self, route: str, body: dict | None = None) -> Any:
        """The reply of HTTP route ``route`` (``config/...``, ``robot/<command>``, ``results_functions/[fn]``).

        Raises:
            ConnectionError: unknown route, or the backend refused the request. ValueError: an action refused.
        """
        prefix, _, rest = route.partition("/")
        if prefix == "config":
            return self._call(route, self.api.config, [k for k in rest.split("/") if k])
        if prefix == "robot":
            return self._call(route, self.service.call, self.api.robot, rest)
        if prefix == "results_functions":
            if not rest:
                return self.api.results_function_names()
            return self._call(route, self.api.results_function, rest, body or {})
        raise ConnectionError(f"BenchBot backend refused /{route} (404): unknown route")

    def step(self, action: str | None, args: dict, observations: list[str] | None) -> dict:
        """The native step (:meth:`benchbot.core.server.BackendApi.step`) on the backend thread. Its arrays come
        back as read-only views (no copy), as over HTTP: the episode keeps the same arrays for its observers
        (recorder, live view) and a backend may cache them, so a caller must not be able to write into them."""
        reply = self._call("native/step", self.service.call, self.api.step, action, args, observations)
        return {**reply, "observations": _read_only(reply["observations"])}

    def close(self) -> None:
        """Nothing to close: the service belongs to the caller."""


class BenchBot:
    """A connection to a BenchBot backend.

    Args:
        agent: the :class:`~benchbot.api.Agent` that :meth:`run` drives.
        supervisor_address: ``http://host:port/`` of the backend (see module doc for the default).
        auto_start: wait for the backend and reset the episode now.
        timeout_s: per-request timeout in seconds (an action may take this long).
        backend: a :class:`~benchbot.core.server.BackendService` in this process: use it directly instead of
            HTTP (``supervisor_address`` is then ignored).
        transport: any object with the transport methods (``ping``, ``get``, ``step``, ``close``); overrides the
            two above.

    Raises:
        ConnectionError: the backend does not answer within 60 s, or a request fails (the message names the
            route and the backend's error).
    """

    def __init__(
        self,
        agent: Any = None,
        supervisor_address: str | None = None,
        auto_start: bool = True,
        timeout_s: float = 120.0,
        backend: "BackendService | None" = None,
        transport: Any = None,
    ) -> None:
        self.agent = agent
        if transport is None and backend is not None:
            transport = InProcessTransport(backend)
        if transport is None:
            address = supervisor_address or settings.get("BENCHBOT_SUPERVISOR_ADDRESS")
            address = address if "://" in address else f"http://{address}"
            transport = HttpTransport(address.rstrip("/") + "/", timeout_s, settings.get("BENCHBOT_TOKEN"))
        self.transport = transport
        self.address = transport.address
        self._state: dict = {}
        self._config: dict | None = None
        if auto_start:
            self.start()

    def _get(self, route: str, body: dict | None = None) -> Any:
        return self.transport.get(route, body)

    # --------------------------------------------------------------------------------------- lifecycle
    def start(self, wait_s: float = 60.0) -> None:
        """Wait up to ``wait_s`` for the backend, then :meth:`reset` to scene 0 (the original restarted the
        current scene instead, docs/original-benchbot.md)."""
        deadline = time.monotonic() + wait_s
        while not self.transport.ping():
            if time.monotonic() > deadline:
                raise ConnectionError(
                    f"no BenchBot backend answered at {self.address} within {wait_s:.0f} s; "
                    "start one with `benchbot run` or set BENCHBOT_SUPERVISOR_ADDRESS"
                )
            time.sleep(0.2)
        self._get("robot/reset")
        self._state = self._get("robot/state")

    @property
    def config(self) -> dict:
        """The backend's config ``{task, results, robot, environments}``."""
        if self._config is None:
            self._config = self._get("config/")
        return self._config

    @property
    def actions(self) -> list[str]:
        """The actions allowed now (``[]`` once collided or finished)."""
        return list(self._state.get("actions", []))

    @property
    def observations(self) -> list[str]:
        """The observation names of the task."""
        return list(self.config["task"]["observations"])

    def step(self, action: str | None, **action_kwargs: Any) -> tuple[dict, ActionResult]:
        """Perform ``action`` (``None``: only observe) and return ``(observations, result)``.

        Raises:
            ValueError: the action is not allowed now (the message says why: COLLISION, FINISHED, not an action
                of the task).
        """
        if action is not None and action not in self.actions:
            why = "COLLISION" if self._state.get("is_collided") else "FINISHED" if self._state.get("is_finished") else "WRONG_ACTUATION_MODE?"
            raise ValueError(f"action '{action}' is not allowed now ({why}); allowed: {self.actions}")
        reply = self.transport.step(action, action_kwargs, None)
        self._state = reply["state"]
        return reply["observations"], ActionResult[reply["result"]]

    def reset(self) -> tuple[dict, ActionResult]:
        """Back to the first scene's start (when the robot has moved), then observe."""
        if self._state.get("is_dirty") or self._state.get("scene_number", 0) != 0 or self._state.get("is_collided"):
            self._get("robot/reset")
        return self.step(None)

    def next_scene(self) -> bool:
        """Go to the next scene; False at the last one.

        Raises:
            RuntimeError: the robot has collided.
        """
        if self._state.get("is_collided"):
            raise RuntimeError("the robot has collided: no more scenes can be visited")
        success = bool(self._get("robot/next")["next_success"])
        self._state = self._get("robot/state")
        return success

    # --------------------------------------------------------------------------------------- results
    def empty_results(self) -> dict:
        """``{task_details, environment_details, results}`` with an empty instance of the task's format."""
        config = self.config
        return {
            "task_details": config["task"],
            "environment_details": config["environments"],
            "results": self._get("results_functions/create") if config.get("results") else {},
        }

    def results_functions(self) -> dict[str, Callable]:
        """The results format's functions, run by the backend: ``{name: fn(*args, **kwargs)}``."""
        names = self._get("results_functions/")
        return {n: (lambda *a, _n=n, **k: self._get(f"results_functions/{_n}", {"args": list(a), "kwargs": k})) for n in names}

    @property
    def result_filename(self) -> str:
        """Where :meth:`run` asks the agent to save results (its folder is created)."""
        Path(RESULT_LOCATION).parent.mkdir(parents=True, exist_ok=True)
        return RESULT_LOCATION

    def run(self, agent: Any = None) -> None:
        """Drive ``agent`` (or the constructor's) through every scene, then save its results.

        For each scene: reset/observe, then ``pick_action`` → :meth:`step` until ``agent.is_done(result)``;
        then :meth:`next_scene` until it returns False; finally ``agent.save_result(result_filename, ...)``.
        """
        agent = agent or self.agent
        if agent is None:
            raise ValueError("BenchBot.run needs an agent")
        observations, result = self.reset()
        while True:
            while not agent.is_done(result):
                action, kwargs = agent.pick_action(observations, self.actions)
                observations, result = self.step(action, **(kwargs or {}))
            if not self.next_scene():
                break
            observations, result = self.step(None)
        agent.save_result(self.result_filename, self.empty_results(), self.results_functions())

    def close(self) -> None:
        """Close the connection."""
        self.transport.close()


def InProcessBenchBot(service: "BackendService", agent: Any = None, auto_start: bool = True) -> BenchBot:
    """A :class:`BenchBot` driving ``service`` in this process (no HTTP); same results as over HTTP."""
    return BenchBot(agent=agent, auto_start=auto_start, backend=service)
