"""Planar robot motion for the Taichi simulator (pure NumPy/math, no Taichi): the pose controller's commands
integrated exactly (:func:`benchbot.core.motion.integrate_unicycle`) and a circular-footprint collision check against
the room walls and object boxes.

Frames and units: SE(2) poses ``[x m, y m, yaw rad]`` in the ``map`` frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from benchbot.core.motion import ControllerGains, PoseControllers, integrate_unicycles
from benchbot.core.robot import MotionOutcome


#: How often (in controller ticks) :func:`drive_robots` finds again the obstacles near each robot.
NEAR_REFRESH_TICKS = 8


def _box_distances(p: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(M, C) distances (m) from points ``p`` (M, 2) to axis-aligned boxes ``lo``/``hi`` ((M or 1, C, 2)); 0 inside."""
    q = np.clip(p[:, None, :], lo, hi)
    return np.hypot(q[..., 0] - p[:, None, 0], q[..., 1] - p[:, None, 1])


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

    def clearances(self, xy: np.ndarray, among: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Signed clearances (M,) float64 (m) between the footprint at each of ``xy`` (M, 2) and its nearest
        obstacle (negative: overlap), and that obstacle's index (M,) int64 into :attr:`names` (-1: the walls).

        Args:
            among: (M, C) int64 obstacle indices per point (from :meth:`near`) to check instead of all K; the walls
                are always checked.
        """
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        wall = np.minimum(np.minimum(p[:, 0] - self.room_min[0], self.room_max[0] - p[:, 0]),
                          np.minimum(p[:, 1] - self.room_min[1], self.room_max[1] - p[:, 1])) - self.radius
        best, index = wall, np.full(len(p), -1, dtype=np.int64)
        if among is not None and among.shape[1]:
            lo, hi = self._padded()
            d = _box_distances(p, lo[among], hi[among]) - self.radius
        elif among is None and len(self.rect_min):
            d = _box_distances(p, self.rect_min[None], self.rect_max[None]) - self.radius
            among = np.broadcast_to(np.arange(len(self.rect_min)), d.shape)
        else:
            return best, index
        i = np.argmin(d, axis=1)
        rows = np.arange(len(p))
        nearest = d[rows, i]
        closer = nearest < best
        return np.where(closer, nearest, best), np.where(closer, among[rows, i], index)

    def near(self, xy: np.ndarray, reach: float) -> np.ndarray:
        """(M, C) int64: for each of ``xy`` (M, 2), the obstacles whose boxes lie within ``reach`` + the footprint
        radius (m) of it, padded with K (a box infinitely far away): the only ones a footprint that moves less than
        ``reach`` from there can touch."""
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        if not len(self.rect_min):
            return np.zeros((len(p), 0), dtype=np.int64)
        close = _box_distances(p, self.rect_min[None], self.rect_max[None]) <= reach + self.radius
        width = int(close.sum(axis=1).max())
        order = np.argsort(~close, axis=1, kind="stable")[:, :width]  # the close ones first, in index order
        return np.where(np.take_along_axis(close, order, axis=1), order, len(self.rect_min))

    def _padded(self) -> tuple[np.ndarray, np.ndarray]:
        """:attr:`rect_min`, :attr:`rect_max` with one box at infinity appended (index K, :meth:`near`'s padding)."""
        far = np.full((1, 2), np.inf)
        return np.concatenate([self.rect_min, far]), np.concatenate([self.rect_max, far])

    def clearance(self, xy: np.ndarray) -> tuple[float, str]:
        """Signed clearance (m) between the footprint at ``xy`` (2,) and the nearest obstacle (negative: overlap),
        and that obstacle's name (``'wall'`` for the walls)."""
        best, index = self.clearances(np.asarray(xy, dtype=np.float64)[:2])
        return float(best[0]), "wall" if index[0] < 0 else self.names[int(index[0])]

    def collides(self, xy: np.ndarray) -> bool:
        """Whether the footprint circle centred at ``xy`` (2,) touches a wall or an obstacle box."""
        return self.clearance(xy)[0] <= 0.0


def drive(pose: np.ndarray, goal: np.ndarray, obstacles: Obstacles | None,
          gains: ControllerGains = ControllerGains()) -> tuple[np.ndarray, MotionOutcome]:
    """Drive from ``pose`` to ``goal`` (both (3,) ``[x, y, yaw]``): :func:`drive_robots` of one robot.

    Returns:
        (final pose (3,) float64, :class:`MotionOutcome` with the simulated duration including ``settle_s``).
    """
    poses, collided, seconds = drive_robots(np.asarray(pose, dtype=np.float64).reshape(1, 3),
                                            np.asarray(goal, dtype=np.float64).reshape(1, 3), obstacles, gains)
    return poses[0], MotionOutcome(collided=bool(collided[0]), duration_s=float(seconds[0]))


def drive_robots(poses: np.ndarray, goals: np.ndarray, obstacles: Obstacles | None,
                 gains: ControllerGains = ControllerGains()) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Drive N robots from ``poses`` to ``goals`` (both (N, 3) ``[x, y, yaw]``, map frame) together with
    :class:`~benchbot.core.motion.PoseControllers`, integrating each command exactly over ``1 / gains.rate_hz``
    seconds of simulated time. Before each step, every moving robot's next pose is checked against ``obstacles``
    (not against the other robots); on contact that robot stays at its current pose and stops. A robot whose goal
    is its pose does not move.

    Returns:
        (final poses (N, 3) float64, collided (N,) bool, simulated seconds (N,) float64: until the contact, or the
        motion plus ``gains.settle_s``).
    """
    dt = 1.0 / gains.rate_hz
    ctl = PoseControllers(goals, gains)
    poses = np.array(poses, dtype=np.float64).reshape(-1, 3)
    collided = np.zeros(len(poses), dtype=bool)
    ticks = np.zeros(len(poses))
    # each robot checks only the obstacles near it, found again every NEAR_REFRESH_TICKS ticks within the farthest it
    # can move meanwhile (so the outcome is that of checking every obstacle)
    reach = NEAR_REFRESH_TICKS * max(gains.linear_max_mps, -gains.linear_min_mps) * dt + 1e-6
    tick = 0
    while (moving := ctl.command(poses)).any():
        if obstacles is not None and tick % NEAR_REFRESH_TICKS == 0:
            near = obstacles.near(poses[:, :2], reach)
        tick += 1
        idx = np.flatnonzero(moving)
        nxt = integrate_unicycles(poses[idx], ctl.v[idx], ctl.w[idx], dt)
        hit = (np.zeros(len(idx), dtype=bool) if obstacles is None
               else obstacles.clearances(nxt[:, :2], among=near[idx])[0] <= 0.0)
        collided[idx[hit]] = True
        ctl.stop(idx[hit])
        poses[idx[~hit]] = nxt[~hit]
        ticks[idx[~hit]] += 1
    return poses, collided, np.where(collided, ticks * dt, ticks * dt + gains.settle_s)
