"""The backend server: an :class:`~benchbot.core.episode.Episode` behind HTTP on 127.0.0.1.

Routes (the original supervisor's, reference §3, plus the native protocol):

======================================  ======================================================================
``GET /``                               greeting (JSON string)
``GET /config/[key/...]``               the config ``{task, results, robot, environments}`` or a nested key (404)
``GET|POST /robot/<command>``           ``is_collided``, ``is_dirty``, ``is_finished``, ``is_running``, ``next``,
                                        ``reset``, ``restart``, ``stop``, ``selected_environment``, ``state``
``GET|POST /results_functions/[fn]``    the results format's function names, or call one with
                                        ``{"args": [...], "kwargs": {...}}``
``POST /native/step``                   one round trip per step: MessagePack ``{action, args, observations?}``
                                        → ``{result, observations, state}`` (arrays as raw bytes, wire.py)
======================================  ======================================================================

Errors are JSON ``{"error": message, "hint": hint}`` with 400 (bad request), 404 (unknown route/key) or 409
(action refused); a backend failure is 500 with its message. Every episode call runs on one dedicated worker
thread (Taichi and other simulators need a single thread), built in :class:`BackendService`.
"""

from __future__ import annotations

import asyncio
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

from benchbot.core import wire
from benchbot.core.episode import Episode
from benchbot.core.errors import ActionError, BackendError, BenchbotError

SUPERVISOR_GREETING = "Hello, I am the BenchBot supervisor"
ROBOT_GREETING = "Hello, I am the BenchBot robot controller"
MSGPACK = wire.MSGPACK_TYPE


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


def _error(status: int, exc: BenchbotError | str, hint: str = "") -> JSONResponse:
    message = exc.message if isinstance(exc, BenchbotError) else exc
    hint = exc.hint if isinstance(exc, BenchbotError) else hint
    return JSONResponse({"error": message, "hint": hint}, status_code=status)


async def _json_body(request: Request) -> dict:
    raw = await request.body()
    if not raw.strip():
        return {}
    try:
        body = json.loads(raw)
    except (json.JSONDecodeError, UnicodeDecodeError):
        raise BenchbotError("request body is not valid JSON", "send a JSON object or nothing") from None
    if not isinstance(body, dict):
        raise BenchbotError(f"request body must be a JSON object, got {type(body).__name__}", "")
    return body


def build_app(service: BackendService) -> Starlette:
    """The Starlette application serving ``service``'s episode."""
    episode = service.episode

    async def root(request: Request) -> Response:
        return JSONResponse(SUPERVISOR_GREETING)

    async def config(request: Request) -> Response:
        node: Any = episode.config
        for key in [k for k in request.path_params.get("path", "").split("/") if k]:
            if not isinstance(node, dict) or key not in node:
                return _error(404, f"config has no key '{key}'", "GET /config/ lists the whole config")
            node = node[key]
        return JSONResponse(node)

    robot_commands: dict[str, Callable[[], dict]] = {
        "is_collided": lambda: {"is_collided": episode.collided},
        "is_dirty": lambda: {"is_dirty": episode.dirty},
        "is_finished": lambda: {"is_finished": episode.is_finished},
        "is_running": lambda: {"is_running": episode.running},
        "next": lambda: {"next_success": episode.next()},
        "reset": lambda: {"reset_success": episode.reset()},
        "restart": lambda: {"restart_success": episode.restart()},
        "stop": lambda: {"stop_success": episode.stop()},
        "selected_environment": episode.selected_environment,
        "state": episode.state,
    }

    async def robot(request: Request) -> Response:
        command = request.path_params.get("command", "")
        if not command:
            return JSONResponse(ROBOT_GREETING)
        if command not in robot_commands:
            return _error(404, f"unknown robot command '{command}'", f"one of: {', '.join(robot_commands)}")
        try:
            return JSONResponse(await service.acall(robot_commands[command]))
        except BenchbotError as exc:
            return _error(500, exc)

    async def results_functions(request: Request) -> Response:
        name = request.path_params.get("fn", "")
        if not name:
            return JSONResponse(sorted(service.results_functions))
        if name not in service.results_functions:
            return _error(404, f"the results format has no function '{name}'", "GET /results_functions/ lists them")
        try:
            body = await _json_body(request)
            args, kwargs = body.get("args", []), body.get("kwargs", {})
            if not isinstance(args, list) or not isinstance(kwargs, dict):
                return _error(400, "'args' must be a list and 'kwargs' an object", "")
            return JSONResponse(service.results_functions[name](*args, **kwargs))
        except BenchbotError as exc:
            return _error(400, exc)
        except TypeError as exc:
            return _error(400, f"{name}: {exc}", "check the arguments")

    def _step(action: str | None, args: dict, names: list[str] | None) -> dict:
        result = episode.act(action, args) if action is not None else episode.result()
        return {"result": result, "observations": episode.observe(names), "state": episode.state()}

    async def native_step(request: Request) -> Response:
        try:
            raw = await request.body()
            body = wire.unpack(raw) if raw else {}
            if not isinstance(body, dict):
                raise BenchbotError("step request must be a map", "send {action, args}")
            action, args, names = body.get("action"), body.get("args") or {}, body.get("observations")
            if action is not None and not isinstance(action, str):
                raise BenchbotError(f"'action' must be a string or null, got {type(action).__name__}", "")
            if not isinstance(args, dict):
                raise BenchbotError(f"'args' must be a map, got {type(args).__name__}", "")
            if names is not None and (not isinstance(names, list) or not all(isinstance(n, str) for n in names)):
                raise BenchbotError("'observations' must be a list of names", "")
            reply = await service.acall(_step, action, args, names)
        except ActionError as exc:
            return _error(409, exc)
        except BackendError as exc:
            return _error(500, exc)
        except BenchbotError as exc:
            return _error(400, exc)
        return Response(wire.pack(reply), media_type=MSGPACK)

    methods = ["GET", "POST"]
    return Starlette(
        routes=[
            Route("/", root, methods=methods),
            Route("/config/", config, methods=methods),
            Route("/config/{path:path}", config, methods=methods),
            Route("/robot/", robot, methods=methods),
            Route("/robot/{command}", robot, methods=methods),
            Route("/results_functions/", results_functions, methods=methods),
            Route("/results_functions/{fn}", results_functions, methods=methods),
            Route("/native/step", native_step, methods=["POST"]),
        ]
    )


class ServerThread:
    """Serves an app with uvicorn on a background thread (127.0.0.1 by default).

    Args:
        app: the ASGI app.
        host: bind address.
        port: TCP port; 0 picks a free one (read :attr:`port` after :meth:`start`).

    Raises:
        BackendError: (from start) the server did not come up within 10 s, e.g. the port is taken.
    """

    def __init__(self, app: Any, host: str = "127.0.0.1", port: int = 0) -> None:
        self.host = host
        self.server = uvicorn.Server(
            uvicorn.Config(app, host=host, port=port, log_level="warning", lifespan="off", access_log=False)
        )
        self.thread = threading.Thread(target=self.server.run, name="benchbot-http", daemon=True)
        self.port = port

    def start(self) -> "ServerThread":
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
        """``http://host:port/``."""
        return f"http://{self.host}:{self.port}/"

    def stop(self) -> None:
        """Stop serving and wait for the thread."""
        self.server.should_exit = True
        self.thread.join(timeout=10)
