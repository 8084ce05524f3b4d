"""A Gymnasium environment over a BenchBot backend (``pip install benchbot[gym]``; docs/gym.md).

Importing this module registers two Gymnasium ids (so does importing ``benchbot`` when ``gymnasium`` is already
imported; the id ``"benchbot.gym:BenchBot-v0"`` imports this module itself):

* ``BenchBot-v0``: an in-process simulator, ``gym.make("BenchBot-v0", task=..., env=..., robot=..., seed=...,
  options={"width": 160, "height": 120})``; defaults ``semantic_slam:active:ground_truth``, ``miniroom:1``, ``carter``.
* ``BenchBotRemote-v0``: a backend served over HTTP (``benchbot run``), ``gym.make("BenchBotRemote-v0",
  address="http://127.0.0.1:10000/")`` (default: ``BENCHBOT_SUPERVISOR_ADDRESS``, else that address).

Observations (``gymnasium.spaces.Dict``): ``image_rgb`` Box (H, W, 3) uint8; ``image_depth`` Box (H, W) float32
metres (0 where nothing is hit); ``laser`` Box (N,) float64 ranges in metres (the scan's angles are fixed:
``laser['scans'][:, 1]`` of the API); ``pose`` Box (3,) float64 ``[x m, y m, yaw rad]`` of the robot in the map frame.
Entries the task does not observe are left out. Each entry is its observation kind's ``gym`` (``GymEntry``:
:mod:`benchbot.core.observations`), so a plugin's own sensor with one has its entry too; the kinds are the
episode's for a backend in this process, else this process's registry's (``Registry.observations``).

Actions: active tasks ``Discrete(4)``: 0 forward ``step_m``, 1 backward ``step_m``, 2 turn left ``turn_deg``,
3 turn right ``turn_deg``; passive tasks ``Discrete(1)`` (``move_next``). Reward 0 (BenchBot scores results, not
steps). ``terminated``: the robot collided (``info['result'] == 'COLLISION'``) or the passive trajectory is used up
(``'FINISHED'``); ``truncated``: ``max_steps`` steps since the last reset. A ``step`` after ``terminated`` warns and
returns the terminal observation again with ``terminated=True`` (the backend refuses every action until a reset).
"""

from __future__ import annotations

from typing import Any, Callable

#: The in-process environment's defaults (``BenchBot-v0``).
DEFAULT_TASK = "semantic_slam:active:ground_truth"
DEFAULT_ENV = "miniroom:1"
DEFAULT_ROBOT = "carter"

#: Gymnasium id → the keyword arguments it adds to the caller's.
ENV_IDS: dict[str, dict[str, Any]] = {
    "BenchBot-v0": {"task": DEFAULT_TASK, "env": DEFAULT_ENV, "robot": DEFAULT_ROBOT},
    "BenchBotRemote-v0": {},
}

#: Gymnasium id → its ``vector_entry_point``: ``gym.make_vec(id, num_envs=N)`` builds N batched robots in one
#: process by default (:mod:`benchbot.gym_vector`); ``vectorization_mode="sync"`` steps N environments instead.
VECTOR_ENTRY_POINTS: dict[str, str] = {"BenchBot-v0": "benchbot.gym_devices:make_vector_env"}


def _gym() -> Any:
    try:
        import gymnasium
    except ImportError:  # pragma: no cover - depends on the environment
        raise ImportError("benchbot.gym needs gymnasium: install the extra with `pip install benchbot[gym]`") from None
    return gymnasium


def check_episode_arguments(max_steps: Any, step_m: Any, turn_deg: Any, render_mode: Any) -> None:
    """Check the keywords every BenchBot Gym environment takes (single and vector alike).

    Raises:
        ValueError: ``max_steps`` not an integer >= 1, ``step_m`` (m) or ``turn_deg`` (degrees) not a positive finite
            number, or ``render_mode`` not None or ``'rgb_array'`` (one line naming the keyword).
    """
    if render_mode not in (None, "rgb_array"):
        raise ValueError(f"render_mode {render_mode!r} is not supported: use None or 'rgb_array'")
    if isinstance(max_steps, bool) or not (isinstance(max_steps, int) and max_steps >= 1):
        raise ValueError(f"max_steps must be an integer >= 1, got {max_steps!r}")
    for name, value in (("step_m", step_m), ("turn_deg", turn_deg)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value < float("inf"):
            raise ValueError(f"{name} must be a positive number, got {value!r}")


def lazy_classes(namespace: dict, makers: dict[str, Callable[[], type]]) -> Callable[[str], Any]:
    """A module ``__getattr__`` that builds each class of ``makers`` (name → maker) on first access and keeps it in
    the module's ``namespace`` (its ``globals()``), so importing the module does not need gymnasium.

    Raises (from the returned function):
        AttributeError: a name that is not in ``makers``. ImportError: gymnasium is not installed (from the maker).
    """
    def module_getattr(name: str) -> Any:
        if name not in makers:
            raise AttributeError(name)
        namespace[name] = cls = makers[name]()
        return cls

    return module_getattr


def register_envs() -> None:
    """Register :data:`ENV_IDS` with Gymnasium (entry point ``benchbot.gym:BenchBotEnv``, vector entry points
    :data:`VECTOR_ENTRY_POINTS`, no time limit wrapper: the environment truncates itself at ``max_steps``).
    Idempotent.

    Raises:
        ImportError: gymnasium is not installed.
    """
    gymnasium = _gym()
    for env_id, kwargs in ENV_IDS.items():
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point="benchbot.gym:BenchBotEnv",
                               vector_entry_point=VECTOR_ENTRY_POINTS.get(env_id), kwargs=dict(kwargs))


