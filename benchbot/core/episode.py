"""The episode: the supervisor's state machine for one task, one robot and one or more scenes.

Semantics follow the original BenchBot supervisor and robot controller (routes: docs/protocol.md; actions,
frames and localisation: docs/observations.md), with its state-machine bugs fixed (docs/original-benchbot.md,
section 11, lists them):

* ``reset`` really returns to scene 0 (the original reloaded the current scene while reporting 0);
* ``next`` clears ``initial_pose`` along with the trajectory progress (the original kept scene 1's);
* ``stop`` clears the running state; the default localisation is ``ground_truth`` (the original's default was 1);
* one switch decides localisation for motion and observations alike: the task's ``localisation`` field.

States: ``scene_index`` (0-based), ``trajectory_next`` (index of the next ``move_next`` pose, ``None`` before the
first), ``collided`` (latched until the scene is reloaded), ``dirty`` (latched once the robot is more than 1 m or
2° from the scene's start pose), ``initial_pose`` (``T_map_robot`` captured before the first motion, reported at the
robot frame's height).

All methods must be called from one thread (the backend server's worker thread).
"""

from __future__ import annotations

import copy
import math
from typing import Any, Callable, Sequence

import numpy as np

from benchbot.core import limits
from benchbot.core import noise as noise_models
from benchbot.core import observations
from benchbot.core import seeding
from benchbot.core.errors import ActionError, BackendError, BenchbotError
from benchbot.core.geometry import (
    pose7_to_se2,
    pose_observation,
    start_pose_to_se2,
    se2_compose,
    se2_relative,
    se2_to_matrix,
    wrap_angle,
)
from benchbot.core.robot import RobotBackend

ACTIONS = ("move_next", "move_distance", "move_angle")
# The original's simulator marked the robot dirty past 1 m or 2° from the start pose (docs/original-benchbot.md, 6)
DIRTY_DISTANCE_M = 1.0
DIRTY_ANGLE_RAD = math.radians(2.0)

SUCCESS, FINISHED, COLLISION = "SUCCESS", "FINISHED", "COLLISION"

#: The environment fields a client is served (``/config/environments``): what the original's environment YAMLs
#: held, minus anything that names or holds ground truth. Every other field (``_file_path``, mesh ``objects`` with
#: their poses, a plugin's own fields) stays on the backend's side; ``map_path`` is replaced
#: (:func:`served_environment`).
SERVED_ENVIRONMENT_FIELDS = ("name", "variant", "type", "map_path", "start_pose", "trajectory_poses",
                             "object_labels", "robots", "description", "lighting", "source")


class ActionArgumentError(ActionError):
    """An action's argument is not a finite number within its bound (:data:`~benchbot.core.limits.MAX_MOVE_DISTANCE_M`,
    :data:`~benchbot.core.limits.MAX_MOVE_ANGLE_DEG`): a malformed request (HTTP 400), not a refusal of the
    episode."""


def served_environment(env: dict) -> dict:
    """The part of environment spec ``env`` that clients see: the fields of :data:`SERVED_ENVIRONMENT_FIELDS`, with
    ``map_path`` replaced by the environment's ``name:variant``. A simulator's ``map_path`` is the file it builds
    the scene from — for ``sim_taichi`` the ground-truth JSON itself — so it is never served; the original's was an
    Unreal asset path that no client used."""
    served = {k: copy.deepcopy(env[k]) for k in SERVED_ENVIRONMENT_FIELDS if k in env}
    if "map_path" in served:
        served["map_path"] = f"{env.get('name')}:{env.get('variant')}"
    return served


def motion_argument(action: str, key: str, value: Any, bound: limits.Limit, unit: str) -> float:
    """``value`` as a float if it is a finite number within ``± bound`` (a missing argument means 0).

    Raises:
        ActionArgumentError: a non-number, NaN, ±inf, an integer too large for a float, or a value past the bound;
            the message names the action, the argument, the bound and its environment variable.
    """
    limit = bound.value()
    number = math.nan
    if not isinstance(value, bool) and isinstance(value, (int, float)):
        try:
            number = float(value)
        except OverflowError:  # an integer of hundreds of digits
            number = math.inf
    if math.isfinite(number) and abs(number) <= limit:
        return number
    shown = repr(value)
    shown = shown if len(shown) <= 40 else shown[:37] + "..."
    raise ActionArgumentError(
        f"{action}: '{key}' must be a finite number within ±{limit:g} {unit}, got {shown}",
        f"e.g. {{'{key}': 0.5}}; the bound is ${bound.env}",
    )


