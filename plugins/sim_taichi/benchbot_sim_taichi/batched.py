"""N simulated robots in one scene, moved and sensed together: the ``sim_taichi`` backend's
:class:`~benchbot.core.robot.BatchedRobots` (:meth:`TaichiSimBackend.batched
<benchbot_sim_taichi.backend.TaichiSimBackend.batched>`), behind the Gym vector environment
(:mod:`benchbot.gym_vector`).

One renderer holds the scene; each :meth:`TaichiBatchedRobots.observe` renders every robot's camera and laser in ONE
kernel launch (:meth:`~benchbot_sim_taichi.render.renderer.Renderer.render_sensors`). Motion is the single robot's
law on arrays (:func:`benchbot_sim_taichi.kinematics.drive_robots`): each robot moves exactly as it would alone, and the
robots do not collide with one another. Frames as the backend's (its module docstring): the camera's optical frame
and the lidar at their mounts on each robot's footprint.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from benchbot.core.errors import BackendError
from benchbot.core.geometry import se2_to_matrices
from benchbot.core.robot import BatchedRobots

from benchbot_sim_taichi.kinematics import drive_robots

#: What the batch senses, each observation kind (of the registry's, :mod:`benchbot.core.observations`) by the output
#: of the renderer's batched kernel that answers it (``Renderer.render_sensors``); the Gym vector environment reads
#: the kinds' Gym entries from the registry.
RENDERED = {"image_rgb": "rgb", "image_depth": "depth", "laser": "ranges"}


class TaichiBatchedRobots(BatchedRobots):
    """``count`` robots of ``backend`` (a :class:`~benchbot_sim_taichi.backend.TaichiSimBackend` with a loaded scene),
    all at the scene's start pose; see :class:`~benchbot.core.robot.BatchedRobots` for the contract.

    ``observe(..., on_device=True)``: on CUDA the images are
    :class:`~benchbot_sim_taichi.render.dlpack.DeviceArray` s of the renderer's GPU buffers (DLPack and the CUDA Array
    Interface, no copy); on the CPU they are NumPy views of its buffers (NumPy exports DLPack itself). Either way the
    next ``observe`` writes over them, after waiting on CUDA for the work queued on every stream (a consumer's reads
    of the last frames, even on a stream of its own: ``Renderer.wait_for_readers``). The laser's ranges always come
    back as NumPy.

    Raises:
        BackendError: no scene is loaded; ``count`` < 1; the backend renders in ``quality`` mode, adds sensor noise
            or integrates several samples a pixel
            (a batch renders fast mode without noise: use one simulator per environment for those).
    """

    observations = tuple(RENDERED)

    def __init__(self, backend: Any, count: int) -> None:
        scene = backend._need_scene()
        if int(count) < 1:
            raise BackendError(f"a batch of robots needs count >= 1, got {count}", "ask for at least one robot")
        noisy = backend.noise_preset_name != "none" or any(v > 0 for v in backend.noise.values())
        if backend.mode != "fast" or noisy:
            raise BackendError(
                f"batched robots render fast mode without sensor noise; this backend has mode {backend.mode!r}"
                f"{' and sensor noise' if noisy else ''}",
                "use options mode fast and noise none, or one simulator per environment (vectorization_mode='sync')")
        if backend.samples_per_pixel != 1:
            raise BackendError(
                f"batched robots shade one ray a pixel; this robot's camera has samples_per_pixel "
                f"{backend.samples_per_pixel}",
                "use samples_per_pixel 1, or one simulator per environment (vectorization_mode='sync')")
        self.backend = backend
        self.count = int(count)
        self.start_pose = np.asarray(scene.start_se2, dtype=np.float64).copy()
        self._poses = np.tile(self.start_pose, (self.count, 1))

    def poses(self) -> np.ndarray:
        """(N, 3) float64 ``[x m, y m, yaw rad]`` of each robot in ``map`` (a copy)."""
        return self._poses.copy()

    def place(self, which: np.ndarray, poses: np.ndarray | None = None) -> None:
        """Put the robots ``which`` ((N,) bool) at ``poses`` ((N, 3); None: the start pose), no checks."""
        which = np.asarray(which, dtype=bool).reshape(self.count)
        self._poses[which] = self.start_pose if poses is None else np.asarray(poses, np.float64).reshape(-1, 3)[which]

    def move_to(self, goals: np.ndarray, which: np.ndarray) -> np.ndarray:
        """Drive the robots ``which`` ((N,) bool) to ``goals`` ((N, 3), map); (N,) bool: stopped before a contact."""
        which = np.flatnonzero(np.asarray(which, dtype=bool).reshape(self.count))
        collided = np.zeros(self.count, dtype=bool)
        if len(which):
            goals = np.asarray(goals, dtype=np.float64).reshape(self.count, 3)
            b = self.backend
            self._poses[which], collided[which], _ = drive_robots(self._poses[which], goals[which], b.obstacles,
                                                                  b.gains)
        return collided

    def observe(self, names: Sequence[str], *, on_device: bool = False) -> dict[str, Any]:
        """``image_rgb`` (N, H, W, 3) uint8, ``image_depth`` (N, H, W) float32 m, ``laser`` (N, beams) float64 m of
        every robot, from one kernel launch (see the class docstring for ``on_device``).

        Raises:
            KeyError: a name not in :data:`RENDERED`.
        """
        for name in names:
            if name not in self.observations:
                raise KeyError(name)
        b = self.backend
        renderer = b._renderer
        T_map_footprint = se2_to_matrices(self._poses)
        lidars = T_map_footprint @ b.T_footprint_lidar if "laser" in names else None
        device = on_device and renderer.device_buffers
        if device:  # the frames handed out last time are overwritten now: let their readers finish first
            renderer.wait_for_readers()
        out = renderer.render_sensors(b.K, T_map_footprint @ b.T_footprint_camera, b.width, b.height, lidars,
                                      b.laser_angles if lidars is not None else None, to_host=False)
        wanted = {name: key for name, key in RENDERED.items() if name in names}
        if device:  # the images stay where the kernel wrote them; the laser's ranges (small) come to the host
            if renderer.arch == "cuda":
                renderer.sync()  # the images are complete before anyone reads them, on any stream (dlpack.py)
            result = {name: _exported(out[key], renderer.arch) for name, key in wanted.items() if name != "laser"}
            host = renderer.host_copies({"ranges": out["ranges"]}) if lidars is not None else {}
        else:  # only what was asked for is copied (not the segmentation images)
            host = renderer.host_copies({key: out[key] for key in wanted.values()})
            result = {name: host[key] for name, key in wanted.items() if name != "laser"}
        if lidars is not None:
            result["laser"] = np.clip(host["ranges"][:, :len(b.laser_angles)].astype(np.float64), 0.0, b.range_max)
        return result


def _exported(array: Any, arch: str) -> Any:
    """A renderer output buffer (a Taichi ndarray) without a copy: a DLPack-exporting
    :class:`~benchbot_sim_taichi.render.dlpack.DeviceArray` on CUDA, a NumPy view of its host memory otherwise."""
    if isinstance(array, np.ndarray):
        return array
    if arch == "cuda":
        from benchbot_sim_taichi.render.dlpack import DeviceArray

        return DeviceArray(array)
    from benchbot_sim_taichi.render.host_copy import host_view

    return host_view(array)