class _EnvMethods:
    """The methods of :class:`BenchBotEnv` (which adds ``gymnasium.Env``, imported when the class is built:
    :func:`make_env_class`)."""

    def __init__(self, backend: Any = None, address: str | None = None, max_steps: int = 200,
                 step_m: float = 0.25, turn_deg: float = 15.0, render_mode: str | None = None, *,
                 task: str | None = None, env: str | None = None, robot: str | None = None, seed: int = 0,
                 options: dict | None = None) -> None:
        from benchbot.api.benchbot import BenchBot

        spaces = _gym().spaces
        check_episode_arguments(max_steps, step_m, turn_deg, render_mode)
        self._owned = None  # the in-process service this environment built, closed by close()
        if task is not None or env is not None or robot is not None:
            if backend is not None or address is not None:
                raise ValueError("give task/env/robot (an in-process simulator) or backend or address, not both")
            from benchbot.core.registry import get_registry
            from benchbot.core.session import resolve_run, start_service

            registry = get_registry()
            run = resolve_run(registry, task or DEFAULT_TASK, robot or DEFAULT_ROBOT, env or DEFAULT_ENV)
            backend = self._owned = start_service(registry, run, seed=int(seed), options=dict(options or {}))
        elif options is not None or seed != 0:
            raise ValueError("seed and options configure an in-process simulator: give task/env/robot too")
        try:
            self.bot = BenchBot(backend=backend, supervisor_address=address, auto_start=False)
            self.bot.start()
        except BaseException:
            if self._owned is not None:
                self._owned.close()
            raise
        self.max_steps, self.step_m, self.turn_deg = max_steps, float(step_m), float(turn_deg)
        self.render_mode = render_mode
        task_actions = self.bot.config["task"]["actions"]
        self.active = "move_distance" in task_actions and "move_angle" in task_actions
        self.action_space = spaces.Discrete(4 if self.active else 1)
        obs, _ = self.bot.step(None)
        self._last_rgb = obs.get("image_rgb")
        # the observation kinds with a Gym entry (benchbot.core.observations): the episode's in this process,
        # else this process's registry (plugins' kinds included)
        kinds = getattr(getattr(backend, "episode", None), "observation_kinds", None)
        if kinds is None:
            from benchbot.core.registry import get_registry

            kinds = get_registry().observations
        #: ``{observation name: GymEntry}`` of the entries of :attr:`observation_space`
        self.gym_entries = {name: kind.gym for name, kind in kinds.items() if kind.gym is not None and name in obs}
        self.observation_space = spaces.Dict({entry.key: entry.space(spaces, obs[name])
                                              for name, entry in self.gym_entries.items()})
        self._steps = 0
        self._terminal: tuple[dict, dict] | None = None  # (observation, info) once terminated

    def _convert(self, obs: dict) -> dict:
        out = {entry.key: entry.value(obs[name]) for name, entry in self.gym_entries.items()}
        if "image_rgb" in out:
            self._last_rgb = out["image_rgb"]
        return out

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        """Back to a fresh scene 0, the robot at its start pose; returns ``(observation, {'scene_number': int})``.

        ``seed`` seeds :attr:`np_random` and, for an in-process simulator this environment built, the simulator
        (colour variation, sensor and odometry noise) from this reset on; a backend given or reached over HTTP
        keeps the seed it was started with.
        """
        super().reset(seed=seed)
        if seed is not None and self._owned is not None:
            self._owned.call(setattr, self._owned.episode, "seed", int(seed))
        self.bot._get("robot/reset")  # always a fresh scene 0, even when the robot has not moved
        self.bot._state = self.bot._get("robot/state")
        obs, _ = self.bot.step(None)
        self._steps = 0
        self._terminal = None
        return self._convert(obs), {"scene_number": obs["scene_number"]}

    def step(self, action: Any) -> tuple[dict, float, bool, bool, dict]:
        """Perform ``action`` (an int of :attr:`action_space`); returns ``(observation, 0.0, terminated,
        truncated, info)`` with ``info = {'result': 'SUCCESS' | 'COLLISION' | 'FINISHED', 'scene_number': int}``.

        After ``terminated`` (a collision, or a passive trajectory used up) the backend accepts no action until
        :meth:`reset`: a further ``step`` warns (``gymnasium.logger``) and returns the terminal observation and
        ``terminated=True`` again, with ``info['after_terminal'] = True``, without moving.

        Raises:
            ValueError: ``action`` is not in the action space. ConnectionError: the backend failed.
        """
        from benchbot.api.benchbot import ActionResult

        if not self.action_space.contains(action):
            raise ValueError(f"action {action!r} is not in {self.action_space}")
        if self._terminal is not None:
            _gym().logger.warn(
                "BenchBotEnv.step() called after terminated=True (the robot "
                f"{'collided' if self._terminal[1]['result'] == 'COLLISION' else 'finished its trajectory'}); "
                "call reset() first")
            obs, info = self._terminal
            return {k: v.copy() for k, v in obs.items()}, 0.0, True, False, {**info, "after_terminal": True}
        action = int(action)
        if self.active:
            name, kwargs = [("move_distance", {"distance": self.step_m}), ("move_distance", {"distance": -self.step_m}),
                            ("move_angle", {"angle": self.turn_deg}), ("move_angle", {"angle": -self.turn_deg})][action]
        else:
            name, kwargs = "move_next", {}
        obs, result = self.bot.step(name, **kwargs)
        self._steps += 1
        terminated = result is not ActionResult.SUCCESS
        truncated = not terminated and self._steps >= self.max_steps
        info = {"result": result.name, "scene_number": obs["scene_number"]}
        converted = self._convert(obs)
        if terminated:
            self._terminal = ({k: v.copy() for k, v in converted.items()}, dict(info))
        return converted, 0.0, terminated, truncated, info

    def render(self) -> Any:
        """The last colour image, (H, W, 3) uint8 (None when the task observes none)."""
        return self._last_rgb

    def close(self) -> None:
        """Close the connection to the backend, and the in-process simulator this environment built."""
        bot, self.bot = getattr(self, "bot", None), None
        if bot is not None:
            bot.close()
        owned, self._owned = getattr(self, "_owned", None), None
        if owned is not None:
            owned.close()


