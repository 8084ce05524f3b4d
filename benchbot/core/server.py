"""The backend server: an :class:`~benchbot.core.episode.Episode` behind HTTP (127.0.0.1 by default).

Routes (the original supervisor's, reference §3 and §5.1, plus the native protocol; ``docs/protocol.md``):

======================================  ======================================================================
``GET /``                               greeting (JSON string)
``GET /config/[key/...]``               the config ``{task, results, robot, environments}`` or a nested key (404)
``GET|POST /connections/<name>``        the original protocol: an action (JSON body = its arguments; blocks
                                        until the motion ends; reply ``null``) or one observation (reply:
                                        jsonpickle text, NumPy arrays by ``jsonpickle.ext.numpy``)
``GET|POST /robot/<command>``           ``is_collided``, ``is_dirty``, ``is_finished``, ``is_running``, ``next``,
                                        ``reset``, ``restart``, ``stop``, ``selected_environment``, ``state``,
                                        ``run_info`` (task, robot, environments, seed)
``GET|POST /results_functions/[fn]``    the results format's function names, or call one with
                                        ``{"args": [...], "kwargs": {...}}``
``POST /native/step``                   one round trip per step: MessagePack ``{action, args, observations?}``
                                        → ``{result, observations, state}`` (arrays as raw bytes, wire.py);
                                        with ``shm: {client, segment, slot}`` from a loopback client, large arrays
                                        go through a shared-memory segment instead (shared_frames.py)
======================================  ======================================================================

Errors are JSON ``{"error": message, "hint": hint}`` with 400 (bad request), 401 (missing/wrong token), 404
(unknown route/key/connection), 405 (method), 409 (action refused); 500 is a backend failure (its message says
which); 504 an action that ran past the action timeout (the motion still completes on the backend thread and the
episode stays usable). Request bodies are only ever parsed as JSON or MessagePack: nothing a client sends is
unpickled. Every episode call runs on one dedicated worker thread (Taichi and other simulators need a single
thread), built in :class:`BackendService`; :class:`BackendApi` holds the protocol-independent operations that the
routes and the in-process client (:mod:`benchbot.api`) share.
"""

from __future__ import annotations

import asyncio
import copy
import hmac
import json
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Callable

import uvicorn
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import JSONResponse, Response
from starlette.routing import Route

from benchbot.core import shared_frames, wire
from benchbot.core.shared_frames import is_loopback
from benchbot.core.episode import ACTIONS, Episode
from benchbot.core.errors import ActionError, BackendError, BenchbotError

SUPERVISOR_GREETING = "Hello, I am the BenchBot supervisor"
ROBOT_GREETING = "Hello, I am the BenchBot robot controller"
MSGPACK = wire.MSGPACK_TYPE
TOKEN_HEADER = "x-benchbot-token"
DEFAULT_ACTION_TIMEOUT_S = 120.0
#: The original robot config's API-side callback for colour images (reference §4): clients import it from
#: ``benchbot_api.api_callbacks``.
RGB_CALLBACK = "api_callbacks.convert_to_rgb"


_WORKER: ThreadPoolExecutor | None = None
_WORKER_LOCK = threading.Lock()


def backend_worker() -> ThreadPoolExecutor:
    """The process-wide single thread on which every robot backend runs (Taichi needs one thread per process)."""
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

    Raises:
        BenchbotError: whatever ``build_episode`` raises.
    """

    def __init__(self, build_episode: Callable[[], Episode], results_functions: dict[str, Callable] | None = None):
        self.executor = backend_worker()
        self.results_functions = results_functions or {}
        self.episode: Episode = self.executor.submit(build_episode).result()

    def call(self, fn: Callable, *args: Any) -> Any:
        """Run ``fn(*args)`` on the worker thread and wait for it."""
        return self.executor.submit(fn, *args).result()

    async def acall(self, fn: Callable, *args: Any) -> Any:
        """Await ``fn(*args)`` run on the worker thread."""
        return await asyncio.wrap_future(self.executor.submit(fn, *args))

    def close(self) -> None:
        """Close the robot backend (on the worker thread); the thread stays for the next service."""
        self.call(self.episode.backend.close)


# ------------------------------------------------------------------------------------------------- errors
class NotFoundError(BenchbotError):
    """An unknown route, config key, robot command, connection or results function (HTTP 404)."""


class BadRequestError(BenchbotError):
    """A malformed request body or argument (HTTP 400)."""


class ActionTimeoutError(BackendError):
    """An action ran past the server's action timeout (HTTP 504)."""


class UnauthorizedError(BenchbotError):
    """A request without the server's token (HTTP 401)."""


