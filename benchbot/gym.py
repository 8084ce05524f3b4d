"""A Gymnasium environment over a BenchBot backend (``pip install benchbot[gym]``).

Observations (``gymnasium.spaces.Dict``): ``image_rgb`` Box (H, W, 3) uint8; ``image_depth`` Box (H, W) float32
metres (0 where nothing is hit); ``laser`` Box (N,) float64 ranges in metres (the scan's angles are fixed:
``laser['scans'][:, 1]`` of the API); ``pose`` Box (3,) float64 ``[x m, y m, yaw rad]`` of the robot in the map frame.
Entries the task does not observe are left out.

Actions: active tasks ``Discrete(4)``: 0 forward ``step_m``, 1 backward ``step_m``, 2 turn left ``turn_deg``,
3 turn right ``turn_deg``; passive tasks ``Discrete(1)`` (``move_next``). Reward 0 (BenchBot scores results, not
steps). ``terminated``: collision or trajectory finished; ``truncated``: ``max_steps`` reached.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from benchbot.api.benchbot import ActionResult, BenchBot


def _gym() -> Any:
    try:
        import gymnasium
    except ImportError:  # pragma: no cover - depends on the environment
        raise ImportError("benchbot.gym needs gymnasium: install the extra with `pip install benchbot[gym]`") from None
    return gymnasium


def _yaw(rpy: Any) -> float:
    return float(rpy[2])


def make_env_class() -> type:
    """The :class:`BenchBotEnv` class (built lazily so importing this module does not import gymnasium)."""
    gymnasium = _gym()
    spaces = gymnasium.spaces

    class BenchBotEnv(gymnasium.Env):
        """BenchBot as a ``gymnasium.Env``.

        Args:
            backend: a :class:`~benchbot.core.server.BackendService` in this process, or None to connect over HTTP.
            address: the backend's ``http://host:port/`` (with ``backend=None``; default as :class:`BenchBot`).
            max_steps: episode length before ``truncated``.
            step_m: metres per forward/backward action. turn_deg: degrees per turn action.

        Raises:
            ConnectionError: no backend answers.
        """

        metadata = {"render_modes": ["rgb_array"]}

        def __init__(self, backend: Any = None, address: str | None = None, max_steps: int = 200,
                     step_m: float = 0.25, turn_deg: float = 15.0, render_mode: str | None = None) -> None:
            self.bot = BenchBot(backend=backend, supervisor_address=address, auto_start=False)
            self.bot.start()
            self.max_steps, self.step_m, self.turn_deg = max_steps, step_m, turn_deg
            self.render_mode = render_mode
            task_actions = self.bot.config["task"]["actions"]
            self.active = "move_distance" in task_actions and "move_angle" in task_actions
            self.action_space = spaces.Discrete(4 if self.active else 1)
            obs, _ = self.bot.step(None)
            self._last_rgb = obs.get("image_rgb")
            entries: dict[str, Any] = {}
            if "image_rgb" in obs:
                entries["image_rgb"] = spaces.Box(0, 255, obs["image_rgb"].shape, np.uint8)
            if "image_depth" in obs:
                entries["image_depth"] = spaces.Box(0.0, np.inf, obs["image_depth"].shape, np.float32)
            if "laser" in obs:
                laser = obs["laser"]
                entries["laser"] = spaces.Box(0.0, np.inf, (laser["scans"].shape[0],), np.float64)
            if "poses" in obs:
                entries["pose"] = spaces.Box(-np.inf, np.inf, (3,), np.float64)
            self.observation_space = spaces.Dict(entries)
            self._steps = 0

        def _convert(self, obs: dict) -> dict:
            out: dict[str, Any] = {}
            if "image_rgb" in self.observation_space.spaces:
                out["image_rgb"] = np.array(obs["image_rgb"], dtype=np.uint8)
                self._last_rgb = out["image_rgb"]
            if "image_depth" in self.observation_space.spaces:
                out["image_depth"] = np.clip(np.array(obs["image_depth"], dtype=np.float32), 0.0, None)
            if "laser" in self.observation_space.spaces:
                out["laser"] = np.clip(np.array(obs["laser"]["scans"][:, 0], dtype=np.float64), 0.0, None)
            if "pose" in self.observation_space.spaces:
                robot = obs["poses"]["robot"]
                t = robot["translation_xyz"]
                out["pose"] = np.array([t[0], t[1], _yaw(robot["rotation_rpy"])], dtype=np.float64)
            return out

        def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
            """Back to a fresh scene 0 (robot at its start pose); returns ``(observation, {'scene_number': int})``."""
            super().reset(seed=seed)
            obs, _ = self._hard_reset()  # always a fresh scene 0: the robot at its start pose
            self._steps = 0
            return self._convert(obs), {"scene_number": obs["scene_number"]}

        def _hard_reset(self) -> tuple[dict, ActionResult]:
            self.bot._get("robot/reset")
            self.bot._state = self.bot._get("robot/state")
            return self.bot.step(None)

        def step(self, action: Any) -> tuple[dict, float, bool, bool, dict]:
            """Perform action ``action`` (an int of :attr:`action_space`); returns ``(observation, 0.0, terminated,
            truncated, {'result': ActionResult name, 'scene_number': int})``.

            Raises:
                ValueError: ``action`` is not in the action space. ConnectionError: the backend failed.
            """
            if not self.action_space.contains(action):
                raise ValueError(f"action {action!r} is not in {self.action_space}")
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
            return self._convert(obs), 0.0, terminated, truncated, info

        def render(self) -> Any:
            """The last colour image, (H, W, 3) uint8 (None when the task observes none)."""
            return self._last_rgb

        def close(self) -> None:
            """Close the connection to the backend."""
            self.bot.close()

    return BenchBotEnv


def __getattr__(name: str) -> Any:
    if name == "BenchBotEnv":
        cls = make_env_class()
        globals()["BenchBotEnv"] = cls
        return cls
    raise AttributeError(name)


__all__ = ["BenchBotEnv", "make_env_class"]
