"""The HTTP routes: :func:`build_app` puts a :class:`~benchbot.server.service.BackendService`'s episode behind
them (the original supervisor's, plus the native protocol; docs/protocol.md).

======================================  ======================================================================
``GET /``                               greeting (JSON string)
``GET /config/[key/...]``               the config ``{task, results, robot, environments}`` or a nested key (404)
``GET|POST /connections/<name>``        the original protocol: an action (JSON body = its arguments; blocks
                                        until the motion ends; reply ``null``) or one observation (reply:
                                        jsonpickle text, NumPy arrays by ``jsonpickle.ext.numpy``)
``GET|POST /robot/<command>``           ``is_collided``, ``is_dirty``, ``is_finished``, ``is_running``, ``next``,
                                        ``reset``, ``restart``, ``stop``, ``selected_environment``, ``state``,
                                        ``run_info`` (task, robot, environments, seed), ``is_free`` (whether
                                        the caller may start the episode now, else why not), ``release`` (give the
                                        episode up: :class:`~benchbot.server.ownership.EpisodeOwnership`;
                                        a supervisor's ``{"client": id, "anonymous": bool}`` ends the hold of
                                        a solution that has ended: loopback or token holders only, else 403)
``GET|POST /results_functions/[fn]``    the results format's function names, or call one with
                                        ``{"args": [...], "kwargs": {...}}``
``POST /native/step``                   one round trip per step: MessagePack ``{action, args, observations?}``
                                        → ``{result, observations, state}`` (arrays as raw bytes, wire.py);
                                        with ``shm: {client, segment, slot}`` from a loopback client, large arrays
                                        go through a shared-memory segment instead (shared_frames.py)
======================================  ======================================================================

Errors and their statuses: :mod:`benchbot.server.http_errors`. Request-sized work (parsing a large body,
results functions, encoding observations) never runs on the event loop; every episode call runs on the backend
thread.
"""

from __future__ import annotations

import asyncio
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Callable

from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import JSONResponse, Response
from starlette.routing import Route

from benchbot.core import limits
from benchbot.protocol import shared_frames, wire
from benchbot.core.errors import BenchbotError
from benchbot.server.http_errors import (
    ActionTimeoutError, BadRequestError, ForbiddenError, error_response, status_of,
)
from benchbot.server.middleware import BodyLimit, MergeSlashes, TokenGuard
from benchbot.server.operations import BackendApi
from benchbot.server.ownership import (
    CLIENT_ID_PATTERN, READ_ONLY_COMMANDS, EpisodeOwnership, client_identity,
)
from benchbot.server.request_decoding import PARSE_OFF_LOOP_BYTES, parse_json_body, parse_step_body
from benchbot.server.service import BackendService
from benchbot.core.limits import DEFAULT_ACTION_TIMEOUT_S
from benchbot.protocol.shared_frames import is_loopback

SUPERVISOR_GREETING = "Hello, I am the BenchBot supervisor"
MSGPACK = wire.MSGPACK_TYPE


def encode_jsonpickle(value: Any) -> str:
    """jsonpickle text of ``value`` with NumPy arrays (``jsonpickle.ext.numpy``), as the original controller sent.
    The server only encodes; it never decodes jsonpickle."""
    import jsonpickle
    import jsonpickle.ext.numpy as jsonpickle_numpy

    jsonpickle_numpy.register_handlers()
    # keys=False pinned: the original client decodes this, and jsonpickle 5 flips the default (jsonpickle 4.x warns
    # on every call with keys=False all the same).
    return jsonpickle.encode(value, keys=False)