def status_of(exc: BaseException) -> int:
    """The HTTP status of an error raised by :class:`BackendApi`."""
    if isinstance(exc, NotFoundError):
        return 404
    if isinstance(exc, UnauthorizedError):
        return 401
    if isinstance(exc, ActionError):
        return 409
    if isinstance(exc, ActionTimeoutError):
        return 504
    if isinstance(exc, BackendError):
        return 500
    if isinstance(exc, BenchbotError):
        return 400
    return 500


def _error(status: int, exc: BaseException | str, hint: str = "") -> JSONResponse:
    message = exc.message if isinstance(exc, BenchbotError) else str(exc)
    hint = exc.hint if isinstance(exc, BenchbotError) else hint
    return JSONResponse({"error": message, "hint": hint}, status_code=status)


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not allowed")


def parse_json_body(raw: bytes) -> dict:
    """The JSON object of a request body (``{}`` when empty).

    Raises:
        BadRequestError: not JSON (NaN/Infinity included), or not an object.
    """
    if not raw.strip():
        return {}
    try:
        body = json.loads(raw, parse_constant=_reject_constant)
    except (ValueError, UnicodeDecodeError, RecursionError):
        raise BadRequestError("request body is not valid JSON", "send a JSON object or nothing") from None
    if not isinstance(body, dict):
        raise BadRequestError(f"request body must be a JSON object, got {type(body).__name__}", "e.g. {}")
    return body


