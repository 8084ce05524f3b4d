"""The sensor poses that the render benchmarks (``render.py``, ``sensors_kernels.py``) time frames at: an
environment's trajectory, seen as the robot's sensors would see it.
"""

from __future__ import annotations

import numpy as np


def trajectory_views(scene) -> tuple[list, list, np.ndarray]:
    """``(cameras, lidars, angles)`` along ``scene``'s passive trajectory (its start pose when it has none):
    ``cameras`` the (4, 4) poses of the camera's optical frame in ``map``
    (``benchbot_sim_taichi.backend.trajectory_cameras``), ``lidars`` the (4, 4) poses of a laser 0.3 m above each
    trajectory pose, and ``angles`` the 360 beam angles (rad, float64) of a one-degree scan from −180°."""
    from benchbot.core.geometry import se2_to_matrix
    from benchbot_sim_taichi.backend import trajectory_cameras

    poses = scene.trajectory_se2 if len(scene.trajectory_se2) else scene.start_se2[None]
    lidars = [se2_to_matrix(*p, z=0.3) for p in poses]
    return trajectory_cameras(scene), lidars, np.radians(np.arange(-180.0, 180.0, 1.0))