def build_app(
    service: BackendService,
    *,
    token: str | None = None,
    action_timeout_s: float = DEFAULT_ACTION_TIMEOUT_S,
    api: BackendApi | None = None,
    lease_s: float | None = None,
) -> Starlette:
    """The Starlette application serving ``service``'s episode.

    Args:
        service: the backend service.
        token: when set, every request must carry it in the ``X-BenchBot-Token`` header (or ``Authorization:
            Bearer <token>``); otherwise → 401. Required when serving on an address other than loopback.
        action_timeout_s: an action (native or original protocol) still running after this many seconds answers
            504; the motion completes on the backend thread and later requests queue behind it.
        api: the operations object (one is built when None).
        lease_s: :class:`EpisodeOwnership`'s idle time; None: :data:`~benchbot.core.limits.EPISODE_LEASE_S`.

    Raises:
        UsageError: a limit's environment variable (:mod:`benchbot.core.limits`) is not a positive number.
    """
    api = api or BackendApi(service)
    ownership = EpisodeOwnership(limits.EPISODE_LEASE_S.value() if lease_s is None else lease_s)
    max_body = int(limits.MAX_REQUEST_BYTES.value())
    results_timeout_s = limits.RESULTS_FUNCTION_TIMEOUT_S.value()
    for limit in (limits.MAX_OBSERVATION_NAMES, limits.MAX_RESULTS_ARG_NUMBER, limits.MAX_RESULTS_REPLY_BYTES,
                  limits.MAX_MOVE_DISTANCE_M, limits.MAX_MOVE_ANGLE_DEG):
        limit.value()  # a bad variable is a one-line error now, not a 500 on the first request
    h = _Handlers(service, api, ownership, token, action_timeout_s, results_timeout_s)
    methods = ["GET", "POST"]
    app = Starlette(
        routes=[
            h.route("/", h.root, methods),
            h.route("/config/", h.config, methods),
            h.route("/config/{path:path}", h.config, methods),
            h.route("/connections/{name}", h.connections, methods, _always),
            h.route("/robot/", h.robot, methods),
            h.route("/robot/{command}", h.robot, methods, h.mutating_command),
            h.route("/results_functions/", h.results_functions, methods),
            h.route("/results_functions/{fn}", h.results_functions, methods),
            h.route("/native/step", h.native_step, ["POST"], _always),
        ]
    )
    app.state.api = api
    app.state.ownership = ownership
    limited = BodyLimit(app, max_body)
    guarded_app: Any = TokenGuard(limited, token) if token else limited
    served = MergeSlashes(guarded_app)
    served.segments = h.segments  # ServerThread.stop removes them
    served.executors = (h.results_worker, h.request_workers)  # ServerThread.stop shuts them down
    return served  # type: ignore[return-value]


def _always(request: Request) -> bool:
    """A route whose every request claims the episode (:class:`EpisodeOwnership`)."""
    return True


def _never(request: Request) -> bool:
    """A route whose requests never claim the episode (they only keep the caller's hold alive)."""
    return False


async def _off_loop(executor: ThreadPoolExecutor, fn: Callable, *args: Any) -> Any:
    """``fn(*args)`` on one of ``executor``'s threads, awaited without blocking the event loop."""
    return await asyncio.wrap_future(executor.submit(fn, *args))