# ------------------------------------------------------------------------------------------------- operations
class BackendApi:
    """The protocol-independent operations of the backend, shared by the HTTP routes and the in-process client.

    Methods marked *worker* must run on the backend thread (``service.call``/``service.acall``); the others may
    run anywhere.

    Args:
        service: the backend service.
    """

    def __init__(self, service: BackendService) -> None:
        self.service = service
        self.episode = service.episode
        self._obs_cache: tuple[Any, dict] | None = None
        self._generation = 0
        ep = self.episode
        self._fresh_at = ep.step_count  # the step count when the episode was last fresh (scene 0, at the start)
        self.robot_commands: dict[str, Callable[[], Any]] = {
            "is_collided": lambda: {"is_collided": ep.collided},
            "is_dirty": lambda: {"is_dirty": ep.dirty},
            "is_finished": lambda: {"is_finished": ep.is_finished},
            "is_running": self._is_running,
            "next": lambda: {"next_success": self._mutate(ep.next)},
            "reset": lambda: {"reset_success": self._reset()},
            "restart": lambda: {"restart_success": self._mutate(ep.restart)},
            "stop": lambda: {"stop_success": self._mutate(ep.stop)},
            "selected_environment": ep.selected_environment,
            "state": ep.state,
            "run_info": lambda: {"task": ep.task["name"], "robot": ep.robot["name"],
                                 "environments": [f"{e['name']}:{e['variant']}" for e in ep.environments],
                                 "seed": ep.seed},
        }

    # ---------------------------------------------------------------------------------------- helpers
    def _mutate(self, fn: Callable[[], Any]) -> Any:
        self._generation += 1
        return fn()

    def _reset(self) -> bool:
        ok = self._mutate(self.episode.reset)
        self._fresh_at = self.episode.step_count
        return ok

    def _obs_key(self) -> tuple:
        """What the cached observations depend on: any change of it means a new instant."""
        ep = self.episode
        return (self._generation, ep.scene_index, ep.step_count, ep.trajectory_next, ep.collided, id(ep.initial_pose))

    def _is_running(self) -> dict:
        """*worker*. ``is_running`` is the original client's start handshake (reference §4: it is only queried by
        ``BenchBot.start``): an episode that a previous client used is returned to a fresh scene 0 first, so
        ``benchbot run`` serves episode after episode to original clients as well."""
        ep = self.episode
        if ep.step_count != self._fresh_at or ep.scene_index != 0 or not ep.running:
            self._reset()
        return {"is_running": ep.running}

    def config(self, keys: list[str] | None = None) -> Any:
        """The config ``{task, results, robot, environments}`` or the value at nested ``keys``.

        The robot's ``image_rgb`` connection carries the original's ``callback_api`` (reference §4) so original
        clients convert ``{encoding, data}`` to an array. Ground truth is never part of the config.

        Raises:
            NotFoundError: a key is missing (list indices are not supported, as in the original).
        """
        node: Any = self.full_config()
        for key in keys or []:
            if not isinstance(node, dict) or key not in node:
                raise NotFoundError(f"config has no key '{key}'", "GET /config/ gives the whole config")
            node = node[key]
        return node

    def full_config(self) -> dict:
        """The served config (a copy)."""
        config = copy.deepcopy(self.episode.config)
        connections = config.get("robot", {}).get("connections", {})
        if isinstance(connections.get("image_rgb"), dict):
            connections["image_rgb"].setdefault("callback_api", RGB_CALLBACK)
        return config

    def robot(self, command: str) -> Any:
        """*worker*. Run a robot command (module table) and return its JSON reply.

        Raises:
            NotFoundError: unknown command.
        """
        if not command:
            return ROBOT_GREETING
        if command not in self.robot_commands:
            raise NotFoundError(f"unknown robot command '{command}'", f"one of: {', '.join(self.robot_commands)}")
        return self.robot_commands[command]()

    def results_function_names(self) -> list[str]:
        """The results format's function names (sorted)."""
        return sorted(self.service.results_functions)

    def results_function(self, name: str, body: dict) -> Any:
        """Call results function ``name`` with ``body['args']``/``body['kwargs']``.

        Raises:
            NotFoundError: unknown function. BadRequestError: bad arguments, or the function rejected them.
        """
        if name not in self.service.results_functions:
            raise NotFoundError(f"the results format has no function '{name}'", "GET /results_functions/ lists them")
        args, kwargs = body.get("args", []), body.get("kwargs", {})
        if not isinstance(args, list) or not isinstance(kwargs, dict):
            raise BadRequestError("'args' must be a list and 'kwargs' an object", 'e.g. {"args": [], "kwargs": {}}')
        try:
            value = self.service.results_functions[name](*args, **kwargs)
        except BenchbotError as exc:
            raise BadRequestError(f"{name}: {exc.message}", exc.hint) from None
        except Exception as exc:  # the arguments came from the client: its mistake, not a backend failure
            raise BadRequestError(f"{name} failed on the given arguments: {exc!r}", "check the arguments") from None
        try:
            json.dumps(value, allow_nan=False)
        except (TypeError, ValueError):
            raise BadRequestError(f"{name} returned a value that is not JSON", "check the arguments") from None
        return value

    def step(self, action: Any, args: Any, names: Any, *, borrowed: bool = False) -> dict:
        """*worker*. The native step: perform ``action`` (None: only observe), then observe. ``borrowed``: the
        observations' arrays may be the backend's own (:meth:`Episode.observe`), for a caller that copies them before
        the next episode call and modifies none.

        Returns:
            ``{'result': 'SUCCESS'|'FINISHED'|'COLLISION', 'observations': {...}, 'state': {...}}``.

        Raises:
            BadRequestError: wrong types. ActionError: action or observation refused. BackendError: backend failure.
        """
        if action is not None and not isinstance(action, str):
            raise BadRequestError(f"'action' must be a string or null, got {type(action).__name__}", "")
        if args is None:
            args = {}
        if not isinstance(args, dict):
            raise BadRequestError(f"'args' must be a map, got {type(args).__name__}", "")
        if names is not None and (not isinstance(names, list) or not all(isinstance(n, str) for n in names)):
            raise BadRequestError("'observations' must be a list of names", "")
        ep = self.episode
        result = self._mutate(lambda: ep.act(action, args)) if action is not None else ep.result()
        return {"result": result, "observations": ep.observe(names, borrowed=borrowed), "state": ep.state()}

    def act(self, action: str, args: dict) -> None:
        """*worker*. The original protocol's action connection: perform it (blocking)."""
        self._mutate(lambda: self.episode.act(action, args))

    def observation(self, name: str) -> Any:
        """*worker*. One observation in the original controller's structures (``image_rgb`` as
        ``{'encoding': 'rgb8', 'data': (H, W, 3) uint8}``). All of the task's observations are taken at once and
        kept until the next state change, so an original client's one-by-one requests see one instant.

        Raises:
            NotFoundError: the task does not observe ``name``.
        """
        ep = self.episode
        if name not in ep.task["observations"]:
            raise NotFoundError(
                f"observation '{name}' is not part of task {ep.task['name']}",
                f"available: {', '.join(ep.task['observations'])}",
            )
        if self._obs_cache is None or self._obs_cache[0] != self._obs_key():
            obs = ep.observe(None)
            self._obs_cache = (self._obs_key(), obs)  # after observe: it may capture initial_pose
        value = self._obs_cache[1][name]
        if name == "image_rgb":
            return {"encoding": "rgb8", "data": value}
        return value

    def connection(self, name: str, body: dict) -> Any:
        """*worker*. ``/connections/<name>``: an action (``body`` = its arguments; returns None) or an observation.

        Raises:
            NotFoundError: ``name`` is not a connection of the robot. ActionError: the action is refused.
        """
        connections = self.episode.robot.get("connections", {})
        if name not in connections:
            raise NotFoundError(f"the robot has no connection '{name}'", f"one of: {', '.join(connections)}")
        if name in ACTIONS or name in self.episode.task["actions"]:
            self.act(name, body)
            return None
        return self.observation(name)


