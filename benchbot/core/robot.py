"""The contract between the episode (core) and a robot backend (a simulator or a real robot).

A plugin offers backends through the hook ``benchbot_robot_backends`` as ``{robot type: factory}``; the episode
builds one with ``factory(robot_spec, options)`` and drives it through the methods below. Backends know nothing of
tasks, scenes or the HTTP protocol: the episode keeps that state (docs/protocol.md).

Frames: ``map`` is the environment's world frame (z up, metres). The robot frame (``robot_spec['robot_frame']``)
is x forward, y left, z up, above the floor point under the robot's centre at a height of the backend's (0 = on the
floor; :meth:`RobotBackend.base_pose` is its planar part). The camera frame (``camera``) is the optical
frame of the RGB-D camera: z forward along the optical axis, x right, y down in the image, so a pixel (u, v) with
depth d (metres, along z) is ``d · K⁻¹ [u, v, 1]ᵀ`` in that frame.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np


@dataclass(frozen=True)
class MotionOutcome:
    """What happened during one motion.

    Attributes:
        collided: the robot's footprint touched the scene; the motion stopped before the contact.
        duration_s: simulated or wall time the motion took, seconds.
    """

    collided: bool
    duration_s: float


#: The environment type of the real world: a scene of this type is a room a real robot drives in (docs/your-robot.md).
REAL_ENVIRONMENT_TYPE = "real"


def episode_clock(environments: Sequence[dict]) -> str:
    """The clock of an episode in ``environments`` (environment specs): ``"wall"`` when one is of type ``real`` (a
    real robot: its time is the wall clock, motions take what they take), else ``"simulated"`` (a simulator's time,
    which advances with the motions, behind ROS 2 or not). Recordings (``benchbot.clock``) and the batch manifest's
    episode ``backend`` say it."""
    real = any(isinstance(e, dict) and e.get("type") == REAL_ENVIRONMENT_TYPE for e in environments)
    return "wall" if real else "simulated"


class RobotBackend(abc.ABC):
    """One robot, in one scene at a time.

    Args (of every factory):
        robot_spec: the validated robot spec (dict; schema ``robot``).
        options: backend options, e.g. ``{'seed': 0, 'arch': 'cpu', 'width': 640, 'height': 480}``; unknown keys
            are ignored.
    """

    #: True when the backend applies the sensor models of a ``noise`` option (:mod:`benchbot.core.noise`); the
    #: episode refuses a preset other than ``none`` on a backend that does not (a real robot's noise is its own).
    noise_presets: bool = False

    @abc.abstractmethod
    def load_scene(self, environment: dict, *, seed: int = 0) -> None:
        """Load ``environment`` (a validated environment spec) and place the robot at its normalised
        ``start_pose``, at rest, with no collision. Called at the start of every scene and on reset/restart.
        ``seed`` is the scene's world seed (:meth:`benchbot.core.episode.Episode.scene_seed`: derived from the
        run's seed and the environment's name and variant): a simulator builds the same scene for the same seed; its
        sensor noise draws from its ``seed`` option (the episode seed) as well, so repetitions differ.

        Raises:
            benchbot.core.errors.BackendError: the scene cannot be loaded.
        """

    @abc.abstractmethod
    def base_pose(self) -> np.ndarray:
        """The robot frame's ground-truth pose, (3,) float64 ``[x m, y m, yaw rad]`` in the ``map`` frame."""

    @abc.abstractmethod
    def move_to(self, goal: np.ndarray) -> MotionOutcome:
        """Drive to ``goal`` (3,) ``[x m, y m, yaw rad]`` (map frame) with the pose controller of
        :mod:`benchbot.core.motion`; stop before any contact with the scene and report it."""

    @abc.abstractmethod
    def frame_transforms(self) -> dict[str, np.ndarray]:
        """Ground-truth ``T_map_<frame>`` (4, 4) float64 for every frame the robot spec's ``poses`` lists (except
        the special ``initial_pose``, which the episode reports at the height of the robot frame given here)."""

    @abc.abstractmethod
    def observe(self, names: Sequence[str]) -> dict[str, Any]:
        """Sensor observations for ``names``: those this robot has among the observation kinds that are sensors
        (:mod:`benchbot.core.observations`: the core's ``image_rgb``, ``image_depth``, ``image_rgb_info``,
        ``image_depth_info``, ``laser``, ``image_segment``, and kinds of plugins' own sensors), each in its kind's
        structure (docs/observations.md; ``poses`` is built by the episode from :meth:`frame_transforms`).

        Raises:
            KeyError: a name this backend cannot observe.
        """

    def observe_borrowed(self, names: Sequence[str]) -> dict[str, Any]:
        """As :meth:`observe`, but the arrays may be the backend's own (its render or cache buffers) instead of
        copies the caller owns. They must stay valid until the backend's next :meth:`observe` or
        :meth:`observe_borrowed` call (observers read the episode's latest observation until then) and must not be
        modified: the caller copies what it keeps. The native HTTP step uses this, as it copies every array into
        the reply or into the client's shared-memory slot straight away, on the backend thread (one copy per array,
        as in-process callers get from :meth:`observe`). By default it is :meth:`observe`; a backend whose
        :meth:`observe` copies from buffers it keeps overrides it to skip that copy.

        Raises:
            KeyError: a name this backend cannot observe.
        """
        return self.observe(names)

    def batched(self, count: int) -> "BatchedRobots":
        """``count`` robots like this one in the scene :meth:`load_scene` loaded, moved and sensed together (the
        Gym vector environment, :mod:`benchbot.gym_vector`). A simulator offers it by overriding this method.

        Raises:
            NotImplementedError: this backend has no batched robots (a real robot, a simulator without them).
            benchbot.core.errors.BackendError: no scene is loaded.
        """
        raise NotImplementedError(f"{type(self).__name__} has no batched robots")

    def close(self) -> None:
        """Release resources (GPU memory, threads, connections). The backend is not used afterwards."""


