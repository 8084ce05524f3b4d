"""The hooks through which plugins extend BenchBot (pluggy project name ``benchbot``).

A plugin is a module registered under the entry-point group ``benchbot``; it implements any of these hooks with
the :data:`hookimpl` marker. Content hooks return *specs*: either a path to a YAML/JSON file or a dict. The core
validates every spec against ``schemas/<kind>.schema.json`` and indexes it by name (environments by
``name:variant``); a duplicate name is an error naming both plugins.

Plugin modules must import nothing heavy (taichi, rclpy, ray) at import time: do it inside the factories.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Union

import pluggy

if TYPE_CHECKING:  # pragma: no cover
    from benchbot.core.robot import RobotBackend

PROJECT_NAME = "benchbot"
ENTRY_POINT_GROUP = "benchbot"

hookspec = pluggy.HookspecMarker(PROJECT_NAME)
hookimpl = pluggy.HookimplMarker(PROJECT_NAME)

Spec = Union[str, Path, dict]


class ContentHooks:
    """Hooks returning content specs. Call policy: every implementation is called once, when the registry is
    built; the results of all plugins are concatenated."""

    @hookspec
    def benchbot_tasks(self) -> list[Spec]:
        """Return task specs (schema ``task``): ``name``, ``actions``, ``observations``, ``localisation``,
        ``results_format``, ``scene_count``, ``description``. Called once when the registry is built."""

    @hookspec
    def benchbot_robots(self) -> list[Spec]:
        """Return robot specs (schema ``robot``): ``name``, ``type`` (selects the robot backend), ``global_frame``,
        ``robot_frame``, ``poses``, ``connections``. Called once when the registry is built."""

    @hookspec
    def benchbot_environments(self) -> list[Spec]:
        """Return environment specs (schema ``environment``): ``name``, ``variant``, ``type``, ``map_path``,
        ``start_pose`` ``[qw,qx,qy,qz,x,y,z]``, ``trajectory_poses``, ``object_labels``. Indexed as
        ``name:variant``. Called once when the registry is built."""

    @hookspec
    def benchbot_formats(self) -> list[Spec]:
        """Return results-format specs (schema ``format``): ``name`` and ``functions`` (``create``,
        ``create_object``, ``validate`` as ``"module:attr"`` import paths). Called once when the registry is built."""

    @hookspec
    def benchbot_evaluators(self) -> list[Spec]:
        """Return evaluation-method specs (schema ``evaluator``): ``name``, ``valid_result_formats``,
        ``valid_ground_truth_formats``, ``functions`` (``evaluate``, optional ``combine``). Called once when the
        registry is built."""

    @hookspec
    def benchbot_examples(self) -> list[Spec]:
        """Return example-solution specs (schema ``example``): ``name``, ``native_command`` (run from the spec's
        folder), ``description``. Called once when the registry is built."""

    @hookspec
    def benchbot_batches(self) -> list[Spec]:
        """Return batch specs (schema ``batch``): ``name`` and ``environments`` (a list of environment strings).
        Called once when the registry is built."""

    @hookspec
    def benchbot_ground_truths(self) -> list[Spec]:
        """Return ground-truth specs (schema ``ground_truth``): ``{environment, format, ground_truth}`` as in the
        original BenchBot's ground-truth JSON files; found by the environment's ``name:variant``. Called once when
        the registry is built."""


class BehaviourHooks:
    """Hooks that add behaviour."""

    @hookspec
    def benchbot_robot_backends(self) -> dict[str, Callable[..., "RobotBackend"]]:
        """Return ``{robot type: factory}``. ``factory(robot_spec: dict, options: dict) -> RobotBackend`` builds a
        backend for robots whose spec has that ``type``. Called once when the registry is built; a type offered
        by two plugins is an error."""

    @hookspec
    def benchbot_commands(self, app: Any) -> None:
        """Add commands to the Typer ``app`` of the ``benchbot`` CLI. Called once when the CLI starts."""


class ObserverHooks:
    """Hooks that observe episodes (TUI, recorders, progress bars). Nothing in the data path depends on them;
    every implementation is called, results are ignored, and they must return quickly."""

    @hookspec
    def benchbot_episode_started(self, info: dict) -> None:
        """Called when an episode starts. ``info``: ``task``, ``robot``, ``environments`` (names)."""

    @hookspec
    def benchbot_step(self, info: dict) -> None:
        """Called after every action. ``info``: ``step`` (int), ``action`` (str or None), ``args`` (dict),
        ``result`` (``SUCCESS``/``FINISHED``/``COLLISION``), ``scene_number`` (int), ``pose`` ((3,) x m, y m,
        yaw rad, map frame)."""

    @hookspec
    def benchbot_episode_finished(self, info: dict) -> None:
        """Called when an episode ends. ``info``: ``steps`` (int), ``collided`` (bool), ``finished`` (bool)."""


HOOK_CLASSES = (ContentHooks, BehaviourHooks, ObserverHooks)
