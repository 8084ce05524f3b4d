"""The backend server: an :class:`~benchbot.core.episode.Episode` behind HTTP (127.0.0.1 by default).

Routes (the original supervisor's, docs/protocol.md, plus the native protocol; ``docs/protocol.md``):

======================================  ======================================================================
``GET /``                               greeting (JSON string)
``GET /config/[key/...]``               the config ``{task, results, robot, environments}`` or a nested key (404)
``GET|POST /connections/<name>``        the original protocol: an action (JSON body = its arguments; blocks
                                        until the motion ends; reply ``null``) or one observation (reply:
                                        jsonpickle text, NumPy arrays by ``jsonpickle.ext.numpy``)
``GET|POST /robot/<command>``           ``is_collided``, ``is_dirty``, ``is_finished``, ``is_running``, ``next``,
                                        ``reset``, ``restart``, ``stop``, ``selected_environment``, ``state``,
                                        ``run_info`` (task, robot, environments, seed), ``release`` (give the
                                        episode up: :class:`EpisodeOwnership`)
``GET|POST /results_functions/[fn]``    the results format's function names, or call one with
                                        ``{"args": [...], "kwargs": {...}}``
``POST /native/step``                   one round trip per step: MessagePack ``{action, args, observations?}``
                                        → ``{result, observations, state}`` (arrays as raw bytes, wire.py);
                                        with ``shm: {client, segment, slot}`` from a loopback client, large arrays
                                        go through a shared-memory segment instead (shared_frames.py)
======================================  ======================================================================

Errors are JSON ``{"error": message, "hint": hint}`` with 400 (bad request, or an argument past its limit), 401
(missing/wrong token), 404 (unknown route/key/connection), 405 (method), 409 (action refused, or the episode belongs
to another client), 413 (body past :data:`~benchbot.core.limits.MAX_REQUEST_BYTES`); 500 is a backend failure (its
message says which; paths of ground-truth files are blanked out); 504 an action or results function that ran past
its timeout (the motion still completes on the backend thread and the episode stays usable). Request bodies are
only ever parsed as JSON or MessagePack: nothing a client sends is unpickled. Every bound a request can reach is in
:mod:`benchbot.core.limits`; request-sized work (parsing a large body, results functions, encoding observations)
never runs on the event loop. Every episode call runs on one dedicated worker thread (Taichi and other simulators
need a single thread), built in :class:`BackendService`; :class:`BackendApi` holds the protocol-independent
operations that the routes and the in-process client (:mod:`benchbot.api`) share. The episode belongs to one client
at a time (:class:`EpisodeOwnership`).
"""

from __future__ import annotations

import asyncio
import hmac
import json
import math
import re
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Callable

import uvicorn
from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import JSONResponse, Response
from starlette.routing import Route

from benchbot.core import limits, shared_frames, wire
from benchbot.core.shared_frames import is_loopback
from benchbot.core.episode import ACTIONS, ActionArgumentError, Episode
from benchbot.core.errors import ActionError, BackendError, BenchbotError

SUPERVISOR_GREETING = "Hello, I am the BenchBot supervisor"
ROBOT_GREETING = "Hello, I am the BenchBot robot controller"
MSGPACK = wire.MSGPACK_TYPE
TOKEN_HEADER = "x-benchbot-token"
#: The header naming a client (8–128 of ``A-Z a-z 0-9 _ . : -``, e.g. a random hex id): the episode belongs to one
#: client at a time (:class:`EpisodeOwnership`).
CLIENT_HEADER = "x-benchbot-client"
CLIENT_ID_PATTERN = re.compile(r"[A-Za-z0-9_.:-]{8,128}")
#: Request bodies at least this large are parsed on a worker thread, not on the event loop.
PARSE_OFF_LOOP_BYTES = 64 * 1024
#: Robot commands that only read the episode: any client may ask them, and asking does not claim the episode.
READ_ONLY_COMMANDS = frozenset({"", "is_collided", "is_dirty", "is_finished", "selected_environment", "state",
                                "run_info"})
