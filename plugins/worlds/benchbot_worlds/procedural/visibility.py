"""Which ground-truth objects a robot's camera sees from which poses in a procedural home (NumPy; metres, radians,
``map`` frame, z up).

**What "seen" means** (the guarantee of a procedural home's passive trajectory): an object is seen from a robot pose
``(x, y, yaw)`` when at least one of its 9 sample points (the cuboid's centroid and its 8 corners) is

1. inside the camera's image: the camera sits at the robot's pose carried by :attr:`Camera.mount_xyz` (x forward,
   y left from the robot's footprint centre; z above the floor), level, looking along the robot's yaw; with the
   point at depth ``u`` ahead, ``v`` left and ``w`` up of the camera: ``u >= min_depth_m``, ``|v| <= u·tan(hfov/2)``
   and ``|w| <= u·tan(vfov/2)`` where ``tan(vfov/2) = tan(hfov/2)·height/width`` (a pinhole of square pixels:
   90° × 73.7° for carter's 640 × 480 at 90°);
2. within :attr:`Camera.max_range_m` (3-D distance from the camera, 8 m by default);
3. in the line of sight: the 2-D segment from the camera to the point's xy passes through the interior of no wall
   rectangle (:func:`~.free_space.wall_rects`: walls are full height, doorways are open full height; a point on a
   wall's face is not hidden by it).

Objects do not hide each other (no occlusion by furniture): a known simplification.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .free_space import object_boxes, wall_rects
from .layout import Layout

#: Height (m) of the robot frame above the floor in carter's poses (BEAR's trajectory poses' z).
ROBOT_Z_M = 0.244


@dataclass(frozen=True)
class Camera:
    """A level pinhole camera on the robot: image ``width`` × ``height`` pixels, horizontal field of view
    ``hfov_deg``, ``mount_xyz`` (m: forward, left, height above the floor), objects seen up to ``max_range_m`` and
    from ``min_depth_m`` ahead."""

    width: int = 640
    height: int = 480
    hfov_deg: float = 90.0
    mount_xyz: tuple[float, float, float] = (0.11, 0.06, 1.054)
    max_range_m: float = 8.0
    min_depth_m: float = 0.1

    @property
    def tan_h(self) -> float:
        return math.tan(math.radians(self.hfov_deg) / 2)

    @property
    def tan_v(self) -> float:
        return self.tan_h * self.height / self.width


#: carter's camera (plugins/sim_taichi/benchbot_sim_taichi/robots/carter.yaml).
CARTER_CAMERA = Camera()


def sample_points(objects: list[dict]) -> np.ndarray:
    """(N, 9, 3) float64: each object's centroid then its cuboid's 8 corners (m, map frame)."""
    lo, hi, _ = object_boxes(objects)
    corners = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], dtype=np.float64)
    pts = lo[:, None, :] + corners[None] * (hi - lo)[:, None, :]
    return np.concatenate([((lo + hi) / 2)[:, None, :], pts], axis=1)


def segments_blocked(p0: np.ndarray, p1: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(M,) bool: whether each 2-D segment ``p0``→``p1`` ((M, 2) each) passes through the open interior of one of
    the rectangles ``lo``/``hi`` ((W, 2) each) for a positive length (slab test)."""
    out = np.zeros(len(p0), dtype=bool)
    step = max(1, (1 << 16) // max(1, len(lo)))
    for s in range(0, len(p0) if len(lo) else 0, step):
        out[s:s + step] = _blocked(p0[s:s + step], p1[s:s + step], lo, hi)
    return out


def _blocked(p0: np.ndarray, p1: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    a, d = p0[:, None, :], (p1 - p0)[:, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        ta, tb = (lo[None] - a) / d, (hi[None] - a) / d
    par = np.abs(d) < 1e-12
    inside = (a > lo[None]) & (a < hi[None])
    t_in = np.where(par, np.where(inside, -np.inf, np.inf), np.minimum(ta, tb)).max(axis=2)
    t_out = np.where(par, np.where(inside, np.inf, -np.inf), np.maximum(ta, tb)).min(axis=2)
    return (np.minimum(t_out, 1.0) - np.maximum(t_in, 0.0) > 1e-9).any(axis=1)


def seen_pairs(se2: np.ndarray, which: np.ndarray, points: np.ndarray, walls: tuple[np.ndarray, np.ndarray],
               camera: Camera = CARTER_CAMERA) -> np.ndarray:
    """(M,) bool: whether object ``which[m]`` (its sample points ``points[which[m]]``, (N, S, 3)) is seen from the
    robot pose ``se2[m]`` ((M, 3) ``[x, y, yaw]``), as the module says, the walls being ``walls`` = (lo, hi)."""
    se2 = np.asarray(se2, dtype=np.float64).reshape(-1, 3)
    c, s = np.cos(se2[:, 2]), np.sin(se2[:, 2])
    mx, my, mz = camera.mount_xyz
    cam = np.stack([se2[:, 0] + c * mx - s * my, se2[:, 1] + s * mx + c * my], axis=1)
    rel = points[which] - np.concatenate([cam, np.full((len(se2), 1), mz)], axis=1)[:, None, :]  # (M, S, 3)
    u = c[:, None] * rel[..., 0] + s[:, None] * rel[..., 1]
    v = -s[:, None] * rel[..., 0] + c[:, None] * rel[..., 1]
    ok = ((u >= camera.min_depth_m) & (np.abs(v) <= u * camera.tan_h) & (np.abs(rel[..., 2]) <= u * camera.tan_v)
          & (np.linalg.norm(rel, axis=2) <= camera.max_range_m))
    seen = np.zeros(len(se2), dtype=bool)
    for k in range(ok.shape[1]):  # the line of sight only for the pairs no earlier point showed
        m = np.nonzero(ok[:, k] & ~seen)[0]
        if len(m):
            seen[m] = ~segments_blocked(cam[m], points[which[m], k, :2], *walls)
    return seen


def poses_to_se2(poses) -> np.ndarray:
    """(P, 3) float64 ``[x, y, yaw]`` of 7-number poses ``[qw, qx, qy, qz, x, y, z]`` (the yaw of the rotation)."""
    p = np.asarray(poses, dtype=np.float64).reshape(-1, 7)
    qw, qx, qy, qz = p[:, 0], p[:, 1], p[:, 2], p[:, 3]
    yaw = np.arctan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
    return np.stack([p[:, 4], p[:, 5], yaw], axis=1)


def seen_matrix(layout: Layout, objects: list[dict], poses, *, camera: Camera = CARTER_CAMERA,
                walls: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """(P, N) bool: object n is seen from pose p (as the module says). ``poses``: P 7-number poses
    ``[qw, qx, qy, qz, x, y, z]`` (map frame); ``walls``: (lo, hi) (W, 2) wall rectangles instead of
    :func:`~.free_space.wall_rects` of ``layout``.

    Raises:
        ValueError: a pose is not 7 numbers, or an object lacks centroid/extent.
    """
    se2 = poses_to_se2(poses) if len(poses) else np.zeros((0, 3))
    points = sample_points(objects)
    walls = wall_rects(layout) if walls is None else walls
    out = np.zeros((len(se2), len(points)), dtype=bool)
    if len(se2) and len(points):
        pp, nn = np.meshgrid(np.arange(len(se2)), np.arange(len(points)), indexing="ij")
        out[:] = seen_pairs(se2[pp.ravel()], nn.ravel(), points, walls, camera).reshape(out.shape)
    return out


def unseen_objects(layout: Layout, objects: list[dict], poses, *, camera: Camera = CARTER_CAMERA,
                   walls: tuple[np.ndarray, np.ndarray] | None = None) -> list[int]:
    """Indices (ascending) of the ``objects`` seen from none of ``poses`` (7-number poses, map frame), "seen" as
    the module defines it; ``walls`` as :func:`seen_matrix`.

    Raises:
        ValueError: as :func:`seen_matrix`.
    """
    if not objects:
        return []
    return [int(i) for i in np.nonzero(~seen_matrix(layout, objects, poses, camera=camera, walls=walls).any(axis=0))[0]]