def encode_jsonpickle(value: Any) -> str:
    """jsonpickle text of ``value`` with NumPy arrays (``jsonpickle.ext.numpy``), as the original controller sent.
    The server only encodes; it never decodes jsonpickle."""
    import jsonpickle
    import jsonpickle.ext.numpy as jsonpickle_numpy

    jsonpickle_numpy.register_handlers()
    return jsonpickle.encode(value)


# ------------------------------------------------------------------------------------------------- the app
def build_app(
    service: BackendService,
    *,
    token: str | None = None,
    action_timeout_s: float = DEFAULT_ACTION_TIMEOUT_S,
    api: BackendApi | None = None,
) -> Starlette:
    """The Starlette application serving ``service``'s episode.

    Args:
        service: the backend service.
        token: when set, every request must carry it in the ``X-BenchBot-Token`` header (or ``Authorization:
            Bearer <token>``); otherwise → 401. Required when serving on an address other than loopback.
        action_timeout_s: an action (native or original protocol) still running after this many seconds answers
            504; the motion completes on the backend thread and later requests queue behind it.
        api: the operations object (one is built when None).
    """
    api = api or BackendApi(service)
    segments = shared_frames.SegmentPool()  # same-host clients' shared-memory segments (used on the backend thread)

    async def guarded(request: Request, handler: Callable) -> Response:
        try:
            return await handler(request)
        except BenchbotError as exc:
            return _error(status_of(exc), exc)
        except Exception as exc:  # never crash the server: a documented 500 naming the failure
            return _error(500, f"backend failure: {exc!r}", "see the backend's log; BENCHBOT_DEBUG=1 for details")

    async def with_timeout(fn: Callable, *args: Any) -> Any:
        future = service.executor.submit(fn, *args)
        try:
            return await asyncio.wait_for(asyncio.shield(asyncio.wrap_future(future)), timeout=action_timeout_s)
        except asyncio.TimeoutError:
            raise ActionTimeoutError(
                f"the action did not finish within {action_timeout_s:g} s",
                "the motion completes in the background; query /robot/state, then go on",
            ) from None

    async def root(request: Request) -> Response:
        return JSONResponse(SUPERVISOR_GREETING)

    async def config(request: Request) -> Response:
        keys = [k for k in request.path_params.get("path", "").split("/") if k]
        return JSONResponse(api.config(keys))

    async def robot(request: Request) -> Response:
        command = request.path_params.get("command", "")
        if command and command not in api.robot_commands:
            api.robot(command)  # raises NotFoundError without touching the worker
        return JSONResponse(await service.acall(api.robot, command))

    async def results_functions(request: Request) -> Response:
        name = request.path_params.get("fn", "")
        if not name:
            return JSONResponse(api.results_function_names())
        body = parse_json_body(await request.body())
        return JSONResponse(api.results_function(name, body))

    async def connections(request: Request) -> Response:
        name = request.path_params["name"]
        body = parse_json_body(await request.body())
        value = await with_timeout(api.connection, name, body)
        return Response(encode_jsonpickle(value), media_type="application/json")

    async def native_step(request: Request) -> Response:
        raw = await request.body()
        try:
            body = wire.unpack(raw) if raw else {}
        except BenchbotError as exc:
            raise BadRequestError(exc.message, exc.hint) from None
        if not isinstance(body, dict):
            raise BadRequestError("step request must be a map", "send {action, args}")
        offer = None
        if body.get("shm") is not None:
            try:
                offer = shared_frames.check_offer(body["shm"])
            except BenchbotError as exc:
                raise BadRequestError(exc.message, exc.hint) from None
        refused = offer is not None and (request.client is None or not is_loopback(request.client.host))

        def step_and_pack() -> bytes:
            # On the backend thread: the observations are borrowed from the backend and copied once, into the
            # reply or into the client's slot, before any other episode call can change them.
            reply = api.step(body.get("action"), body.get("args"), body.get("observations"), borrowed=True)
            if refused:
                reply["shm_error"] = "shared memory is for clients on the backend's host (loopback) only"
            if offer is None or refused:
                return wire.pack(reply)
            return segments.pack(reply, offer)

        return Response(await with_timeout(step_and_pack), media_type=MSGPACK)

    def route(path: str, handler: Callable, methods: list[str]) -> Route:
        async def endpoint(request: Request) -> Response:
            return await guarded(request, handler)

        return Route(path, endpoint, methods=methods)

    methods = ["GET", "POST"]
    app = Starlette(
        routes=[
            route("/", root, methods),
            route("/config/", config, methods),
            route("/config/{path:path}", config, methods),
            route("/connections/{name}", connections, methods),
            route("/robot/", robot, methods),
            route("/robot/{command}", robot, methods),
            route("/results_functions/", results_functions, methods),
            route("/results_functions/{fn}", results_functions, methods),
            route("/native/step", native_step, ["POST"]),
        ]
    )
    app.state.api = api
    guarded_app: Any = TokenGuard(app, token) if token else app
    served = MergeSlashes(guarded_app)
    served.segments = segments  # ServerThread.stop removes them
    return served  # type: ignore[return-value]