#: What a ground-truth path is replaced with in an error message.
HIDDEN = "<hidden>"
DEFAULT_ACTION_TIMEOUT_S = 120.0
#: The original robot config's API-side callback for colour images (docs/original-benchbot.md): clients import it
#: from ``benchbot_api.api_callbacks``.
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
        hidden: strings never to be served, e.g. the paths of the environments' ground-truth files (error
            messages have them blanked out); the environments' own ``map_path``/``_file_path`` and mesh paths are
            added.
        on_close: called once, on the worker thread, with the episode when the service closes (before the backend
            closes): :func:`benchbot.core.session.start_service` calls the ``benchbot_episode_finished`` hook there.

    Raises:
        BenchbotError: whatever ``build_episode`` raises.
    """

    def __init__(self, build_episode: Callable[[], Episode], results_functions: dict[str, Callable] | None = None,
                 hidden: set[str] | None = None, on_close: Callable[[Episode], None] | None = None):
        self.executor = backend_worker()
        self.results_functions = results_functions or {}
        self.episode: Episode = self.executor.submit(build_episode).result()
        self.hidden = set(hidden or ()) | ground_truth_strings(self.episode.environments)
        self._on_close, self._closed = on_close, False

    def call(self, fn: Callable, *args: Any) -> Any:
        """Run ``fn(*args)`` on the worker thread and wait for it."""
        return self.executor.submit(fn, *args).result()

    async def acall(self, fn: Callable, *args: Any) -> Any:
        """Await ``fn(*args)`` run on the worker thread."""
        return await asyncio.wrap_future(self.executor.submit(fn, *args))

    def close(self) -> None:
        """Call ``on_close`` (once), then close the robot backend, on the worker thread; the thread stays for the
        next service."""
        if not self._closed and self._on_close is not None:
            self._closed = True
            try:
                self.call(self._on_close, self.episode)
            finally:
                self.call(self.episode.backend.close)
            return
        self._closed = True
        self.call(self.episode.backend.close)


def ground_truth_strings(environments: list[dict]) -> set[str]:
    """The strings of environment specs that name files holding (or building) ground truth: ``map_path``,
    ``_file_path`` and each mesh object's ``mesh`` (at least 4 characters long, so that blanking them out of a
    message cannot blank out ordinary words)."""
    found: set[str] = set()
    for env in environments:
        values = [env.get("map_path"), env.get("_file_path")]
        objects = env.get("objects")
        if isinstance(objects, list):
            values += [o.get("mesh") for o in objects if isinstance(o, dict)]
        found |= {v for v in values if isinstance(v, str) and len(v) >= 4}
    return found


def redact(text: str, hidden: set[str]) -> str:
    """``text`` with every string of ``hidden`` replaced by :data:`HIDDEN` (longest first)."""
    for secret in sorted(hidden, key=len, reverse=True):
        if secret in text:
            text = text.replace(secret, HIDDEN)
    return text


# ------------------------------------------------------------------------------------------------- errors
class NotFoundError(BenchbotError):
    """An unknown route, config key, robot command, connection or results function (HTTP 404)."""


class BadRequestError(BenchbotError):
    """A malformed request body or argument (HTTP 400)."""


class ActionTimeoutError(BackendError):
    """An action ran past the server's action timeout (HTTP 504)."""


class UnauthorizedError(BenchbotError):
    """A request without the server's token (HTTP 401)."""


class EpisodeInUseError(BenchbotError):
    """The episode belongs to another client (HTTP 409; :class:`EpisodeOwnership`)."""


class PayloadTooLargeError(BenchbotError):
    """A request body past :data:`~benchbot.core.limits.MAX_REQUEST_BYTES` (HTTP 413)."""


