"""The abstract agent a solution implements (docs/observations.md)."""

from __future__ import annotations

import abc
from typing import Any, Callable


class Agent(abc.ABC):
    """A solution: picks actions from observations, decides when it is done, and saves its results."""

    @abc.abstractmethod
    def is_done(self, action_result: Any) -> bool:
        """True to end the current scene, given the last :class:`~benchbot.api.ActionResult`."""

    @abc.abstractmethod
    def pick_action(self, observations: dict, action_list: list[str]) -> tuple[str, dict]:
        """The next action ``(name, kwargs)`` given the observations (docs/observations.md structures) and the actions
        allowed now."""

    @abc.abstractmethod
    def save_result(self, filename: str, empty_results: dict, results_format_fns: dict[str, Callable]) -> None:
        """Write the results JSON to ``filename``; ``empty_results`` holds ``task_details``,
        ``environment_details`` and an empty ``results`` of the task's format; ``results_format_fns`` holds that
        format's functions (``create``, ``create_object``, ``validate``)."""