class BatchedRobots(abc.ABC):
    """N robots of one backend in its scene, moved and sensed together (:meth:`RobotBackend.batched`). They do not
    see or collide with one another. Frames and units as :class:`RobotBackend`'s; robot ``i`` is index ``i`` of
    every array.

    Attributes:
        count: N.
        start_pose: (3,) float64 ``[x m, y m, yaw rad]``: the scene's start pose (map frame), where :meth:`place`
            puts robots by default.
        observations: the names :meth:`observe` offers: observation kinds of the registry
            (:mod:`benchbot.core.observations`, plugins' included) that have a Gym entry (the simulator's
            ``image_rgb``, ``image_depth``, ``laser``).
    """

    count: int
    start_pose: np.ndarray
    observations: tuple[str, ...]

    @abc.abstractmethod
    def poses(self) -> np.ndarray:
        """(N, 3) float64 ``[x m, y m, yaw rad]`` of each robot frame in ``map`` (a copy)."""

    @abc.abstractmethod
    def place(self, which: np.ndarray, poses: np.ndarray | None = None) -> None:
        """Put the robots selected by ``which`` ((N,) bool) at ``poses`` ((N, 3), the selected rows used; None: the
        start pose), at rest, without motion or collision checks."""

    @abc.abstractmethod
    def move_to(self, goals: np.ndarray, which: np.ndarray) -> np.ndarray:
        """Drive the robots selected by ``which`` ((N,) bool) to ``goals`` ((N, 3) map frame, the selected rows
        used) with the pose controller of :mod:`benchbot.core.motion`, as :meth:`RobotBackend.move_to` drives one;
        returns (N,) bool, True where a robot stopped before a contact with the scene."""

    @abc.abstractmethod
    def observe(self, names: Sequence[str], *, on_device: bool = False) -> dict[str, Any]:
        """The sensors ``names`` (among :attr:`observations`) of all N robots at their poses, with a leading batch
        axis: each kind's Gym entry value (``ObservationKind.gym``) of every robot, stacked: ``image_rgb``
        (N, H, W, 3) uint8, ``image_depth`` (N, H, W) float32 metres (0: no hit), ``laser`` (N, beams) float64
        ranges in metres clipped to the laser's ``range_max`` (the beams' angles fixed, as the single robot's scan),
        a plugin's kind (N, ...) as its entry's value. NumPy arrays the caller owns; with ``on_device`` the images may instead be the
        backend's own device buffers exporting DLPack (``__dlpack__``), valid until the next call.

        Raises:
            KeyError: a name not in :attr:`observations`.
        """

    def close(self) -> None:
        """Release what the batch holds (the backend it came from stays open)."""