def status_of(exc: BaseException) -> int:
    """The HTTP status of an error raised by :class:`BackendApi`."""
    if isinstance(exc, NotFoundError):
        return 404
    if isinstance(exc, UnauthorizedError):
        return 401
    if isinstance(exc, PayloadTooLargeError):
        return 413
    if isinstance(exc, ActionArgumentError):
        return 400
    if isinstance(exc, (ActionError, EpisodeInUseError)):
        return 409
    if isinstance(exc, ActionTimeoutError):
        return 504
    if isinstance(exc, BackendError):
        return 500
    if isinstance(exc, BenchbotError):
        return 400
    return 500


def _error(status: int, exc: BaseException | str, hint: str = "", hidden: set[str] | None = None) -> JSONResponse:
    message = exc.message if isinstance(exc, BenchbotError) else str(exc)
    hint = exc.hint if isinstance(exc, BenchbotError) else hint
    if hidden:
        message, hint = redact(message, hidden), redact(hint, hidden)
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


def _as_number(value: int | float | str) -> float | None:
    """``value`` as a float (``inf`` for integers too large for one); a string only when it reads as a number
    (a long string of digits counts as ``inf``); None otherwise."""
    if isinstance(value, str):
        text = value.strip()
        if len(text) > 400:
            return math.inf if text.lstrip("+-").replace("_", "").isdigit() else None
        try:
            return float(text)
        except ValueError:
            return None
    try:
        return float(value)
    except OverflowError:
        return math.inf


def check_results_arguments(args: Any, kwargs: Any) -> None:
    """Refuse results-function arguments that ask for more than :data:`~benchbot.core.limits.MAX_RESULTS_ARG_NUMBER`:
    every number, and every string that reads as one, must lie within its ± bound (the server cannot tell which
    argument a function uses as a count). Walks the arguments without recursion (any nesting depth).

    Raises:
        BadRequestError: naming the first value past the bound and the variable that raises it.
    """
    bound = limits.MAX_RESULTS_ARG_NUMBER.value()
    stack: list[Any] = [args, kwargs]
    while stack:
        node = stack.pop()
        if isinstance(node, dict):
            stack.extend(node.keys())
            stack.extend(node.values())
        elif isinstance(node, list):
            stack.extend(node)
        elif isinstance(node, (int, float, str)) and not isinstance(node, bool):
            number = _as_number(node)
            if number is not None and abs(number) > bound:
                shown = repr(node) if len(repr(node)) <= 40 else repr(node)[:37] + "..."
                raise BadRequestError(
                    f"results function argument {shown} is past the limit of ±{bound:g}",
                    f"arguments (counts included) must lie within ±{bound:g}; "
                    f"${limits.MAX_RESULTS_ARG_NUMBER.env} on the backend raises it",
                )


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
        """*worker*. ``is_running`` is the original client's start handshake (only its ``BenchBot.start`` asks it:
        docs/original-benchbot.md, section 5): an episode that a previous client used is returned to a fresh scene 0
        first, so ``benchbot run`` serves episode after episode to original clients as well."""
        ep = self.episode
        if ep.step_count != self._fresh_at or ep.scene_index != 0 or not ep.running:
            self._reset()
        return {"is_running": ep.running}

    def config(self, keys: list[str] | None = None) -> Any:
        """The config ``{task, results, robot, environments}`` or the value at nested ``keys``.

        The robot's ``image_rgb`` connection carries the original's ``callback_api`` (docs/original-benchbot.md) so
        original clients convert ``{encoding, data}`` to an array. Ground truth is never part of the config.

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
        """The served config (a copy; no ground truth: :attr:`Episode.config`)."""
        config = self.episode.config
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

    def check_results_function(self, name: str) -> None:
        """Raises NotFoundError unless the results format has function ``name``."""
        if name not in self.service.results_functions:
            raise NotFoundError(f"the results format has no function '{name}'", "GET /results_functions/ lists them")

    def results_function(self, name: str, body: dict) -> Any:
        """Call results function ``name`` with ``body['args']``/``body['kwargs']`` (on the calling thread: the
        server calls :meth:`results_function_json` on its results thread).

        Raises:
            NotFoundError: unknown function. BadRequestError: bad arguments, arguments past
            :data:`~benchbot.core.limits.MAX_RESULTS_ARG_NUMBER`, a reply past
            :data:`~benchbot.core.limits.MAX_RESULTS_REPLY_BYTES`, or the function rejected them.
        """
        return self.results_function_json(name, body)[0]

    def results_function_json(self, name: str, body: dict) -> tuple[Any, str]:
        """:meth:`results_function`'s value and its JSON text."""
        self.check_results_function(name)
        args, kwargs = body.get("args", []), body.get("kwargs", {})
        if not isinstance(args, list) or not isinstance(kwargs, dict):
            raise BadRequestError("'args' must be a list and 'kwargs' an object", 'e.g. {"args": [], "kwargs": {}}')
        check_results_arguments(args, kwargs)
        try:
            value = self.service.results_functions[name](*args, **kwargs)
        except BenchbotError as exc:
            raise BadRequestError(f"{name}: {exc.message}", exc.hint) from None
        except Exception as exc:  # the arguments came from the client: its mistake, not a backend failure
            raise BadRequestError(f"{name} failed on the given arguments: {exc!r}", "check the arguments") from None
        try:
            text = json.dumps(value, allow_nan=False)
        except (TypeError, ValueError, RecursionError):
            raise BadRequestError(f"{name} returned a value that is not JSON", "check the arguments") from None
        bound = limits.MAX_RESULTS_REPLY_BYTES.value()
        if len(text) > bound:
            raise BadRequestError(f"{name}'s reply of {len(text)} bytes is past the limit of {bound:g} bytes",
                                  f"ask for less; ${limits.MAX_RESULTS_REPLY_BYTES.env} on the backend raises it")
        return value, text

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
        if names is not None:
            bound = limits.MAX_OBSERVATION_NAMES.value()
            if not isinstance(names, list):
                raise BadRequestError("'observations' must be a list of names", "")
            if len(names) > bound:
                raise BadRequestError(f"'observations' names {len(names)} observations, past the limit of {bound:g}",
                                      f"ask for the task's observations (${limits.MAX_OBSERVATION_NAMES.env})")
            if not all(isinstance(n, str) for n in names):
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


