"""Planar robot motion for the Taichi simulator (pure NumPy/math, no Taichi): the pose controller's commands
integrated exactly (:func:`benchbot.core.motion.integrate_unicycle`) and a circular-footprint collision check against
the room walls and object boxes.

Frames and units: SE(2) poses ``[x m, y m, yaw rad]`` in the ``map`` frame.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from benchbot.core.geometry import se2_compose_many, se2_relative_many
from benchbot.core.motion import ControllerGains, PoseControllers, integrate_unicycles
from benchbot.core.robot import MotionOutcome


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
        """Obstacles of a :class:`~benchbot_worlds.scene.model.Scene` for a robot of footprint ``radius`` (m) and
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
        """(M, C) int64: for each of ``xy`` (M, 2), the obstacles whose boxes, grown by ``reach`` + the footprint
        radius (m) on every side, contain it (every box within that distance, and a few corner boxes farther),
        padded with K (a box infinitely far away): all a footprint that moves less than ``reach`` from there can
        touch."""
        p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        grow = reach + self.radius
        close = ((p[:, None, :] >= self.rect_min[None] - grow) & (p[:, None, :] <= self.rect_max[None] + grow)).all(-1)
        rows, cols = np.nonzero(close)  # row-major: each row's boxes in index order
        counts = np.bincount(rows, minlength=len(p))
        out = np.full((len(p), int(counts.max()) if len(p) else 0), len(self.rect_min), dtype=np.int64)
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        out[rows, np.arange(len(rows)) - starts[rows]] = cols
        return out

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
    """Drive N robots from ``poses`` to ``goals`` (both (N, 3) ``[x, y, yaw]``, map frame) with
    :class:`~benchbot.core.motion.PoseControllers`, each command integrated exactly over ``1 / gains.rate_hz``
    seconds of simulated time. Before each tick, a robot's next pose is checked against ``obstacles`` (not against
    the other robots); on contact that robot stays at its current pose and stops. A robot whose goal is its pose
    does not move.

    The controller's law depends only on the goal relative to the robot, so each robot's path is its relative
    goal's path from the origin (:func:`local_path`, the relative goal rounded to :data:`GOAL_QUANTUM`, cached)
    carried into the map frame, and the collisions of all ticks of all robots are checked at once. One robot moves
    exactly as it does in a batch.

    Memory: the paths are (N, T + 1, 3) float64, T the longest path's ticks (at most two phases of
    ``gains.phase_timeout_s`` at ``gains.rate_hz``: 1,200 by default); the collision checks go by blocks of robots of
    about :data:`CHECK_PAIRS` (pose, obstacle) pairs.

    Returns:
        (final poses (N, 3) float64, collided (N,) bool, simulated seconds (N,) float64: until the contact, or the
        motion plus ``gains.settle_s``).

    Raises:
        ValueError: a pose or goal that is not finite (:class:`~benchbot.core.motion.PoseControllers`).
    """
    poses = np.array(poses, dtype=np.float64).reshape(-1, 3)
    n = len(poses)
    relative = np.round(se2_relative_many(poses, np.asarray(goals, dtype=np.float64).reshape(-1, 3)) / GOAL_QUANTUM)
    keys, which = np.unique(relative, axis=0, return_inverse=True)
    paths = [local_path(tuple(key * GOAL_QUANTUM), gains) for key in keys]
    ticks = np.array([len(path) - 1 for path in paths], dtype=np.int64)[which.reshape(-1)]
    longest = int(ticks.max()) if n else 0
    local = np.zeros((len(paths), longest + 1, 3))
    for u, path in enumerate(paths):
        local[u, :len(path)], local[u, len(path):] = path, path[-1]
    path = se2_compose_many(poses[:, None, :], local[which.reshape(-1)])  # (N, T + 1, 3) map poses after 0..T ticks
    path[:, 0] = poses  # exactly where they are (composing with the identity may round the last bit)
    dt = 1.0 / gains.rate_hz
    collided = np.zeros(n, dtype=bool)
    first = ticks.copy()
    if obstacles is not None and longest:
        reach = float(np.hypot(local[..., 0], local[..., 1]).max()) + 1e-6
        near = obstacles.near(poses[:, :2], reach)
        hit = np.zeros((n, longest), dtype=bool)
        # robots in blocks of about CHECK_PAIRS (point, obstacle) pairs: the temporaries stay bounded (a 30 s phase
        # is 600 ticks at 20 Hz) however many robots, ticks and nearby obstacles there are
        rows = max(1, CHECK_PAIRS // (longest * max(1, near.shape[1])))
        for start in range(0, n, rows):
            block = near[start:start + rows]
            block = block[:, :int((block < len(obstacles.rect_min)).sum(axis=1).max())]  # drop all-padding columns
            hit[start:start + rows] = obstacles.clearances(
                path[start:start + rows, 1:, :2].reshape(-1, 2),
                among=np.repeat(block, longest, axis=0))[0].reshape(len(block), longest) <= 0.0
        hit &= np.arange(longest)[None, :] < ticks[:, None]
        collided = hit.any(axis=1)
        first = np.where(collided, np.argmax(hit, axis=1), ticks)  # ticks made before the contact
    final = path[np.arange(n), first]
    return final, collided, np.where(collided, first * dt, first * dt + gains.settle_s)


#: Relative goals are rounded to this (m and rad) so that robots given the same move share one path.
GOAL_QUANTUM = 1e-9

#: At most about this many (footprint pose, obstacle) pairs are checked at once by :func:`drive_robots` (its
#: temporaries: about 80 bytes a pair).
CHECK_PAIRS = 1 << 20


@functools.lru_cache(maxsize=4096)
def local_path(relative_goal: tuple[float, float, float], gains: ControllerGains) -> np.ndarray:
    """(T + 1, 3) float64: the poses after 0..T ticks of the pose controller driving from the origin to
    ``relative_goal`` ``(x m, y m, yaw rad)`` (its frame), each command integrated exactly
    (:func:`~benchbot.core.motion.integrate_unicycles`), until the controller is done (read-only, cached)."""
    ctl = PoseControllers(np.array([relative_goal]), gains)
    pose = np.zeros((1, 3))
    out = [pose[0]]
    while ctl.command(pose)[0]:
        pose = integrate_unicycles(pose, ctl.v, ctl.w, 1.0 / gains.rate_hz)
        out.append(pose[0])
    path = np.array(out)
    path.flags.writeable = False
    return path
