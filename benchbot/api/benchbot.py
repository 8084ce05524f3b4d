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

The backend's refusals and a backend that does not answer raise :class:`BackendRefusal` errors (still a
``ValueError`` for 409 and a ``ConnectionError`` otherwise, as before), each one line with its fix; left uncaught in a
solution, one is printed as that line (``error: ...``) instead of a traceback (``BENCHBOT_DEBUG=1`` shows it).
"""

from __future__ import annotations

import enum
import json
import http.client
import os
import secrets
import ssl
import sys
import threading
import urllib.parse
import time
import weakref
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from benchbot.core import settings
from benchbot.protocol import shared_frames, wire
from benchbot.core.errors import BenchbotError
# one request on a connection of its own, and the TLS context of an address: the core's (re-exported here)
from benchbot.protocol.wire import ConnectTimeout, ReadTimeout, request_once, tls_context

if TYPE_CHECKING:
    from benchbot.server import BackendService

RESULT_LOCATION = settings.get("BENCHBOT_RESULT_LOCATION")
DEFAULT_ADDRESS = settings.default("BENCHBOT_SUPERVISOR_ADDRESS")
TOKEN_HEADER = wire.TOKEN_HEADER
#: The header naming this client to the backend (one client owns an episode at a time: docs/protocol.md).
CLIENT_HEADER = wire.CLIENT_HEADER


class ActionResult(enum.Enum):
    """Outcome of an action: ``SUCCESS`` (ready for the next), ``FINISHED`` (passive trajectory used up),
    ``COLLISION`` (the robot collided; no more actions). Values are plain ints (the original's were 1-tuples)."""

    SUCCESS = 0
    FINISHED = 1
    COLLISION = 2


class BackendRefusal(Exception):
    """A request the backend refused, or a backend that did not answer: one line saying what happened and how to
    fix it. Raised as :class:`EpisodeRefused` (a ``ValueError``) or as :class:`BackendRefused` or
    :class:`BackendUnreachable` (both ``ConnectionError``), the types the client always raised. Left uncaught in the
    main thread, it is printed as ``error: <that line>`` without a traceback (``BENCHBOT_DEBUG=1`` shows it).

    Attributes:
        route: the route (``robot/reset``, ``native/step``, ...). status: the HTTP status (None: no answer).
    """

    route: str = ""
    status: int | None = None


class EpisodeRefused(BackendRefusal, ValueError):
    """409: an action refused, or the episode belongs to another client (docs/protocol.md, "One client at a
    time")."""


class BackendRefused(BackendRefusal, ConnectionError):
    """Any other refusal (400, 401, 404, 413, 500, 503 a robot fault, 504, ...)."""


class BackendUnreachable(BackendRefusal, ConnectionError):
    """No answer: nothing listens at the address, the connection broke, or the request timed out."""


def _refusal(route: str, status: int, error: Any, hint: Any = None) -> BackendRefusal:
    """The exception for the backend's refusal of ``/route`` with HTTP ``status`` and the error ``{"error": error,
    "hint": hint}`` (docs/protocol.md): ``EpisodeRefused("<error> (<hint>)")`` (a ``ValueError``) for 409 (an action
    refused, or the episode owned by another client), else ``BackendRefused("BenchBot backend refused /<route>
    (<status>): <error> (<hint>)")`` (a ``ConnectionError``); `` (<hint>)`` is left out when there is no hint; line
    breaks become spaces. Both transports raise their refusals through it."""
    detail = f"{error} ({hint})" if hint else f"{error}"
    detail = " ".join(detail.split("\n"))
    exc: BackendRefusal
    if status == 409:
        exc = EpisodeRefused(detail)
    else:
        exc = BackendRefused(f"BenchBot backend refused /{route} ({status}): {detail}")
    exc.route, exc.status = route, status
    _print_refusals_in_one_line()
    return exc


def _one_line_excepthook(kind: type, exc: BaseException, tb: Any) -> None:
    if isinstance(exc, BackendRefusal) and settings.get("BENCHBOT_DEBUG") != "1":
        print(f"error: {exc}", file=sys.stderr, flush=True)
        return
    _previous_excepthook(kind, exc, tb)


_previous_excepthook = sys.excepthook
_hook_installed = False


def _print_refusals_in_one_line() -> None:
    """Make an uncaught :class:`BackendRefusal` print as one line: installs a ``sys.excepthook`` once per process
    (at the first refusal), which hands every other exception to the hook that was there before. A hook the
    solution sets later replaces it."""
    global _previous_excepthook, _hook_installed
    if not _hook_installed:
        _hook_installed = True
        _previous_excepthook = sys.excepthook
        sys.excepthook = _one_line_excepthook


def _reply_refusal(route: str, status: int, content: bytes) -> BackendRefusal:
    """:func:`_refusal` for an HTTP reply of ``status`` whose body is ``content``: the error and hint of its JSON
    body, else (a body that is not such JSON) its first 200 bytes."""
    try:
        body = json.loads(content)
        error, hint = body.get("error"), body.get("hint")
    except Exception:
        error, hint = content[:200].decode("utf-8", "replace"), None
    return _refusal(route, status, error, hint)


class HttpRequest:
    """What an ``event_hooks["request"]`` hook is given, before the request is sent.

    Attributes:
        method: ``"GET"`` or ``"POST"``.
        url: the full URL (str).
        headers: the headers sent (dict of str; ``Host`` and ``Content-Length`` are added by :mod:`http.client`).
    """

    __slots__ = ("method", "url", "headers")

    def __init__(self, method: str, url: str, headers: dict[str, str]) -> None:
        self.method, self.url, self.headers = method, url, headers


class HttpResponse:
    """What an ``event_hooks["response"]`` hook is given, once the reply is read.

    Attributes:
        request: the :class:`HttpRequest` it answers.
        status_code: the HTTP status (int).
        content: the body (bytes).
    """

    __slots__ = ("request", "status_code", "content")

    def __init__(self, request: HttpRequest, status_code: int, content: bytes) -> None:
        self.request, self.status_code, self.content = request, status_code, content


class HttpTransport:
    """The client's HTTP transport: the standard library's :mod:`http.client`, one kept-alive connection per
    thread, a timeout on every request.

    Every route (the native step's MessagePack and the JSON routes) goes over the calling thread's connection:
    :mod:`http.client` takes ~1 ms less than httpx per request on loopback, more for multi-megabyte replies. A
    connection that the backend closed while idle is replaced, and the request sent again on the new one, once; a
    request that failed on a fresh connection is never sent again, so an action cannot run twice.

    Args:
        address: ``http://host:port/`` or ``https://host:port/`` (a path after the port prefixes every route).
        timeout_s: per-request timeout in seconds for each socket operation (an action may take this long);
            connecting times out after 5 s.
        token: sent as ``X-BenchBot-Token`` when set.
        event_hooks: ``{"request": [fn, ...], "response": [fn, ...]}``: each ``fn`` is called with an
            :class:`HttpRequest` before every request is sent, or an :class:`HttpResponse` once its reply is read
            (e.g. to count requests); other keys are ignored.
        shared_memory: receive a step's large arrays through a shared-memory file instead of the HTTP reply
            (:mod:`benchbot.protocol.shared_frames`; same results, fewer copies). ``None`` (default): when the backend
            is on loopback and ``/dev/shm`` (``$BENCHBOT_SHARED_MEMORY_DIR``) is usable, unless
            ``$BENCHBOT_SHARED_MEMORY=0``; a setting with no valid value (``BENCHBOT_SHARED_MEMORY=on``,
            ``BENCHBOT_SHARED_MEMORY_DIR`` no readable folder) leaves it off and says so in one line on stderr
            (:func:`benchbot.protocol.shared_frames.unavailable_reason`). If this process cannot map the backend's
            segment (e.g. it runs in another container), the transport turns the path off and carries on inline;
            :attr:`shared_memory_error` says why in either case.
        ca_file: for ``https://`` addresses (a backend behind a TLS proxy, or ``benchbot run --tls-cert``): a PEM
            file of the certificate authorities to trust, else ``$BENCHBOT_CA_FILE``, else the system's.

    Attributes:
        headers: sent with every request (``X-BenchBot-Client``, and ``X-BenchBot-Token`` when set); changing an
            entry changes every later request.

    Raises:
        ValueError: the address is not ``http://`` or ``https://``, or the authorities' file cannot be used.
    """

    CONNECT_TIMEOUT_S = 5.0

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
        self.event_hooks = event_hooks or {}
        self._host, self._port = url.hostname or "127.0.0.1", url.port or (443 if self._tls else 80)
        self._base_path = url.path.rstrip("/")
        self._local = threading.local()
        # every thread's connection, to close them all on close (a thread that ends takes its own with it)
        self._connections: weakref.WeakSet[http.client.HTTPConnection] = weakref.WeakSet()
        self._connections_lock = threading.Lock()
        self.shared_memory_error: str | None = None
        if shared_memory is None:
            shared_memory = shared_frames.is_loopback(self._host)
            if shared_memory and (reason := shared_frames.unavailable_reason()) is not None:
                shared_memory, self.shared_memory_error = False, reason
                if reason.startswith(settings.PREFIX) and not reason.startswith(f"{shared_frames.ENV_SWITCH}=0"):
                    print(f"[benchbot] {reason}", file=sys.stderr, flush=True)  # a mistyped setting
        self.shared_memory = bool(shared_memory)
        self._mappings: list[shared_frames.ClientMapping] = []  # every thread's, to let go of them on close
        self._missed_maps = 0  # announced segments gone before this client could map them, in a row
        self._closed = False
        # The episode is released when this transport is closed, and also when it is garbage-collected unclosed
        # (`BenchBot(agent=...).run()` drops its object as soon as run returns) or still open at exit (Ctrl-C).
        self._release_finalizer = weakref.finalize(self, _release_episode, os.getpid(), self._host, self._port,
                                                   self._tls, self._base_path, self.headers)

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
        one stay valid: :meth:`ClientMapping.close <benchbot.protocol.shared_frames.ClientMapping.close>`). If that
        fails, the backend cannot share memory with this process: turn the path off. A segment missing from
        ``/dev/shm`` may instead have been evicted by the backend (more clients than it keeps segments) between
        its reply and this call: the next step asks for a new one, up to
        :data:`~benchbot.protocol.shared_frames.MAP_ATTEMPTS` misses in a row."""
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

    def _connection(self, timeout_s: float) -> tuple[http.client.HTTPConnection, bool]:
        """This thread's connection, opened now (connect timeout :attr:`CONNECT_TIMEOUT_S`, TLS for ``https://``)
        when it has none, with ``timeout_s`` for each socket operation; and whether it was already open."""
        conn = getattr(self._local, "conn", None)
        reused = conn is not None and conn.sock is not None
        if conn is None:
            if self._tls is not None:
                conn = http.client.HTTPSConnection(self._host, self._port, context=self._tls)
            else:
                conn = http.client.HTTPConnection(self._host, self._port)
            self._local.conn = conn
            with self._connections_lock:
                self._connections.add(conn)
        if conn.sock is None:  # new, or closed by http.client after a reply that ended the connection
            conn.timeout = min(self.CONNECT_TIMEOUT_S, timeout_s)
            conn.connect()
        if conn.sock.gettimeout() != timeout_s:
            conn.sock.settimeout(timeout_s)
        return conn, reused

    def _drop_connection(self, conn: http.client.HTTPConnection) -> None:
        conn.close()
        self._local.conn = None
        with self._connections_lock:
            self._connections.discard(conn)

    def _send(self, method: str, route: str, body: bytes | None = None, content_type: str | None = None,
              timeout_s: float | None = None) -> tuple[int, bytes]:
        """Send one request on this thread's kept-alive connection and read the whole reply.

        Args:
            method: ``"GET"`` or ``"POST"``.
            route: the route after the address (``native/step``, ``robot/reset``, ``""`` for ``/``).
            body: the request body (bytes), if any, of type ``content_type``.
            timeout_s: this request's timeout in seconds (default :attr:`timeout_s`).

        Returns:
            ``(status, body)`` of the reply (int, bytes), whatever the status.

        Raises:
            OSError, http.client.HTTPException: the connection failed or timed out (the request may have reached
                the backend unless it was retried).
        """
        timeout_s = self.timeout_s if timeout_s is None else timeout_s
        headers = {"content-type": content_type, **self.headers} if content_type else dict(self.headers)
        hooks_in, hooks_out = self.event_hooks.get("request", ()), self.event_hooks.get("response", ())
        request = HttpRequest(method, self.address + route, headers) if hooks_in or hooks_out else None
        for hook in hooks_in:
            hook(request)
        for attempt in (0, 1):
            conn, reused = self._connection(timeout_s)
            try:
                conn.request(method, f"{self._base_path}/{route}", body=body, headers=headers)
                reply = conn.getresponse()
                status, content = reply.status, reply.read()
                break
            except (http.client.RemoteDisconnected, BrokenPipeError, ConnectionResetError):
                self._drop_connection(conn)
                # Only a kept-alive connection that the server closed while idle is retried (once, on a fresh
                # one): the request never reached it. A fresh connection failing is an error, never re-sent, so an
                # action cannot run twice.
                if attempt or not reused:
                    raise
            except BaseException:
                self._drop_connection(conn)
                raise
        for hook in hooks_out:
            hook(HttpResponse(request, status, content))
        return status, content

    def _post(self, route: str, body: bytes, content_type: str) -> bytes:
        """POST ``body`` to ``route``; the reply's body when it succeeded (status below 300).

        Raises:
            EpisodeRefused (ValueError): refused with 409. BackendRefused, BackendUnreachable (ConnectionError): any
                other refusal; the connection failed or timed out. ConnectionError: this transport is closed.
        """
        self._check_open(route)
        try:
            status, content = self._send("POST", route, body, content_type)
        except (OSError, http.client.HTTPException) as exc:
            raise self._unreachable(route, exc) from None
        if status >= 300:
            raise _reply_refusal(route, status, content)
        return content

    def _unreachable(self, route: str, exc: BaseException) -> BackendUnreachable:
        """One line for a request that got no answer: what failed and how to fix it."""
        if isinstance(exc, ssl.SSLCertVerificationError):
            fix = "set BENCHBOT_CA_FILE to the authority that signed the backend's certificate"
        elif isinstance(exc, TimeoutError):
            fix = (f"no reply within {self.timeout_s:g} s: the backend is busy or stuck; a slower action needs "
                   "BenchBot(timeout_s=...)")
        elif isinstance(exc, ConnectionRefusedError):
            fix = "nothing listens there: is the backend (`benchbot run`) still running?"
        else:
            fix = "the backend closed the connection: did `benchbot run` stop? its terminal says why"
        error = BackendUnreachable(f"communication with the BenchBot backend at {self.address} failed on /{route}: "
                                   f"{exc!r} ({fix})")
        error.route = route
        _print_refusals_in_one_line()
        return error

    def ping(self) -> bool:
        """True when the backend answers ``GET /`` with a success (2xx) within 2 s; False when it does not answer or
        answers with a server error (it may still be starting).

        Raises:
            BackendRefused: it answered with a 4xx refusal (a missing token: 401), which waiting cannot fix.
        """
        try:
            status, content = self._send("GET", "", timeout_s=2.0)
        except (OSError, http.client.HTTPException):
            return False
        if 400 <= status < 500:
            raise _reply_refusal("", status, content)
        return 200 <= status < 300

    def get(self, route: str, body: dict | None = None) -> Any:
        """The JSON reply of a JSON route (``config/...``, ``robot/...``, ``results_functions/...``), POSTed
        ``body`` (a JSON-serialisable dict; default ``{}``).

        Raises:
            ValueError: refused with 409. ConnectionError: any other failure or timeout, or a reply that is not
                JSON.
        """
        content = self._post(route, json.dumps(body or {}).encode(), "application/json")
        try:
            return json.loads(content)
        except ValueError as exc:
            raise ConnectionError(f"the BenchBot backend at {self.address} sent a malformed /{route} reply: "
                                  f"{exc}") from None

    def step(self, action: str | None, args: dict, observations: list[str] | None) -> dict:
        """One native step: ``{result, observations, state}``.

        Raises:
            ValueError: the action was refused (409). ConnectionError: any other failure or timeout.
        """
        route = "native/step"
        self._check_open(route)
        request: dict = {"action": action, "args": args}
        if observations is not None:
            request["observations"] = observations
        mapping = None
        if self.shared_memory:
            request["shm"] = self._shm_offer()
            mapping = self._local.mapping
        content = self._post(route, wire.pack(request), wire.MSGPACK_TYPE)
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
        """Close the HTTP connections (every thread's) and let go of the shared-memory segments (idempotent).
        Arrays that earlier steps returned stay valid: a segment is unmapped when the last array read from it is
        gone. Later requests raise ConnectionError. The episode is released (``/robot/release``, 2 s timeout) so
        that another client may use it at once rather than after the backend's idle lease; a transport never closed
        releases it when it is garbage-collected or at exit (in the process that made it)."""
        if self._closed:
            return
        self._release_finalizer.detach()
        try:
            self._send("POST", "robot/release", b"{}", "application/json", timeout_s=2.0)
        except (OSError, http.client.HTTPException):  # the backend is gone: nothing to release
            pass
        self._closed = True
        with self._connections_lock:
            connections = list(self._connections)
            self._connections.clear()
        for conn in connections:
            conn.close()
        for mapping in self._mappings:
            mapping.close()
        self._mappings.clear()


def _release_episode(pid: int, host: str, port: int, tls: ssl.SSLContext | None, base_path: str,
                     headers: dict[str, str]) -> None:
    """``POST /robot/release`` for an :class:`HttpTransport` that was never closed, on a connection of its own (2 s
    at most; nothing when the backend is gone). Only in the process that made the transport: a forked child that
    exits does not release its parent's episode."""
    if os.getpid() != pid:
        return
    try:
        if tls is not None:
            conn: http.client.HTTPConnection = http.client.HTTPSConnection(host, port, timeout=2.0, context=tls)
        else:
            conn = http.client.HTTPConnection(host, port, timeout=2.0)
        try:
            conn.request("POST", f"{base_path}/robot/release", body=b"{}",
                         headers={"content-type": "application/json", **headers})
            conn.getresponse().read()
        finally:
            conn.close()
    except Exception:  # the backend is gone, or the interpreter is shutting down: nothing to release
        pass


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
    """Calls a :class:`~benchbot.server.BackendService` in this process: no HTTP, no serialisation; episode
    calls run on the backend thread (``service.call``). Errors are raised as the HTTP transport raises them
    (``ValueError`` for a refused action, ``ConnectionError`` otherwise).

    Args:
        service: the backend service (``benchbot.core.session.start_service``).
    """

    def __init__(self, service: "BackendService") -> None:
        from benchbot.server import BackendApi

        self.service = service
        self.api = BackendApi(service)
        self.address = "in-process"

    def _call(self, route: str, fn: Callable, *args: Any) -> Any:
        from benchbot.core.errors import ActionError, BenchbotError
        from benchbot.server import status_of

        try:
            return fn(*args)
        except ActionError as exc:  # a refused action, whatever its HTTP status (an argument past its limit: 400)
            raise _refusal(route, 409, exc.message, exc.hint) from None
        except BenchbotError as exc:
            raise _refusal(route, status_of(exc), exc.message, exc.hint) from None

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
        """The native step (:meth:`benchbot.server.BackendApi.step`) on the backend thread. Its arrays come
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
        backend: a :class:`~benchbot.server.BackendService` in this process: use it directly instead of
            HTTP (``supervisor_address`` is then ignored).
        transport: any object with the transport methods (``ping``, ``get``, ``step``, ``close``); overrides the
            two above.

    Raises:
        BackendUnreachable, BackendRefused (ConnectionError): the backend does not answer within 60 s, refuses at
            once (a 4xx to ``GET /``: a missing token), or a request fails (one line naming the route, the
            backend's error and the fix). EpisodeRefused (ValueError): the episode belongs to another client.
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
                error = BackendUnreachable(
                    f"no BenchBot backend answered at {self.address} within {wait_s:.0f} s; "
                    "start one with `benchbot run` or set BENCHBOT_SUPERVISOR_ADDRESS"
                )
                _print_refusals_in_one_line()
                raise error
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