# ------------------------------------------------------------------------------------------------- ownership
class EpisodeOwnership:
    """Which client the episode belongs to: one client at a time (docs/protocol.md, "One client at a time").

    A client is named by its ``X-BenchBot-Client`` header (:data:`CLIENT_HEADER`), else it is the anonymous client
    of its address: the original ``benchbot_api`` sends no header, so original clients on one host count as one
    client, as they did in the original. The first client whose request uses the episode (an action, an
    observation, a native step, a robot command other than :data:`READ_ONLY_COMMANDS`) owns it; until the owner
    releases it (``/robot/release``) or sends no request for ``lease_s`` seconds (none in flight), every other
    client's episode request is refused with :class:`EpisodeInUseError` (409). A client whose lease ran out and
    whose episode another client then took is told so (409) on its next episode request: a client never carries on
    in an episode that someone else has reset.

    Args:
        lease_s: idle seconds after which another client may take the episode.
        clock: monotonic seconds (tests pass their own).

    Use on the event loop only (not thread-safe).
    """

    #: Clients remembered as having lost the episode to another (older ones are forgotten).
    MAX_LOST = 1024

    def __init__(self, lease_s: float, clock: Callable[[], float] = time.monotonic) -> None:
        self.lease_s, self.clock = lease_s, clock
        self.owner: str | None = None
        self.last_seen = 0.0
        self.in_flight = 0
        self._lost: dict[str, None] = {}

    def _idle_s(self) -> float:
        return self.clock() - self.last_seen

    def held_by_other(self, client: str) -> bool:
        """Whether another client holds the episode now."""
        return (self.owner is not None and self.owner != client
                and (self.in_flight > 0 or self._idle_s() < self.lease_s))

    def acquire(self, client: str) -> None:
        """Claim (or keep) the episode for one request of ``client``; pair with :meth:`done`.

        Raises:
            EpisodeInUseError: another client holds it (the message says for how long at most).
        """
        if self.held_by_other(client):
            wait = "until its request ends" if self.in_flight else f"for at most {self.lease_s - self._idle_s():.0f} s"
            if client in self._lost:
                message = (f"the episode was handed to another client after yours sent no request for "
                           f"{self.lease_s:g} s")
            else:
                message = "the episode belongs to another client"
            raise EpisodeInUseError(
                f"{message}; it holds it {wait} (then idle {self.lease_s:g} s frees it, or it sends /robot/release)",
                f"one client per episode: start another backend for a second client "
                f"(the idle time is ${limits.EPISODE_LEASE_S.env} on the backend)",
            )
        if self.owner != client:
            if self.owner is not None:
                self._lost[self.owner] = None
                while len(self._lost) > self.MAX_LOST:
                    self._lost.pop(next(iter(self._lost)))
            self._lost.pop(client, None)
            self.owner = client
        self.in_flight += 1
        self.last_seen = self.clock()

    def done(self, client: str) -> None:
        """The end of a request that :meth:`acquire` let through."""
        if self.owner == client:
            self.in_flight = max(0, self.in_flight - 1)
            self.last_seen = self.clock()

    def touch(self, client: str) -> None:
        """Any other request of ``client``: the owner's renews its lease."""
        if self.owner == client:
            self.last_seen = self.clock()

    def release(self, client: str) -> bool:
        """Give the episode up; True when ``client`` held it and no other request of it is in flight."""
        if self.owner != client or self.in_flight:
            return False
        self.owner = None
        return True


