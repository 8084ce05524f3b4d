"""A Gymnasium vector environment over batched simulated robots: N robots, one renderer launch per step
(``pip install benchbot[gym]``; docs/gym.md, *Vector environments*).

``gym.make_vec("BenchBot-v0", num_envs=N)`` builds :class:`BenchBotVectorEnv` (Gymnasium's ``vector_entry_point``
mode, the default for this id, through :func:`benchbot.gym_devices.make_vector_env`, which spreads the
sub-environments over several GPUs with ``devices=``; ``vectorization_mode="sync"`` steps N separate simulators instead). Each distinct
environment among the sub-environments is one scene, loaded once, with its robots batched
(:meth:`benchbot.core.robot.RobotBackend.batched`): every step moves all N robots with the pose controller on arrays
and renders every camera and laser of a scene in one kernel launch. Sub-environment ``i`` behaves as
``gym.make("BenchBot-v0", ...)`` with the same task, environment, robot and seed would (same actions, spaces,
poses, collisions, ``terminated``/``truncated``), except that:

* the robots do not see or collide with one another;
* observations are the task's kinds with a Gym entry (the registry's observation kinds, plugins' included) that
  the batched robots sense (the simulator's: ``image_rgb``, ``image_depth``, ``laser``), and ``pose``, in fast mode
  without sensor noise; tasks with noisy localisation and scene-change tasks (two scenes) need the ``sync`` mode;
* ``reset(seed=...)`` seeds only :attr:`np_random`: the worlds are fixed by the constructor's ``seed`` (with each
  environment's name and variant, :mod:`benchbot.core.seeding`);
* a sub-environment that terminated or was truncated is reset on its next step (Gymnasium's ``NEXT_STEP``
  autoreset, as ``SyncVectorEnv`` does): its action is ignored and it returns its start observation.

``on_device=True`` hands the images over without a copy: on CUDA as objects exporting DLPack and the CUDA Array
Interface (``torch.from_dlpack(obs["image_rgb"])``, ``jax.dlpack.from_dlpack(...)``), on the CPU as NumPy views.
They are the renderer's buffers, written over by the next ``step``/``reset``: clone what you keep.
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

from benchbot.core import seeding
from benchbot.core.errors import SpecError
from benchbot.core.geometry import pose7_to_se2, se2_compose_many
from benchbot.gym import DEFAULT_ENV, DEFAULT_ROBOT, DEFAULT_TASK, _gym, check_episode_arguments, lazy_classes

#: The observation kinds that are no sensor's (``ObservationKind.sensor`` False) which the vector environment builds
#: itself: ``poses``, the robots' poses (as the episode builds it for :class:`benchbot.gym.BenchBotEnv`).
BUILT_HERE = ("poses",)


def batched_entries(kinds: dict, observations: Sequence[str], sensed: Sequence[str]) -> dict:
    """``{observation name: GymEntry}`` of the vector environment: the task's ``observations`` that have a Gym entry
    in ``kinds`` (the registry's observation kinds, plugins' included: ``Registry.observations``) and that the batch
    ``sensed`` (every scene's :attr:`~benchbot.core.robot.BatchedRobots.observations`), or that the environment
    builds itself (:data:`BUILT_HERE`); in the order of ``kinds``, as :class:`benchbot.gym.BenchBotEnv`'s."""
    return {name: kind.gym for name, kind in kinds.items()
            if kind.gym is not None and name in observations
            and ((kind.sensor and name in sensed) or (not kind.sensor and name in BUILT_HERE))}


def _on_backend_thread(fn: Any, *args: Any) -> Any:
    """``fn(*args)`` on the process's backend thread (:func:`benchbot.server.service.backend_worker`: Taichi
    runs on one thread, shared with in-process ``BenchBot-v0`` environments and services); returns its value,
    raises what it raises."""
    from benchbot.server.service import backend_worker

    return backend_worker().submit(fn, *args).result()


def _one_line(array: np.ndarray) -> str:
    """``array`` for an error message: one line, summarised past 16 elements."""
    return " ".join(np.array2string(np.asarray(array), threshold=16, max_line_width=10**9).split())


def reset_mask(options: dict | None, num_envs: int) -> np.ndarray:
    """The (N,) bool mask of ``reset(options=...)``: ``options['reset_mask']``, else all True.

    Raises:
        ValueError: a mask that is not (N,) bool with at least one True.
    """
    if options is None or "reset_mask" not in options:
        return np.ones(num_envs, dtype=bool)
    mask = np.asarray(options["reset_mask"])
    if mask.shape != (num_envs,) or mask.dtype != np.bool_ or not mask.any():
        raise ValueError(f"options['reset_mask'] must be ({num_envs},) bool with at least one True, "
                         f"got {_one_line(mask)}")
    return mask


def checked_actions(actions: Any, env: Any) -> np.ndarray:
    """``actions`` as (N,) int64 for ``env`` (a vector environment: ``num_envs``, ``action_space``,
    ``single_action_space``).

    Raises:
        ValueError: not N integers of the action space (one line).
    """
    actions = np.asarray(actions)
    if (actions.shape != (env.num_envs,) or actions.dtype.kind not in "iu"
            or not env.action_space.contains(actions.astype(np.int64))):
        raise ValueError(f"actions must be {env.num_envs} integers of {env.single_action_space}, got "
                         f"{_one_line(actions)} (shape {actions.shape}, {actions.dtype})")
    return actions.astype(np.int64)


def _environment_list(env: str | Sequence[str], num_envs: int) -> list[str]:
    """``env`` as one ``name:variant`` string per sub-environment.

    Raises:
        ValueError: a list whose length is not ``num_envs``, or not strings.
    """
    if isinstance(env, str):
        return [env] * num_envs
    names = list(env) if isinstance(env, (list, tuple)) else []
    if len(names) != num_envs or not all(isinstance(n, str) for n in names):
        raise ValueError(f"env must be one 'name:variant' string or a list of {num_envs} of them, got {env!r}")
    return names


class _VectorEnvMethods:
    """The methods of :class:`BenchBotVectorEnv` (which adds Gymnasium's ``VectorEnv``, imported when the class is
    built: :func:`make_vector_env_class`)."""

    def __init__(self, num_envs: int = 1, *, task: str = DEFAULT_TASK, env: str | Sequence[str] = DEFAULT_ENV,
                 robot: str = DEFAULT_ROBOT, seed: int = 0, options: dict | None = None, max_steps: int = 200,
                 step_m: float = 0.25, turn_deg: float = 15.0, render_mode: str | None = None,
                 on_device: bool = False) -> None:
        if isinstance(num_envs, bool) or not (isinstance(num_envs, int) and num_envs >= 1):
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        from gymnasium.vector.utils import batch_space

        spaces = _gym().spaces
        check_episode_arguments(max_steps, step_m, turn_deg, render_mode)
        names = _environment_list(env, num_envs)
        scenes = list(dict.fromkeys(names))
        if on_device and len(scenes) > 1:
            raise ValueError(f"on_device needs one scene per vector environment, got {', '.join(scenes)}: make "
                             "one vector environment per scene")
        self.num_envs, self.render_mode, self.on_device = num_envs, render_mode, bool(on_device)
        self.max_steps, self.step_m, self.turn_rad = max_steps, float(step_m), math.radians(float(turn_deg))
        self._groups: list[tuple[Any, Any, np.ndarray, np.ndarray]] = []  # (backend, robots, indices, trajectory)
        try:
            self.task = _on_backend_thread(self._load_scenes, task, robot, names, int(seed), dict(options or {}))
        except BaseException:
            self.close()
            raise
        self.active = "move_distance" in self.task["actions"] and "move_angle" in self.task["actions"]
        sensed = set.intersection(*(set(robots.observations) for _, robots, _, _ in self._groups))
        #: ``{observation name: GymEntry}`` of :attr:`single_observation_space` (:func:`batched_entries`)
        self.entries = batched_entries(self._kinds, self.task["observations"], sorted(sensed))
        self.keys = {name: entry.key for name, entry in self.entries.items()}
        self._sensors = [name for name in self.keys if self._kinds[name].sensor]
        self.single_action_space = spaces.Discrete(4 if self.active else 1)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._steps = np.zeros(num_envs, dtype=np.int64)
        self._next_pose = np.zeros(num_envs, dtype=np.int64)  # passive: index of the next trajectory pose
        self._needs_reset = np.zeros(num_envs, dtype=bool)
        self._trajectory_lengths = np.zeros(num_envs, dtype=np.int64)  # passive: poses of each one's trajectory
        for _, _, indices, trajectory in self._groups:
            self._trajectory_lengths[indices] = len(trajectory)
        self._last: dict[str, Any] = {}
        self.single_observation_space = _on_backend_thread(self._single_space, spaces)
        self.observation_space = batch_space(self.single_observation_space, num_envs)

    def _load_scenes(self, task: str, robot: str, names: list[str], seed: int, options: dict) -> dict:
        """Build each distinct scene's backend and its batched robots (on the backend thread); returns the
        task spec."""
        from benchbot.core.registry import get_registry
        from benchbot.core.session import resolve_run

        registry = get_registry()
        self._kinds = registry.observations  # the observation kinds, plugins' included
        for scene_name in dict.fromkeys(names):
            run = resolve_run(registry, task, robot, scene_name)
            self._check_task(run.task)
            environment = run.environments[0]
            backend = registry.backend_factory(run.robot["type"])(run.robot, {"seed": seed, **options})
            self._groups.append((backend, None, np.array([], dtype=np.int64), []))
            backend.load_scene(environment, seed=seeding.environment_world_seed(seed, environment))
            indices = np.array([i for i, n in enumerate(names) if n == scene_name], dtype=np.int64)
            try:
                robots = backend.batched(len(indices))
            except NotImplementedError:
                raise SpecError(f"robot '{robot}' (type {run.robot['type']}) has no batched robots",
                                "use gym.make_vec(..., vectorization_mode='sync')") from None
            poses = environment.get("trajectory_poses") or []
            trajectory = np.array([pose7_to_se2(p) for p in poses]).reshape(-1, 3)  # (L, 3) map [x, y, yaw]
            if not len(trajectory) and "move_next" in run.task["actions"]:
                raise SpecError(f"environment {scene_name} has no trajectory_poses for task '{task}'",
                                "choose an environment with a trajectory, or an active task")
            self._groups[-1] = (backend, robots, indices, trajectory)
        return run.task

    @staticmethod
    def _check_task(task: dict) -> None:
        if task.get("scene_count", 1) != 1:
            raise SpecError(f"task '{task['name']}' has {task['scene_count']} scenes: the vector environment "
                            "batches single-scene tasks", "use gym.make_vec(..., vectorization_mode='sync')")
        if task.get("localisation", "ground_truth") != "ground_truth":
            raise SpecError(f"task '{task['name']}' has {task['localisation']} localisation: the vector "
                            "environment batches ground-truth tasks",
                            "use gym.make_vec(..., vectorization_mode='sync')")

    def _single_space(self, spaces: Any) -> Any:
        """One sub-environment's observation space, as ``BenchBot-v0``'s (on the backend thread): each entry's
        space from its kind's Gym entry and one robot's observation of it (the first scene's backend, at its
        start pose); a kind built here has a space of fixed shape (``poses``: (3,)), given no observation."""
        backend = self._groups[0][0]
        sample = backend.observe(self._sensors) if self._sensors else {}
        return spaces.Dict({entry.key: entry.space(spaces, sample.get(name))
                            for name, entry in self.entries.items()})

    # ----------------------------------------------------------------------------------------- observing
    def _poses(self) -> np.ndarray:
        poses = np.zeros((self.num_envs, 3))
        for _, robots, indices, _ in self._groups:
            poses[indices] = robots.poses()
        return poses

    def _observe(self) -> dict[str, Any]:
        sensors = self._sensors
        out: dict[str, Any] = {}
        for _, robots, indices, _ in self._groups:
            part = robots.observe(sensors, on_device=self.on_device) if sensors else {}
            for kind, value in part.items():
                key = self.keys[kind]
                if len(self._groups) == 1:
                    out[key] = value
                    continue
                if key not in out:
                    out[key] = np.empty((self.num_envs,) + tuple(value.shape[1:]), value.dtype)
                out[key][indices] = value
        if "poses" in self.keys:
            out[self.keys["poses"]] = self._poses()
        self._last = out
        return out

    # ----------------------------------------------------------------------------------------- the episode
    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        """Every robot (or those of ``options['reset_mask']``, (N,) bool, as ``SyncVectorEnv``) back at its
        scene's start pose; returns ``(observations, {'scene_number': (N,) int64 zeros, '_scene_number': the
        reset ones})``. ``seed`` seeds :attr:`np_random` only (the worlds are fixed by the constructor's
        ``seed``).

        Raises:
            ValueError: a ``reset_mask`` that is not (N,) bool with at least one True.
        """
        if seed is not None:
            self._np_random, self._np_random_seed = _gym().utils.seeding.np_random(seed)
        mask = reset_mask(options, self.num_envs)
        self._steps[mask] = 0
        self._next_pose[mask] = 0
        self._needs_reset[mask] = False
        obs = _on_backend_thread(self._reset, mask)
        return obs, {"scene_number": np.zeros(self.num_envs, dtype=np.int64), "_scene_number": mask.copy()}

    def _reset(self, mask: np.ndarray) -> dict[str, Any]:
        for _, robots, indices, _ in self._groups:
            robots.place(mask[indices])
        return self._observe()

    def _goals(self, actions: np.ndarray, acting: np.ndarray, poses: np.ndarray) -> np.ndarray:
        """(N, 3) goals of the acting robots (map frame): the task's action per robot."""
        if self.active:  # as the episode's goal: the pose composed with the action's motion
            moves = np.zeros((self.num_envs, 3))
            moves[:, 0] = np.select([actions == 0, actions == 1], [self.step_m, -self.step_m], 0.0)
            moves[:, 2] = np.select([actions == 2, actions == 3], [self.turn_rad, -self.turn_rad], 0.0)
            return se2_compose_many(poses, moves)
        goals = poses.copy()
        for _, _, indices, trajectory in self._groups:
            moving = indices[acting[indices]]
            goals[moving] = trajectory[self._next_pose[moving]]
        return goals

    def step(self, actions: Any) -> tuple[dict, np.ndarray, np.ndarray, np.ndarray, dict]:
        """Perform one action per sub-environment ((N,) ints of :attr:`single_action_space`); returns
        ``(observations, rewards (N,) float64 zeros, terminated (N,) bool, truncated (N,) bool, info)``, with
        ``info['result']`` (N,) str ``'SUCCESS'``/``'COLLISION'``/``'FINISHED'``, masked by ``info['_result']``
        (False where a sub-environment was reset instead), and ``info['scene_number']`` (N,) int64 zeros with
        ``info['_scene_number']`` all True (a reset reports its scene too, as ``SyncVectorEnv`` does).

        Raises:
            ValueError: ``actions`` is not N actions of the action space.
        """
        actions = checked_actions(actions, self)
        resetting, acting = self._needs_reset.copy(), ~self._needs_reset
        collided, obs = _on_backend_thread(self._move_and_observe, actions, resetting, acting)
        self._steps[resetting], self._next_pose[resetting] = 0, 0
        self._steps[acting] += 1
        finished = np.zeros(self.num_envs, dtype=bool)
        if not self.active:
            self._next_pose[acting] += 1
            finished = acting & (self._next_pose >= self._trajectory_lengths)
        terminated = acting & (collided | finished)
        truncated = acting & ~terminated & (self._steps >= self.max_steps)
        self._needs_reset = terminated | truncated
        result = np.where(collided, "COLLISION", np.where(finished, "FINISHED", "SUCCESS"))
        result = np.where(acting, result, "")
        info = {"result": result, "_result": acting.copy(),
                "scene_number": np.zeros(self.num_envs, dtype=np.int64),
                "_scene_number": np.ones(self.num_envs, dtype=bool)}
        return obs, np.zeros(self.num_envs), terminated, truncated, info

    def _move_and_observe(self, actions: np.ndarray, resetting: np.ndarray,
                          acting: np.ndarray) -> tuple[np.ndarray, dict[str, Any]]:
        """Put the ``resetting`` robots at their start, drive the ``acting`` ones (on the backend thread);
        returns (collided (N,) bool, the observations)."""
        goals = self._goals(actions, acting, self._poses())
        collided = np.zeros(self.num_envs, dtype=bool)
        for _, robots, indices, _ in self._groups:
            robots.place(resetting[indices])
            collided[indices] = robots.move_to(goals[indices], acting[indices])
        return collided, self._observe()

    def render(self) -> tuple | None:
        """The last colour images, one (H, W, 3) uint8 NumPy array per sub-environment (None without
        ``image_rgb``)."""
        rgb = self._last.get("image_rgb")
        if rgb is None:
            return None
        if not isinstance(rgb, np.ndarray):  # a DeviceArray: Taichi copies it on its own thread
            rgb = _on_backend_thread(rgb.numpy)
        return tuple(np.array(image) for image in rgb)

    def close_extras(self, **kwargs: Any) -> None:
        """Close every scene's backend (its renderer's memory)."""
        groups, self._groups = getattr(self, "_groups", []), []

        def close_all() -> None:
            for backend, robots, _, _ in groups:
                if robots is not None:
                    robots.close()
                backend.close()

        _on_backend_thread(close_all)


def make_vector_env_class() -> type:
    """The :class:`BenchBotVectorEnv` class (built lazily, as :func:`benchbot.gym.make_env_class`): the methods of
    :class:`_VectorEnvMethods` on Gymnasium's ``VectorEnv``."""
    _gym()
    from gymnasium.vector import AutoresetMode, VectorEnv

    class BenchBotVectorEnv(_VectorEnvMethods, VectorEnv):
        """N BenchBot sub-environments stepped as one (the module docstring gives the contract).

        Args:
            num_envs: N (≥ 1).
            task, env, robot: as ``BenchBot-v0``; ``env`` may also be a list of N ``name:variant`` strings
                (sub-environments of one environment share its scene).
            seed: the world seed (scene appearance) of every scene. options: backend options, e.g.
                ``{'width': 160, 'height': 120, 'arch': 'cuda'}``.
            max_steps, step_m, turn_deg, render_mode: as ``BenchBot-v0``.
            on_device: hand the images over as the renderer's own buffers (DLPack on CUDA; NumPy views on the CPU).

        Raises:
            ValueError: a bad ``num_envs``, ``max_steps``, ``step_m``, ``turn_deg``, ``render_mode`` or ``env``
                list; ``on_device`` with more than one scene.
            benchbot.core.errors.SpecError: an unknown name, a combination the task refuses, a task this vector
                environment does not batch (two scenes, noisy localisation), or a robot without batched robots.
            benchbot.core.errors.BackendError: a scene cannot be built.
        """

        metadata = {"render_modes": ["rgb_array"], "autoreset_mode": AutoresetMode.NEXT_STEP}

    return BenchBotVectorEnv


__getattr__ = lazy_classes(globals(), {"BenchBotVectorEnv": make_vector_env_class})


__all__ = ["BUILT_HERE", "BenchBotVectorEnv", "batched_entries", "checked_actions", "make_vector_env_class",
           "reset_mask"]
