"""A stand-in for the original ``benchbot_api`` client (QUT, 2020), which cannot be installed here.

It performs the original client's exact request sequence (docs/original-benchbot.md, section 5): every query is a
``requests.get`` with a JSON body (``{}`` when there is no data), the reply is decoded with ``jsonpickle.decode``,
status ≥ 300 or any failure becomes ``requests.ConnectionError``; ``start`` polls ``/`` then ``robot/is_running``,
imports the robot's ``callback_api`` functions from ``benchbot_api.<module>``, then restarts (scene ≠ 0) or resets;
``actions`` costs 3 requests; ``step`` sends the action to ``connections/<action>``, derives the result from
``is_collided``/``is_finished``, fetches ``config/task/observations`` and each observation one by one, and
``scene_number`` from ``robot/selected_environment``; ``run`` drives an agent through every scene and saves the
results with ``empty_results()`` and ``results_functions()`` (which run inside the backend).

``requests_made`` counts the HTTP requests, for the benchmarks.
"""

from __future__ import annotations

import importlib
import os
import time
from enum import Enum

import jsonpickle
import jsonpickle.ext.numpy as jsonpickle_numpy
import requests

jsonpickle_numpy.register_handlers()

RESULT_LOCATION = "/tmp/benchbot_result"
TIMEOUT_SUPERVISOR = 60


class ActionResult(Enum):
    SUCCESS = (0,)
    FINISHED = (1,)
    COLLISION = (2,)


class LegacyBenchBot:
    """The original client's behaviour (docs/original-benchbot.md, section 5), request for request."""

    def __init__(self, agent=None, supervisor_address="http://benchbot_supervisor:10000/", auto_start=True,
                 result_location: str = RESULT_LOCATION, poll_s: float = 3.0):
        self.agent = agent
        self.supervisor_address = supervisor_address
        self.result_location = result_location
        self.poll_s = poll_s
        self.requests_made = 0
        self._callbacks: dict = {}
        if auto_start:
            self.start()

    # ----------------------------------------------------------------------------------------------- queries
    def _address(self, route: str, prefix: str) -> str:
        base = self.supervisor_address + ("" if self.supervisor_address.endswith("/") else "/")
        return base + prefix + ("/" if prefix else "") + route

    def _query(self, route: str = "", prefix: str = "connections", data=None):
        data = {} if data is None else data
        address = self._address(route, prefix)
        try:
            self.requests_made += 1
            resp = requests.get(address, json=data)
            if resp.status_code >= 300:
                raise requests.RequestException(f"HTTP status {resp.status_code}")
            return jsonpickle.decode(resp.content)
        except Exception:
            raise requests.ConnectionError(
                "Communication to BenchBot supervisor failed using the route:\n\t%s" % address
            ) from None

    # ----------------------------------------------------------------------------------------------- properties
    @property
    def actions(self):
        return ([] if self._query("is_collided", "robot")["is_collided"]
                or self._query("is_finished", "robot")["is_finished"] else self._query("task/actions", "config"))

    @property
    def config(self):
        return self._query("", "config")

    @property
    def observations(self):
        return self._query("task/observations", "config")

    @property
    def result_filename(self):
        os.makedirs(os.path.dirname(self.result_location), exist_ok=True)
        return self.result_location

    # ----------------------------------------------------------------------------------------------- episode
    def start(self):
        start = time.time()
        connected = False
        while not connected and time.time() - start < TIMEOUT_SUPERVISOR:
            try:
                self._query("/", "")
                connected = True
            except requests.ConnectionError:
                time.sleep(self.poll_s)
        if not connected:
            raise requests.ConnectionError(f"Could not find a BenchBot supervisor @ '{self.supervisor_address}'.")
        while not self._query("is_running", "robot")["is_running"]:
            time.sleep(0.1)
        self._callbacks = {}
        for name, connection in self._query("robot", "config")["connections"].items():
            if "callback_api" in connection:
                module, fn = connection["callback_api"].rsplit(".", 1)
                self._callbacks[name] = getattr(importlib.import_module("benchbot_api." + module), fn)
        if self._query("selected_environment", "robot")["number"] != 0:
            self._query("restart", "robot")
        else:
            self.reset()

    def reset(self):
        if self._query("is_dirty", "robot")["is_dirty"]:
            self._query("reset", "robot")
        return self.step(None)

    def next_scene(self):
        if self._query("is_collided", "robot")["is_collided"]:
            raise RuntimeError("Collision state detected for robot; cannot proceed to next scene")
        return self._query("next", "robot")["next_success"]

    def step(self, action, **action_kwargs):
        if action is not None:
            if action not in self.actions:
                raise ValueError("Action '%s' is unavailable due to: %s" % (
                    action, "COLLISION" if self._query("is_collided", "robot")["is_collided"]
                    else "FINISHED" if self._query("is_finished", "robot")["is_finished"]
                    else "WRONG_ACTUATION_MODE?"))
            self._query(action, "connections", action_kwargs)
        result = ActionResult.SUCCESS
        if self._query("is_collided", "robot")["is_collided"]:
            result = ActionResult.COLLISION
        elif self._query("is_finished", "robot")["is_finished"]:
            result = ActionResult.FINISHED
        observations = {o: self._query(o, "connections") for o in self.observations}
        observations["scene_number"] = self._query("selected_environment", "robot")["number"]
        for key, value in observations.items():
            if self._callbacks.get(key) is not None:
                observations[key] = self._callbacks[key](value)
        return observations, result

    # ----------------------------------------------------------------------------------------------- results
    def empty_results(self):
        return {
            "task_details": self._query("task", "config"),
            "environment_details": self._query("environments", "config"),
            "results": self._query("create", "results_functions") if self._query("results", "config") else {},
        }

    def results_functions(self):
        return {
            name: (lambda *args, _fn=name, **kwargs: self._query(
                "/%s" % _fn, "results_functions", {"args": args, "kwargs": kwargs}))
            for name in self._query("/", "results_functions")
        }

    def run(self, agent=None):
        agent = agent or self.agent

        def scene():
            observations, result = self.reset()
            while not agent.is_done(result):
                action, action_args = agent.pick_action(observations, self.actions)
                observations, result = self.step(action, **action_args)

        scene()
        while self.next_scene():
            scene()
        agent.save_result(self.result_filename, self.empty_results(), self.results_functions())