class _Handlers:
    """The handlers of :func:`build_app`'s routes and what they share: the episode (``service``, ``api``), who holds
    it (``ownership``), the token, the time limits, the same-host clients' shared-memory ``segments`` (used on the
    backend thread), the thread that runs results functions one at a time (never on the event loop, never on the
    backend thread) and the threads that parse large request bodies and encode observation replies."""

    def __init__(self, service: BackendService, api: BackendApi, ownership: EpisodeOwnership, token: str | None,
                 action_timeout_s: float, results_timeout_s: float) -> None:
        self.service, self.api, self.ownership, self.token = service, api, ownership, token
        self.action_timeout_s, self.results_timeout_s = action_timeout_s, results_timeout_s
        self.segments = shared_frames.SegmentPool()
        self.results_worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="benchbot-results")
        self.request_workers = ThreadPoolExecutor(max_workers=2, thread_name_prefix="benchbot-request")

    def route(self, path: str, handler: Callable, methods: list[str],
              claims: Callable[[Request], bool] = _never) -> Route:
        """A route calling ``handler`` through :meth:`guarded`; ``claims`` says which of its requests claim the
        episode."""
        async def endpoint(request: Request) -> Response:
            return await self.guarded(request, handler, claims)

        return Route(path, endpoint, methods=methods)

    async def guarded(self, request: Request, handler: Callable, claims: Callable[[Request], bool]) -> Response:
        """``handler(request)`` with the caller holding the episode while it runs (when ``claims``, else its hold
        kept alive); a :class:`BenchbotError` answers its status, anything else a documented 500."""
        client = None
        claimed = False
        try:
            client = client_identity(request)
            if claims(request):
                self.ownership.acquire(client)
                claimed = True
            else:
                self.ownership.touch(client)
            return await handler(request)
        except BenchbotError as exc:
            return error_response(status_of(exc), exc, hidden=self.service.hidden)
        except Exception as exc:  # never crash the server: a documented 500 naming the failure
            return error_response(500, f"backend failure: {exc!r}",
                                  "see the backend's log; BENCHBOT_DEBUG=1 for details", hidden=self.service.hidden)
        finally:
            if claimed:
                self.ownership.done(client)

    async def with_timeout(self, fn: Callable, *args: Any) -> Any:
        """``fn(*args)`` on the backend thread, awaited at most the action timeout.

        Raises:
            ActionTimeoutError: it did not finish in time (it goes on in the background).
        """
        future = self.service.executor.submit(fn, *args)
        try:
            return await asyncio.wait_for(asyncio.shield(asyncio.wrap_future(future)), timeout=self.action_timeout_s)
        except asyncio.TimeoutError:
            raise ActionTimeoutError(
                f"the action did not finish within {self.action_timeout_s:g} s",
                "the motion completes in the background; query /robot/state, then go on",
            ) from None

    async def body_json(self, request: Request) -> dict:
        """The request's JSON body (a large one parsed off the event loop)."""
        raw = await request.body()
        if len(raw) >= PARSE_OFF_LOOP_BYTES:
            return await _off_loop(self.request_workers, parse_json_body, raw)
        return parse_json_body(raw)

    async def root(self, request: Request) -> Response:
        """``GET /``: the greeting."""
        return JSONResponse(SUPERVISOR_GREETING)

    async def config(self, request: Request) -> Response:
        """``/config/[key/...]``: the config or a nested key."""
        keys = [k for k in request.path_params.get("path", "").split("/") if k]
        return JSONResponse(self.api.config(keys))

    def release_ended(self, request: Request, body: dict) -> bool:
        """``/robot/release`` with a body: a supervisor ends the hold of a solution that has ended.

        Raises:
            ForbiddenError: the caller is neither on the backend's host (loopback) nor holding the token.
            BadRequestError: ``client`` or ``anonymous`` is malformed.
        """
        # A supervisor (benchbot submit) ends the hold of the solution it ran, once that solution's processes have
        # all ended: {"client": the id it gave the solution, "anonymous": true for an original client}. Only a
        # caller on the backend's host (loopback) or holding the token may: not one reaching a tokenless backend
        # through a Unix socket (no client address), such as a batch's sandboxed solution. A solution that
        # `benchbot submit` sandboxes reaches the backend through submit's relay, so from loopback: it may release
        # holds (its own backend's, which reveals nothing), as any process of this host may.
        if self.token is None and (request.client is None or not is_loopback(request.client.host)):
            raise ForbiddenError("only the supervisor on the backend's host may release another client's episode",
                                 "send /robot/release without a body to release your own")
        client, anonymous = body.get("client"), body.get("anonymous", False)
        if client is not None and not (isinstance(client, str) and CLIENT_ID_PATTERN.fullmatch(client)):
            raise BadRequestError("release: 'client' must be 8-128 characters of A-Z a-z 0-9 _ . : -",
                                  "give the X-BenchBot-Client id the solution used")
        if not isinstance(anonymous, bool):
            raise BadRequestError("release: 'anonymous' must be true or false", "e.g. {\"anonymous\": true}")
        return self.ownership.release_ended(None if client is None else f"id:{client}", anonymous)

    async def robot(self, request: Request) -> Response:
        """``/robot/<command>``: ``is_free`` and ``release`` here, the others on the backend thread."""
        command = request.path_params.get("command", "")
        if command == "is_free":  # whether the caller could start the episode now; claims and changes nothing
            refused = self.ownership.refusal(client_identity(request))
            if refused is None:
                return JSONResponse({"is_free": True})
            return JSONResponse({"is_free": False, "error": refused.message, "hint": refused.hint})
        if command == "release":
            body = await self.body_json(request)
            if "client" in body or "anonymous" in body:
                return JSONResponse({"release_success": self.release_ended(request, body)})
            return JSONResponse({"release_success": self.ownership.release(client_identity(request))})
        if command and command not in self.api.robot_commands:
            self.api.robot(command)  # raises NotFoundError without touching the worker
        return JSONResponse(await self.service.acall(self.api.robot, command))

    def mutating_command(self, request: Request) -> bool:
        """Whether a ``/robot/<command>`` request claims the episode (a command that changes it)."""
        command = request.path_params.get("command", "")
        return command not in READ_ONLY_COMMANDS and command != "release" and command in self.api.robot_commands

    async def results_functions(self, request: Request) -> Response:
        """``/results_functions/[fn]``: the names, or one function called on its results thread within its time
        limit.

        Raises:
            ActionTimeoutError: the function did not finish within ``RESULTS_FUNCTION_TIMEOUT_S``.
        """
        name = request.path_params.get("fn", "")
        if not name:
            return JSONResponse(self.api.results_function_names())
        self.api.check_results_function(name)
        body = await self.body_json(request)
        try:
            _, text = await asyncio.wait_for(
                asyncio.shield(_off_loop(self.results_worker, self.api.results_function_json, name, body)),
                self.results_timeout_s)
        except asyncio.TimeoutError:
            raise ActionTimeoutError(
                f"results function '{name}' did not finish within {self.results_timeout_s:g} s",
                f"ask for less (${limits.RESULTS_FUNCTION_TIMEOUT_S.env} on the backend raises the limit)",
            ) from None
        return Response(text, media_type="application/json")

    async def connections(self, request: Request) -> Response:
        """``/connections/<name>``: an action or one observation (the original protocol), jsonpickle text."""
        name = request.path_params["name"]
        body = await self.body_json(request)
        value = await self.with_timeout(self.api.connection, name, body)
        return Response(await _off_loop(self.request_workers, encode_jsonpickle, value), media_type="application/json")

    async def native_step(self, request: Request) -> Response:
        """``POST /native/step``: one step, MessagePack in and out; large arrays through a loopback client's
        shared-memory slot when it offers one.

        Raises:
            BadRequestError: the shared-memory offer is malformed.
        """
        raw = await request.body()
        body = await _off_loop(self.request_workers, parse_step_body, raw) if len(raw) >= PARSE_OFF_LOOP_BYTES \
            else parse_step_body(raw)
        offer = None
        if body.get("shm") is not None:
            try:
                offer = shared_frames.check_offer(body["shm"])
            except BenchbotError as exc:
                raise BadRequestError(exc.message, exc.hint) from None
        # A request with no client address came through the Unix socket, which only the sandboxed solution it is
        # bound into reaches: its segments go to that episode's folder, bound read-only into that sandbox only.
        via_socket = request.client is None and self.segments.socket_folder is not None
        refused = offer is not None and not via_socket and (
            request.client is None or not is_loopback(request.client.host))

        def step_and_pack() -> bytes:
            # On the backend thread: the observations are borrowed from the backend and copied once, into the
            # reply or into the client's slot, before any other episode call can change them.
            reply = self.api.step(body.get("action"), body.get("args"), body.get("observations"), borrowed=True)
            if refused:
                reply["shm_error"] = "shared memory is for clients on the backend's host (loopback) only"
            if offer is None or refused:
                return wire.pack(reply)
            return self.segments.pack(reply, offer, via_socket)

        return Response(await self.with_timeout(step_and_pack), media_type=MSGPACK)
