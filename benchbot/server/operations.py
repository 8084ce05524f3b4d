"""The protocol-independent operations of the backend (:class:`BackendApi`), shared by the HTTP routes
(:mod:`benchbot.server.routes`) and the in-process client (:mod:`benchbot.api`)."""

from __future__ import annotations

import json
from typing import Any, Callable

from benchbot.core import limits
from benchbot.core.episode import ACTIONS
from benchbot.core.observations import BUILT_IN
from benchbot.core.errors import BenchbotError
from benchbot.server.http_errors import BadRequestError, NotFoundError
from benchbot.server.request_decoding import check_results_arguments
from benchbot.server.service import BackendService

ROBOT_GREETING = "Hello, I am the BenchBot robot controller"
#: The original robot config's API-side callback for colour images (docs/original-benchbot.md): clients import it
#: from ``benchbot_api.api_callbacks``. It is the ``image_rgb`` kind's ``original_callback_api``
#: (:mod:`benchbot.core.observations`).
RGB_CALLBACK = BUILT_IN["image_rgb"].original_callback_api


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
        original clients convert ``{encoding, data}`` to an array (every connection of an observation kind with an
        ``original_callback_api`` carries it). Ground truth is never part of the config.

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
        for name, kind in self.episode.observation_kinds.items():
            if kind.original_callback_api and isinstance(connections.get(name), dict):
                connections[name].setdefault("callback_api", kind.original_callback_api)
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
        """*worker*. One observation in the original controller's structures (its kind's ``original_value``:
        ``image_rgb`` as ``{'encoding': 'rgb8', 'data': (H, W, 3) uint8}``). All of the task's observations are
        taken at once and kept until the next state change, so an original client's one-by-one requests see one
        instant.

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
        kind = self.episode.observation_kinds.get(name)
        return kind.original_value(value) if kind is not None and kind.original_value is not None else value

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