def make_env_class() -> type:
    """The :class:`BenchBotEnv` class (built lazily so importing this module does not define it before gymnasium):
    the methods of :class:`_EnvMethods` on ``gymnasium.Env``."""
    gymnasium = _gym()

    class BenchBotEnv(_EnvMethods, gymnasium.Env):
        """BenchBot as a ``gymnasium.Env`` (the module docstring gives the spaces and the episode contract).

        Three ways to reach a backend, exactly one of them:

        * ``task``/``env``/``robot`` (any of them; the others default to :data:`DEFAULT_TASK`, :data:`DEFAULT_ENV`,
          :data:`DEFAULT_ROBOT`): an in-process simulator that this environment builds (``seed``, ``options``) and
          closes;
        * ``backend``: a :class:`~benchbot.server.BackendService` of this process (the caller closes it);
        * neither: HTTP to ``address`` (default ``BENCHBOT_SUPERVISOR_ADDRESS``, else ``http://127.0.0.1:10000/``).

        Args:
            backend: a ``BackendService`` in this process, or None.
            address: the backend's ``http://host:port/`` (with no backend and no task/env/robot).
            max_steps: steps after a reset before ``truncated`` (≥ 1).
            step_m: metres per forward/backward action (> 0). turn_deg: degrees per turn action (> 0).
            render_mode: None or ``'rgb_array'`` (:meth:`render` returns the last colour image either way).
            task, env, robot: the task name, the environment ``name:variant`` and the robot name of an in-process
                simulator (``benchbot list tasks|environments|robots``).
            seed: the in-process simulator's seed (colour variation, sensor and odometry noise); ``reset(seed=s)``
                reseeds it.
            options: backend options of the in-process simulator, e.g. ``{'width': 160, 'height': 120, 'arch':
                'cpu'}`` (camera size in pixels; default 640×480).

        Raises:
            ValueError: both an in-process simulator and a backend or address are asked for, or a bad
                ``max_steps``/``step_m``/``turn_deg``/``render_mode``.
            benchbot.core.errors.SpecError: an unknown task, environment or robot, or a combination the task
                refuses (one line naming it, with a hint).
            ConnectionError: no backend answers at ``address``.
        """

        metadata = {"render_modes": ["rgb_array"]}

    return BenchBotEnv


__getattr__ = lazy_classes(globals(), {"BenchBotEnv": make_env_class})


try:
    register_envs()
except ImportError:  # gymnasium missing: BenchBotEnv says how to install it when first used
    pass

__all__ = ["BenchBotEnv", "DEFAULT_ENV", "DEFAULT_ROBOT", "DEFAULT_TASK", "ENV_IDS", "VECTOR_ENTRY_POINTS",
           "check_episode_arguments", "lazy_classes", "make_env_class", "register_envs"]