class MergeSlashes:
    """ASGI middleware: ``//`` in a path counts as ``/``, as in the original's Flask (Werkzeug merges slashes);
    the original client asks for ``//`` and ``results_functions//create``."""

    def __init__(self, app: Any) -> None:
        self.app = app
        self.state = getattr(app, "state", None)

    async def __call__(self, scope: dict, receive: Callable, send: Callable) -> None:
        if scope["type"] == "http" and "//" in scope.get("path", ""):
            path = scope["path"]
            while "//" in path:
                path = path.replace("//", "/")
            scope = dict(scope, path=path, raw_path=path.encode("utf-8", "surrogateescape"))
        await self.app(scope, receive, send)


class TokenGuard:
    """ASGI middleware: 401 unless the request carries ``token`` (``X-BenchBot-Token: <token>`` or
    ``Authorization: Bearer <token>``); compared in constant time."""

    def __init__(self, app: Any, token: str) -> None:
        self.app, self.token = app, token.encode()
        self.state = getattr(app, "state", None)

    async def __call__(self, scope: dict, receive: Callable, send: Callable) -> None:
        if scope["type"] == "http":
            headers = dict(scope.get("headers") or [])
            given = headers.get(TOKEN_HEADER.encode(), b"")
            auth = headers.get(b"authorization", b"")
            if not given and auth.lower().startswith(b"bearer "):
                given = auth[7:].strip()
            if not hmac.compare_digest(given, self.token):
                response = _error(401, "missing or wrong BenchBot token",
                                  "set BENCHBOT_TOKEN to the token `benchbot run` printed")
                await response(scope, receive, send)
                return
        await self.app(scope, receive, send)


class ServerThread:
    """Serves an app with uvicorn on a background thread (127.0.0.1 by default).

    Args:
        app: the ASGI app.
        host: bind address.
        port: TCP port; 0 picks a free one (read :attr:`port` after :meth:`start`).
        tls_cert, tls_key: serve HTTPS with this PEM certificate chain and private key (the key may be in the
            certificate's file); plain HTTP when None.

    Raises:
        BackendError: (from start) the server did not come up within 10 s, e.g. the port is taken.
    """

    def __init__(self, app: Any, host: str = "127.0.0.1", port: int = 0, *, tls_cert: Any = None,
                 tls_key: Any = None) -> None:
        self.host = host
        self.app = app
        self.scheme = "https" if tls_cert else "http"
        tls = {"ssl_certfile": str(tls_cert), "ssl_keyfile": str(tls_key) if tls_key else None} if tls_cert else {}
        self.server = uvicorn.Server(
            uvicorn.Config(app, host=host, port=port, log_level="warning", lifespan="off", access_log=False, **tls)
        )
        self.thread = threading.Thread(target=self.server.run, name="benchbot-http", daemon=True)
        self.port = port

    def start(self) -> "ServerThread":
        """Start serving and wait until the socket listens (at most 10 s); returns self.

        Raises:
            BackendError: the server did not come up (e.g. the port is taken).
        """
        self.thread.start()
        deadline = time.monotonic() + 10.0
        while not self.server.started:
            if not self.thread.is_alive() or time.monotonic() > deadline:
                raise BackendError(
                    f"the backend server could not listen on {self.host}:{self.port}", "choose another --port"
                )
            time.sleep(0.01)
        self.port = self.server.servers[0].sockets[0].getsockname()[1]
        return self

    @property
    def address(self) -> str:
        """``http://host:port/`` (``https://`` when serving TLS)."""
        return f"{self.scheme}://{self.host}:{self.port}/"

    def stop(self) -> None:
        """Stop serving and wait for the thread."""
        self.server.should_exit = True
        self.thread.join(timeout=10)
        segments = getattr(self.app, "segments", None)
        if segments is not None:
            segments.close()