def client_identity(request: Request) -> str:
    """The name of the client sending ``request``: ``id:<X-BenchBot-Client>``, else ``anonymous@<address>``.

    Raises:
        BadRequestError: the header is there but is not 8–128 of ``A-Z a-z 0-9 _ . : -``.
    """
    given = request.headers.get(CLIENT_HEADER)
    if given is None:
        return f"anonymous@{request.client.host if request.client else 'unknown'}"
    if not CLIENT_ID_PATTERN.fullmatch(given):
        raise BadRequestError("X-BenchBot-Client must be 8-128 characters of A-Z a-z 0-9 _ . : -",
                              "send a random id, e.g. secrets.token_hex(16), with every request")
    return f"id:{given}"


# ------------------------------------------------------------------------------------------------- the app
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
    segments = shared_frames.SegmentPool()  # same-host clients' shared-memory segments (used on the backend thread)
    ownership = EpisodeOwnership(limits.EPISODE_LEASE_S.value() if lease_s is None else lease_s)
    max_body = int(limits.MAX_REQUEST_BYTES.value())
    results_timeout_s = limits.RESULTS_FUNCTION_TIMEOUT_S.value()
    for limit in (limits.MAX_OBSERVATION_NAMES, limits.MAX_RESULTS_ARG_NUMBER, limits.MAX_RESULTS_REPLY_BYTES,
                  limits.MAX_MOVE_DISTANCE_M, limits.MAX_MOVE_ANGLE_DEG):
        limit.value()  # a bad variable is a one-line error now, not a 500 on the first request
    # Results functions run one at a time on their own thread: never on the event loop, never on the backend thread.
    results_worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="benchbot-results")
    # Large request bodies are parsed, and observation replies encoded, on these threads.
    request_workers = ThreadPoolExecutor(max_workers=2, thread_name_prefix="benchbot-request")

    async def off_loop(executor: ThreadPoolExecutor, fn: Callable, *args: Any) -> Any:
        return await asyncio.wrap_future(executor.submit(fn, *args))

    async def guarded(request: Request, handler: Callable, claims: Callable[[Request], bool]) -> Response:
        client = None
        claimed = False
        try:
            client = client_identity(request)
            if claims(request):
                ownership.acquire(client)
                claimed = True
            else:
                ownership.touch(client)
            return await handler(request)
        except BenchbotError as exc:
            return _error(status_of(exc), exc, hidden=service.hidden)
        except Exception as exc:  # never crash the server: a documented 500 naming the failure
            return _error(500, f"backend failure: {exc!r}", "see the backend's log; BENCHBOT_DEBUG=1 for details",
                          hidden=service.hidden)
        finally:
            if claimed:
                ownership.done(client)

    async def with_timeout(fn: Callable, *args: Any) -> Any:
        future = service.executor.submit(fn, *args)
        try:
            return await asyncio.wait_for(asyncio.shield(asyncio.wrap_future(future)), timeout=action_timeout_s)
        except asyncio.TimeoutError:
            raise ActionTimeoutError(
                f"the action did not finish within {action_timeout_s:g} s",
                "the motion completes in the background; query /robot/state, then go on",
            ) from None

    async def body_json(request: Request) -> dict:
        raw = await request.body()
        if len(raw) >= PARSE_OFF_LOOP_BYTES:
            return await off_loop(request_workers, parse_json_body, raw)
        return parse_json_body(raw)

    async def root(request: Request) -> Response:
        return JSONResponse(SUPERVISOR_GREETING)

    async def config(request: Request) -> Response:
        keys = [k for k in request.path_params.get("path", "").split("/") if k]
        return JSONResponse(api.config(keys))

    async def robot(request: Request) -> Response:
        command = request.path_params.get("command", "")
        if command == "release":
            return JSONResponse({"release_success": ownership.release(client_identity(request))})
        if command and command not in api.robot_commands:
            api.robot(command)  # raises NotFoundError without touching the worker
        return JSONResponse(await service.acall(api.robot, command))

    async def results_functions(request: Request) -> Response:
        name = request.path_params.get("fn", "")
        if not name:
            return JSONResponse(api.results_function_names())
        api.check_results_function(name)
        body = await body_json(request)
        try:
            _, text = await asyncio.wait_for(
                asyncio.shield(off_loop(results_worker, api.results_function_json, name, body)), results_timeout_s)
        except asyncio.TimeoutError:
            raise ActionTimeoutError(
                f"results function '{name}' did not finish within {results_timeout_s:g} s",
                f"ask for less (${limits.RESULTS_FUNCTION_TIMEOUT_S.env} on the backend raises the limit)",
            ) from None
        return Response(text, media_type="application/json")

    async def connections(request: Request) -> Response:
        name = request.path_params["name"]
        body = await body_json(request)
        value = await with_timeout(api.connection, name, body)
        return Response(await off_loop(request_workers, encode_jsonpickle, value), media_type="application/json")

    def unpack_step(raw: bytes) -> dict:
        try:
            body = wire.unpack(raw) if raw else {}
        except BenchbotError as exc:
            raise BadRequestError(exc.message, exc.hint) from None
        if not isinstance(body, dict):
            raise BadRequestError("step request must be a map", "send {action, args}")
        return body

    async def native_step(request: Request) -> Response:
        raw = await request.body()
        body = await off_loop(request_workers, unpack_step, raw) if len(raw) >= PARSE_OFF_LOOP_BYTES \
            else unpack_step(raw)
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

    def always(request: Request) -> bool:
        return True

    def never(request: Request) -> bool:
        return False

    def mutating_command(request: Request) -> bool:
        command = request.path_params.get("command", "")
        return command not in READ_ONLY_COMMANDS and command != "release" and command in api.robot_commands

    def route(path: str, handler: Callable, methods: list[str], claims: Callable[[Request], bool] = never) -> Route:
        async def endpoint(request: Request) -> Response:
            return await guarded(request, handler, claims)

        return Route(path, endpoint, methods=methods)

    methods = ["GET", "POST"]
    app = Starlette(
        routes=[
            route("/", root, methods),
            route("/config/", config, methods),
            route("/config/{path:path}", config, methods),
            route("/connections/{name}", connections, methods, always),
            route("/robot/", robot, methods),
            route("/robot/{command}", robot, methods, mutating_command),
            route("/results_functions/", results_functions, methods),
            route("/results_functions/{fn}", results_functions, methods),
            route("/native/step", native_step, ["POST"], always),
        ]
    )
    app.state.api = api
    app.state.ownership = ownership
    limited = BodyLimit(app, max_body)
    guarded_app: Any = TokenGuard(limited, token) if token else limited
    served = MergeSlashes(guarded_app)
    served.segments = segments  # ServerThread.stop removes them
    served.executors = (results_worker, request_workers)  # ServerThread.stop shuts them down
    return served  # type: ignore[return-value]


