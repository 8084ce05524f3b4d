"""Resolving and starting a run: task + robot + environment(s) → a validated combination → a backend service.

Validation follows the original ``benchbot_run`` (docs/original-benchbot.md, section 2.2), in order, with its
unchecked cases checked:
the robot exists; the task exists; the task's results format exists; every scene exists; every scene's type is one
the robot works in (its ``environment_types``, by default just its own ``type``: a ROS 2 robot bridged to the
simulator lists ``sim_taichi``); a plugin provides a backend for that type (the original's check never failed); the number of
scenes equals the task's ``scene_count``; the robot offers every action and observation of the task (docs/protocol.md).
"""

from __future__ import annotations

import contextlib
import sys
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable

from benchbot.core import stages
from benchbot.core.episode import Episode
from benchbot.core.errors import SpecError
from benchbot.core.registry import Registry

if TYPE_CHECKING:
    from benchbot.server import BackendService


@dataclass
class RunSpec:
    """A validated combination.

    Attributes:
        task, robot: their specs. environments: one spec per scene. results_format: the format spec or ``{}``.
        env_string: ``name:v1[:v2]``.
    """

    task: dict
    robot: dict
    environments: list[dict]
    results_format: dict
    env_string: str


def resolve_run(registry: Registry, task_name: str, robot_name: str, env_string: str) -> RunSpec:
    """Validate a task/robot/environment combination (module doc lists the checks).

    Raises:
        SpecError: the first failing check, naming what and how to fix it.
    """
    robot = registry.get("robots", robot_name)
    task = registry.get("tasks", task_name)
    results_format = registry.get("formats", task["results_format"]) if task.get("results_format") else {}
    env_string = registry.canonical(env_string)  # procedural:val:42 -> procedural_val_42:1, as results name it
    environments = registry.scenes(env_string)
    serves = robot.get("environment_types", [robot["type"]])
    for env in environments:
        if env["type"] not in serves:
            raise SpecError(
                f"robot '{robot_name}' works in environments of type {', '.join(serves)} but environment "
                f"{env['name']}:{env['variant']} is of type '{env['type']}'",
                "choose a robot for the environment's type (`benchbot list robots`)",
            )
    registry.backend_factory(robot["type"])
    scene_count = task.get("scene_count", 1)
    if len(environments) != scene_count:
        raise SpecError(
            f"task '{task_name}' needs {scene_count} scene(s) but '{env_string}' gives {len(environments)}",
            "e.g. miniroom:1 for single-scene tasks, miniroom:1:2 for scene change detection",
        )
    offered = set(robot.get("connections", {}))
    for kind in ("actions", "observations"):
        missing = [n for n in task[kind] if n not in offered]
        if missing:
            raise SpecError(
                f"robot '{robot_name}' lacks the {kind} {', '.join(missing)} that task '{task_name}' needs",
                "choose another robot or task",
            )
    return RunSpec(task, robot, environments, results_format, env_string)


def start_service(
    registry: Registry,
    run: RunSpec,
    *,
    seed: int = 0,
    options: dict | None = None,
    on_step: Callable[[dict], None] | None = None,
    factory: Callable[[dict, dict], Any] | None = None,
    world_seed: int | None = None,
    on_stage: Callable[[Any], None] | None = None,
) -> BackendService:
    """Build the robot backend and the episode on the backend worker thread.

    ``seed`` is the episode seed (the backend's ``seed`` option: its sensor noise; odometry and actuation noise);
    ``world_seed`` the run's world seed (None: ``seed``), which with each scene's name and variant fixes the scene
    (:meth:`benchbot.core.episode.Episode.scene_seed`, docs/noise.md *Seeds*).

    ``factory(robot_spec, options)`` builds the backend; by default the one registered for the robot's ``type``
    (the replay of a recording passes its own).

    ``on_stage`` hears the stages of building THIS backend and its first scene
    (:func:`benchbot.core.stages.listening_here` on the backend thread), not those of another service of the process.

    Observer hooks (``benchbot_episode_started``, ``benchbot_step``) are called along with ``on_step``, and
    ``benchbot_episode_finished`` when the service closes. The
    ground-truth files of the environments are the service's ``hidden`` strings (:func:`ground_truth_paths`).

    Raises:
        SpecError, BackendError: the backend or the first scene cannot be built.
    """
    from benchbot.server import BackendService  # here: a command whose episodes the simulator service serves
    # imports no server (uvicorn, Starlette: 0.04 s on the 2-core CPU)

    factory = factory or registry.backend_factory(run.robot["type"])
    hook = registry.plugin_manager.hook

    def step_observer(info: dict) -> None:
        hook.benchbot_step(info=info)
        if on_step is not None:
            on_step(info)

    def build() -> Episode:
        # stdout carries the CLI's data (tables, --json): whatever a backend prints while starting (Taichi's banner)
        # goes to stderr instead.
        heard = stages.listening_here(on_stage) if on_stage is not None else contextlib.nullcontext()
        with contextlib.redirect_stdout(sys.stderr), heard:
            backend = factory(run.robot, {"seed": seed, **(options or {})})
            episode = Episode(
                run.task, run.robot, run.environments, backend,
                results_format=run.results_format, seed=seed, on_step=step_observer,
                noise=str((options or {}).get("noise") or "none"), observation_kinds=registry.observations,
                world_seed=world_seed,
            )
        hook.benchbot_episode_started(
            info={"task": run.task["name"], "robot": run.robot["name"],
                  "environments": [f"{e['name']}:{e['variant']}" for e in run.environments]}
        )
        return episode

    def finished(episode: Episode) -> None:
        state = episode.state()
        hook.benchbot_episode_finished(info={"steps": int(state["step"]), "collided": bool(state["is_collided"]),
                                             "finished": bool(state["is_finished"])})

    functions = registry.functions("formats", run.task["results_format"]) if run.task.get("results_format") else {}
    return BackendService(build, functions, hidden=ground_truth_paths(registry, run.environments), on_close=finished)


def ground_truth_paths(registry: Registry, environments: list[dict]) -> set[str]:
    """The files of the environments' ground truths (``name:variant`` in the registry) that the registry knows of:
    the server blanks them out of anything it serves."""
    found: set[str] = set()
    for env in environments:
        entry = registry.entries.get("ground_truths", {}).get(f"{env['name']}:{env['variant']}")
        if entry is None:
            continue
        for path in (entry.path, entry.spec.get("_file_path")):
            if path:
                found.add(str(path))
    return found