class OdometryNoise:
    """Seeded multiplicative noise on each motion's SE(2) increment (dead-reckoning tasks).

    Two models (task or robot spec field ``odometry_noise``, default ``zero_mean``):

    * ``zero_mean``: the increment (dx, dy, dyaw) in the robot frame becomes (dx·(1+n₁), dy·(1+n₁), dyaw·(1+n₂))
      with nᵢ ~ Normal(0, σ).
    * ``original``: the original BenchBot's ``noisify_odom`` (docs/original-benchbot.md, section 6): the forward
      speed and the turn rate are scaled by (1+n₁), (1+n₂) with nᵢ ~ Normal(**mean = σ**, std = σ) — a positive
      bias: on average the robot "thinks it went 10 % further" — and sideways motion is ignored (dy = 0 before the
      increment is re-integrated as a constant-(v, ω) arc).

    nᵢ are drawn from ``numpy.random.default_rng(seed)``; σ defaults to the original's 0.1 on both.

    Raises:
        ValueError: an unknown model.
    """

    MODELS = ("zero_mean", "original")

    def __init__(self, seed: int, sigma_linear: float = 0.1, sigma_angular: float = 0.1,
                 model: str = "zero_mean") -> None:
        if model not in self.MODELS:
            raise ValueError(f"unknown odometry_noise model {model!r}: use one of {self.MODELS}")
        self.rng = np.random.default_rng(seed)
        self.sigma_linear, self.sigma_angular = sigma_linear, sigma_angular
        self.model = model

    def apply(self, increment: np.ndarray) -> np.ndarray:
        """The noisy version of ``increment`` (3,) ``[dx m, dy m, dyaw rad]`` (robot frame)."""
        if self.model == "original":
            n_lin = self.rng.normal(self.sigma_linear, self.sigma_linear)
            n_ang = self.rng.normal(self.sigma_angular, self.sigma_angular)
            dx, dyaw = float(increment[0]) * (1 + n_lin), float(increment[2]) * (1 + n_ang)
            # integrate translate(v·dt) · rotZ(ω·dt) in small steps as the original node does at its odometry rate
            steps = 20
            x = y = th = 0.0
            for _ in range(steps):
                x += dx / steps * np.cos(th)
                y += dx / steps * np.sin(th)
                th += dyaw / steps
            return np.array([x, y, dyaw])
        n_lin = self.rng.normal(0.0, self.sigma_linear)
        n_ang = self.rng.normal(0.0, self.sigma_angular)
        return np.array([increment[0] * (1 + n_lin), increment[1] * (1 + n_lin), increment[2] * (1 + n_ang)])


def odometry_noise_model(task: dict, robot: dict) -> str:
    """The odometry noise model named by the task's, else the robot's, ``odometry_noise`` field (default
    ``zero_mean``)."""
    return str((task or {}).get("odometry_noise") or (robot or {}).get("odometry_noise") or "zero_mean")