class BodyLimit:
    """ASGI middleware: a request body past ``max_bytes`` is answered 413 — at once when ``Content-Length`` says so
    (nothing of the body is read), else as soon as the bytes received pass the bound. The app gets the body in one
    piece.

    Args:
        app: the ASGI app. max_bytes: the bound (:data:`~benchbot.core.limits.MAX_REQUEST_BYTES`).
    """

    def __init__(self, app: Any, max_bytes: int) -> None:
        self.app, self.max_bytes = app, max_bytes
        self.state = getattr(app, "state", None)

    async def _refuse(self, scope: dict, receive: Callable, send: Callable, size: str) -> None:
        response = _error(413, PayloadTooLargeError(
            f"request body of {size} bytes is past the limit of {self.max_bytes} bytes",
            f"send less; ${limits.MAX_REQUEST_BYTES.env} on the backend raises the limit"))
        response.headers["connection"] = "close"
        await response(scope, receive, send)

    async def __call__(self, scope: dict, receive: Callable, send: Callable) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        declared = dict(scope.get("headers") or []).get(b"content-length")
        if declared is not None:
            try:
                length = int(declared)
            except ValueError:
                length = -1
            if length < 0:
                response = _error(400, "Content-Length is not a whole number of bytes", "send a valid request")
                await response(scope, receive, send)
                return
            if length > self.max_bytes:
                await self._refuse(scope, receive, send, str(length))
                return
        chunks: list[bytes] = []
        size = 0
        while True:
            message = await receive()
            if message["type"] == "http.disconnect":
                return
            chunk = message.get("body", b"")
            size += len(chunk)
            if size > self.max_bytes:
                await self._refuse(scope, receive, send, f"more than {self.max_bytes}")
                return
            chunks.append(chunk)
            if not message.get("more_body", False):
                break
        body = b"".join(chunks)
        delivered = False

        async def replay() -> dict:
            nonlocal delivered
            if not delivered:
                delivered = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()

        await self.app(scope, replay, send)


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
        sock: a socket already bound to ``host:port`` (e.g. reserved before a long start-up, so that a taken port is
            said first); the server listens on it and closes it when it stops. None: bind ``host:port`` at start.

    Raises:
        BackendError: (from start) the server did not come up within 10 s, e.g. the port is taken.
    """

    def __init__(self, app: Any, host: str = "127.0.0.1", port: int = 0, *, tls_cert: Any = None,
                 tls_key: Any = None, sock: Any = None) -> None:
        self.host = host
        self.app = app
        self.scheme = "https" if tls_cert else "http"
        tls = {"ssl_certfile": str(tls_cert), "ssl_keyfile": str(tls_key) if tls_key else None} if tls_cert else {}
        self.server = uvicorn.Server(
            uvicorn.Config(app, host=host, port=port, log_level="warning", lifespan="off", access_log=False, **tls)
        )
        self.thread = threading.Thread(target=self.server.run, kwargs={"sockets": [sock]} if sock else {},
                                       name="benchbot-http", daemon=True)
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
        for executor in getattr(self.app, "executors", ()):
            executor.shutdown(wait=False, cancel_futures=True)
