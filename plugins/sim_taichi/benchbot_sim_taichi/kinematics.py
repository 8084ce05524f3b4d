"""Planar robot motion for the Taichi simulator (pure NumPy/math, no Taichi): the pose controller's commands
integrated exactly (:func:`benchbot.core.motion.integrate_unicycle`) and a circular-footprint collision check against
the room walls and object boxes.

Frames and units: SE(2) poses ``[x m, y m, yaw rad]`` in the ``map`` frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from benchbot.core.motion import ControllerGains, PoseController, integrate_unicycle
from benchbot.core.robot import MotionOutcome


@dataclass
class Obstacles:
    """The obstacles of the robot's footprint.

    Attributes:
        rect_min, rect_max: (K, 2) float64 xy rectangles of the object boxes whose bottom is below the robot's
            ``max_height_m`` (the others pass over the robot).
        names: (K,) object names (for messages).
        room_min, room_max: (2,) float64 xy of the walls' inner faces.
        radius: footprint radius, metres.
    """

    rect_min: np.ndarray
    rect_max: np.ndarray
    names: list[str]
    room_min: np.ndarray
    room_max: np.ndarray
    radius: float

    @classmethod
    def from_scene(cls, scene, radius: float, max_height: float) -> "Obstacles":
        """Obstacles of a :class:`~benchbot_sim_taichi.scene.model.Scene` for a robot of footprint ``radius`` (m) and
        height ``max_height`` (m): every object box with ``min z < max_height``, the scene's other obstacle rectangles
        with ``obstacle_bottom < max_height`` (a furnished home's walls and furniture), and the shell's four walls."""
        keep = scene.box_min[:, 2].astype(np.float64) < max_height
        low = np.asarray(scene.obstacle_bottom, np.float64) < max_height
        extra_min = np.asarray(scene.obstacle_min, np.float64).reshape(-1, 2)[low]
        extra_max = np.asarray(scene.obstacle_max, np.float64).reshape(-1, 2)[low]
        return cls(
            rect_min=np.concatenate([scene.box_min[keep, :2].astype(np.float64), extra_min]),
            rect_max=np.concatenate([scene.box_max[keep, :2].astype(np.float64), extra_max]),
            names=[n for n, k in zip(scene.box_names, keep) if k] + [n for n, k in zip(scene.obstacle_names, low) if k],
            room_min=scene.room_min[:2].astype(np.float64),
            room_max=scene.room_max[:2].astype(np.float64),
            radius=float(radius),
        )

    def clearance(self, xy: np.ndarray) -> tuple[float, str]:
        """Signed clearance (m) between the footprint at ``xy`` (2,) and the nearest obstacle (negative: overlap),
        and that obstacle's name (``'wall'`` for the walls)."""
        p = np.asarray(xy, dtype=np.float64)[:2]
        wall = float(min(p[0] - self.room_min[0], self.room_max[0] - p[0],
                         p[1] - self.room_min[1], self.room_max[1] - p[1])) - self.radius
        best, name = wall, "wall"
        if len(self.rect_min):
            q = np.clip(p, self.rect_min, self.rect_max)
            d = np.hypot(q[:, 0] - p[0], q[:, 1] - p[1]) - self.radius
            i = int(np.argmin(d))
            if d[i] < best:
                best, name = float(d[i]), self.names[i]
        return best, name

    def collides(self, xy: np.ndarray) -> bool:
        """Whether the footprint circle centred at ``xy`` (2,) touches a wall or an obstacle box."""
        return self.clearance(xy)[0] <= 0.0


def drive(pose: np.ndarray, goal: np.ndarray, obstacles: Obstacles | None,
          gains: ControllerGains = ControllerGains()) -> tuple[np.ndarray, MotionOutcome]:
    """Drive from ``pose`` to ``goal`` (both (3,) ``[x, y, yaw]``) with :class:`PoseController`, integrating each
    command exactly over ``1 / gains.rate_hz`` seconds of simulated time. Before each step, the next pose is checked
    against ``obstacles``; on contact the robot stays at the current pose and the outcome says ``collided``.

    Returns:
        (final pose (3,) float64, :class:`MotionOutcome` with the simulated duration including ``settle_s``).
    """
    dt = 1.0 / gains.rate_hz
    ctl = PoseController(np.asarray(goal, dtype=np.float64), gains)
    pose = np.asarray(pose, dtype=np.float64).copy()
    t = 0.0
    while (cmd := ctl.command(pose)) is not None:
        nxt = integrate_unicycle(pose, cmd[0], cmd[1], dt)
        if obstacles is not None and obstacles.collides(nxt[:2]):
            return pose, MotionOutcome(collided=True, duration_s=t)
        pose = nxt
        t += dt
    return pose, MotionOutcome(collided=False, duration_s=t + gains.settle_s)
