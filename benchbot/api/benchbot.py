"""The BenchBot client: talks to a backend (``benchbot run``/``batch``) over HTTP on loopback.

One step is one request (``POST /native/step``, MessagePack with raw arrays); configuration and scene changes use
the original supervisor's JSON routes. Every request has a timeout.

Address: the ``supervisor_address`` argument, else ``$BENCHBOT_SUPERVISOR_ADDRESS`` (set by ``benchbot submit`` and
``benchbot batch``), else ``http://127.0.0.1:10000/``. Results location: ``$BENCHBOT_RESULT_LOCATION``, else the
original's ``/tmp/benchbot_result``.
"""

from __future__ import annotations

import enum
import os
import time
from pathlib import Path
from typing import Any, Callable

import httpx

from benchbot.core import wire

RESULT_LOCATION = os.environ.get("BENCHBOT_RESULT_LOCATION", "/tmp/benchbot_result")
DEFAULT_ADDRESS = "http://127.0.0.1:10000/"


class ActionResult(enum.Enum):
    """Outcome of an action: ``SUCCESS`` (ready for the next), ``FINISHED`` (passive trajectory used up),
    ``COLLISION`` (the robot collided; no more actions). Values are plain ints (the original's were 1-tuples)."""

    SUCCESS = 0
    FINISHED = 1
    COLLISION = 2


class BenchBot:
    """A connection to a BenchBot backend.

    Args:
        agent: the :class:`~benchbot.api.Agent` that :meth:`run` drives.
        supervisor_address: ``http://host:port/`` of the backend (see module doc for the default).
        auto_start: wait for the backend and reset the episode now.
        timeout_s: per-request timeout in seconds (an action may take this long).

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
    ) -> None:
        self.agent = agent
        address = supervisor_address or os.environ.get("BENCHBOT_SUPERVISOR_ADDRESS") or DEFAULT_ADDRESS
        self.address = address if "://" in address else f"http://{address}"
        self.address = self.address.rstrip("/") + "/"
        self._http = httpx.Client(base_url=self.address, timeout=httpx.Timeout(timeout_s, connect=5.0))
        self._state: dict = {}
        self._config: dict | None = None
        if auto_start:
            self.start()

    # --------------------------------------------------------------------------------------- transport
    def _request(self, route: str, *, json_body: dict | None = None, content: bytes | None = None) -> httpx.Response:
        try:
            if content is not None:
                reply = self._http.post(route, content=content, headers={"content-type": wire.MSGPACK_TYPE})
            else:
                reply = self._http.post(route, json=json_body or {})
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

    def _get(self, route: str, body: dict | None = None) -> Any:
        return self._request(route, json_body=body).json()

    # --------------------------------------------------------------------------------------- lifecycle
    def start(self, wait_s: float = 60.0) -> None:
        """Wait up to ``wait_s`` for the backend, then :meth:`reset` to scene 0 (the original restarted the
        current scene instead, reference §4)."""
        deadline = time.monotonic() + wait_s
        while True:
            try:
                self._http.get("", timeout=2.0).raise_for_status()
                break
            except httpx.HTTPError:
                if time.monotonic() > deadline:
                    raise ConnectionError(
                        f"no BenchBot backend answered at {self.address} within {wait_s:.0f} s; "
                        "start one with `benchbot run` or set BENCHBOT_SUPERVISOR_ADDRESS"
                    ) from None
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
        reply = wire.unpack(
            self._request("native/step", content=wire.pack({"action": action, "args": action_kwargs})).content
        )
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
        """Close the HTTP connection."""
        self._http.close()