class Episode:
    """One run of a task on a robot through a list of scenes.

    Args:
        task: validated task spec.
        robot: validated robot spec.
        environments: validated environment specs, one per scene (``len == task.scene_count``).
        backend: the robot backend (already built).
        results_format: the task's results-format spec, or ``{}`` when the task has none.
        seed: the episode seed: seeds the odometry noise and the actuation noise, and (through the backend's
            ``seed`` option) its sensor noise.
        world_seed: the run's world seed (None: ``seed``): every scene is loaded with
            :func:`benchbot.core.seeding.environment_world_seed` of it and the scene's environment, so a name and
            variant give one world whatever the episode's position in a batch (docs/noise.md, *Seeds*).
        on_step: optional callback ``on_step(info: dict)`` after every action (observer hooks).
        noise: a preset of :mod:`benchbot.core.noise` (default ``none``: nothing changes). Other presets make every
            motion execute a noisy version of the one commanded (actuation noise, drawn from
            ``numpy.random.default_rng([seed, scene, 14])``) and, in ``noisy`` localisation, set the odometry
            noise's σ; the backend applies the sensor models (it must have ``noise_presets``).
        observation_kinds: ``{name: ObservationKind}`` of the observations (:mod:`benchbot.core.observations`;
            default its ``BUILT_IN``; ``start_service`` gives the registry's, plugins' kinds included): kept as
            :attr:`observation_kinds` for whoever reads this episode's observations (recorder, Gym, the original
            protocol's routes). A name of a kind that is no ``sensor`` (``poses``) is the episode's to build.

    Raises:
        BackendError: the first scene cannot be loaded, or ``noise`` is not ``none`` and the backend does not apply
            noise presets. UsageError: an unknown preset.
    """

    def __init__(
        self,
        task: dict,
        robot: dict,
        environments: Sequence[dict],
        backend: RobotBackend,
        *,
        results_format: dict | None = None,
        seed: int = 0,
        on_step: Callable[[dict], None] | None = None,
        noise: str = "none",
        observation_kinds: dict | None = None,
        world_seed: int | None = None,
    ) -> None:
        self.task, self.robot, self.environments = task, robot, list(environments)
        self.observation_kinds = dict(observations.BUILT_IN if observation_kinds is None else observation_kinds)
        self.noise_preset_name = noise or "none"
        self.noise_preset = noise_models.get_preset(self.noise_preset_name, flag="noise")
        if not noise_models.is_none(self.noise_preset_name) and not getattr(backend, "noise_presets", False):
            raise BackendError(
                f"noise preset '{noise}' asked for, but robot type '{robot.get('type')}' does not apply noise presets",
                "use --noise none with this robot (a real robot's noise is its own)")
        self.results_format = results_format or {}
        self.backend, self.seed, self.on_step = backend, seed, on_step
        #: the run's world seed; None: :attr:`seed` (so resetting a Gym environment's seed also changes its worlds)
        self.world_seed = world_seed
        self.localisation = task.get("localisation", "ground_truth")
        self.step_count = 0
        # (step_count, observations) of the last observe(); its arrays may be borrowed from the backend, valid until
        # the next observe(): observers read them on the backend thread before then, and never modify them
        self.last_observation: tuple[int, dict] | None = None
        self.running = False
        self.scene_index = 0
        self._load(0)

    # ----------------------------------------------------------------------------------------- state
    def _load(self, scene_index: int) -> None:
        self.scene_index = scene_index
        self.backend.load_scene(self.environments[scene_index], seed=self.scene_seed(scene_index))
        self.start_se2 = start_pose_to_se2(self.environments[scene_index]["start_pose"])
        self.trajectory_next: int | None = None
        self.collided = False
        self.dirty = False
        self.initial_pose: np.ndarray | None = None
        self.odometry = self.backend.base_pose()  # the estimate reported in noisy localisation
        odometry = self.noise_preset["odometry"] or {}
        self.noise = OdometryNoise(self.seed * 1000 + scene_index, model=odometry_noise_model(self.task, self.robot),
                                   **odometry)
        self.actuation_rng = (None if noise_models.is_none(self.noise_preset_name)
                              else np.random.default_rng([self.seed, scene_index, noise_models.STREAM_ACTUATION]))
        self.running = True

    def scene_seed(self, scene_index: int) -> int:
        """The seed scene ``scene_index`` is loaded with: :func:`benchbot.core.seeding.environment_world_seed` of
        :attr:`world_seed` (or :attr:`seed`) and the scene's environment; never the episode's position in a batch."""
        base = self.seed if self.world_seed is None else self.world_seed
        return seeding.environment_world_seed(base, self.environments[scene_index])

    @property
    def environment(self) -> dict:
        """The current scene's environment spec."""
        return self.environments[self.scene_index]

    @property
    def config(self) -> dict:
        """The supervisor's config as clients are served it: ``{task, results, robot, environments}``
        (docs/protocol.md; a fresh copy), each environment cut to :func:`served_environment` (no ground truth, no
        file of it)."""
        return copy.deepcopy({
            "task": self.task,
            "results": self.results_format,
            "robot": self.robot,
        }) | {"environments": [served_environment(env) for env in self.environments]}

    @property
    def is_finished(self) -> bool:
        """The passive trajectory is used up (False before the first ``move_next``)."""
        trajectory = self.environment.get("trajectory_poses") or []
        return self.trajectory_next is not None and self.trajectory_next >= len(trajectory)

    @property
    def actions(self) -> list[str]:
        """The actions allowed now: none once collided or finished, else the task's."""
        return [] if (self.collided or self.is_finished) else list(self.task["actions"])

    def state(self) -> dict:
        """Every flag the client needs after a step: ``is_collided``, ``is_dirty``, ``is_finished``,
        ``is_running``, ``actions``, ``scene_number``, ``scene_count``, ``step``."""
        return {
            "is_collided": self.collided,
            "is_dirty": self.dirty,
            "is_finished": self.is_finished,
            "is_running": self.running,
            "actions": self.actions,
            "scene_number": self.scene_index,
            "scene_count": len(self.environments),
            "step": self.step_count,
        }

    def selected_environment(self) -> dict:
        """``{name, variant, number}`` of the current scene."""
        env = self.environment
        return {"name": env["name"], "variant": env["variant"], "number": self.scene_index}

    def result(self) -> str:
        """``COLLISION`` if collided, else ``FINISHED`` if the trajectory is used up, else ``SUCCESS``."""
        return COLLISION if self.collided else FINISHED if self.is_finished else SUCCESS

    # ----------------------------------------------------------------------------------------- scenes
    def next(self) -> bool:
        """Move to the next scene; False (and nothing changes) at the last scene."""
        if self.scene_index + 1 >= len(self.environments):
            return False
        self._load(self.scene_index + 1)
        return True

    def reset(self) -> bool:
        """Back to scene 0 with a fresh state (the robot at its start pose)."""
        self._load(0)
        return True

    def restart(self) -> bool:
        """Reload the current scene (robot back at its start pose); trajectory progress and ``initial_pose`` are
        kept, as in the original."""
        trajectory_next, initial_pose = self.trajectory_next, self.initial_pose
        self._load(self.scene_index)
        self.trajectory_next, self.initial_pose = trajectory_next, initial_pose
        return True

    def stop(self) -> bool:
        """Stop the episode: no more actions are accepted until reset."""
        self.running = False
        return True

    # ----------------------------------------------------------------------------------------- actions
    def _capture_initial_pose(self) -> None:
        if self.initial_pose is None and not self.dirty:
            self.initial_pose = se2_to_matrix(*self.backend.base_pose())

    def act(self, action: str, args: dict | None = None) -> str:
        """Perform ``action`` with ``args`` and return the result (``SUCCESS``/``FINISHED``/``COLLISION``).

        Args:
            action: ``move_next``; ``move_distance`` (``{'distance': metres}``, + forward); ``move_angle``
                (``{'angle': degrees}``, + counter-clockwise). Missing arguments mean 0.

        Raises:
            ActionError: the action is not allowed now (its message names why: COLLISION, FINISHED, not part of
                the task, stopped). ActionArgumentError: ``distance``/``angle`` is not a finite number within its
                bound (:func:`motion_argument`).
        """
        args = dict(args or {})
        if not self.running:
            raise ActionError("the episode is stopped", "call reset to start again")
        if action not in self.actions:
            why = "COLLISION" if self.collided else "FINISHED" if self.is_finished else "not an action of this task"
            raise ActionError(
                f"action '{action}' refused ({why})", f"allowed now: {', '.join(self.actions) or 'none'}"
            )
        if action not in ACTIONS:
            raise ActionError(f"action '{action}' is not supported by this robot", f"supported: {', '.join(ACTIONS)}")
        self._capture_initial_pose()
        before = self.backend.base_pose()
        current = before if self.localisation != "noisy" else self.odometry  # the pose the robot steers by
        if action == "move_next":
            trajectory = self.environment.get("trajectory_poses") or []
            if not trajectory:
                raise ActionError(
                    f"environment {self.environment['name']}:{self.environment['variant']} has no trajectory_poses",
                    "move_next needs an environment with a trajectory",
                )
            index = self.trajectory_next or 0
            goal = pose7_to_se2(trajectory[index])
        else:
            if action == "move_distance":
                value = motion_argument(action, "distance", args.get("distance", 0.0), limits.MAX_MOVE_DISTANCE_M, "m")
                delta = np.array([value, 0.0, 0.0])
            else:
                value = motion_argument(action, "angle", args.get("angle", 0.0), limits.MAX_MOVE_ANGLE_DEG, "degrees")
                delta = np.array([0.0, 0.0, math.radians(value)])
            goal = se2_compose(current, delta)
        # In noisy localisation the robot steers by its estimate: the motion it makes is the one that would take
        # the estimate to the goal, applied from where it really is.
        truth_goal = goal if self.localisation != "noisy" else se2_compose(before, se2_relative(current, goal))
        if self.actuation_rng is not None:  # the motion executed differs from the one commanded (noise preset)
            executed = noise_models.sample_actuation(se2_relative(before, truth_goal), self.noise_preset["actuation"],
                                                     self.actuation_rng)
            truth_goal = se2_compose(before, executed)
        try:
            outcome = self.backend.move_to(truth_goal)
        except BenchbotError:
            raise
        except Exception as exc:  # a backend bug must reach the user as a clear error, not a dead server
            raise BackendError(f"robot backend failed during {action}: {exc!r}", "see the backend log") from exc
        after = self.backend.base_pose()
        self.odometry = se2_compose(self.odometry, self.noise.apply(se2_relative(before, after)))
        self.collided = self.collided or outcome.collided
        if action == "move_next":
            self.trajectory_next = (self.trajectory_next or 0) + 1
        moved = se2_relative(self.start_se2, after)
        if math.hypot(moved[0], moved[1]) > DIRTY_DISTANCE_M or abs(wrap_angle(moved[2])) > DIRTY_ANGLE_RAD:
            self.dirty = True
        self.step_count += 1
        result = self.result()
        if self.on_step is not None:
            self.on_step(
                {"step": self.step_count, "action": action, "args": args, "result": result,
                 "scene_number": self.scene_index, "pose": after}
            )
        return result

    # ----------------------------------------------------------------------------------------- observations
    def observe(self, names: Sequence[str] | None = None, *, borrowed: bool = False) -> dict[str, Any]:
        """The observations ``names`` (default: the task's) in the structures of docs/observations.md, plus
        ``scene_number`` (int, 0-based). ``borrowed``: the sensor arrays may be the backend's own
        (:meth:`~benchbot.core.robot.RobotBackend.observe_borrowed`), for a caller that copies them at once and
        modifies none.

        Raises:
            ActionError: a name the task does not observe.
        """
        names = list(self.task["observations"] if names is None else names)
        unknown = [n for n in names if n not in self.task["observations"]]
        if unknown:
            raise ActionError(
                f"observation '{unknown[0]}' is not part of task {self.task['name']}",
                f"available: {', '.join(self.task['observations'])}",
            )
        kinds = self.observation_kinds
        sensors = [n for n in names if n not in kinds or kinds[n].sensor]  # poses: built here
        backend_observe = self.backend.observe_borrowed if borrowed else self.backend.observe
        obs = backend_observe(sensors) if sensors else {}
        if "poses" in names:
            obs["poses"] = self._poses()
        obs["scene_number"] = self.scene_index
        self.last_observation = (self.step_count, obs)  # for observers (recorder, live view): no extra render
        return obs

    def _poses(self) -> dict[str, dict]:
        self._capture_initial_pose()
        parent = self.robot.get("global_frame", "map")
        frames = self.backend.frame_transforms()
        if self.localisation == "noisy":
            T_true = se2_to_matrix(*self.backend.base_pose())
            T_believed = se2_to_matrix(*self.odometry)
            correction = T_believed @ np.linalg.inv(T_true)
            frames = {name: correction @ T for name, T in frames.items()}
        out = {}
        robot_frame = frames.get(self.robot.get("robot_frame", "robot"))
        for name in self.robot.get("poses", list(frames)):
            if name == "initial_pose":
                if self.initial_pose is not None:
                    initial = self.initial_pose.copy()
                    if robot_frame is not None:  # at the robot frame's height, as the original's TF lookup was
                        initial[2, 3] = robot_frame[2, 3]
                    out[name] = pose_observation(initial, parent)
            elif name in frames:
                out["camera" if "camera_left" in name else name] = pose_observation(frames[name], parent)
        return out
