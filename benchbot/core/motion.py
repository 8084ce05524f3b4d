"""The robot's motion model: the original BenchBot's pose controller (docs/original-benchbot.md, section 6), as a
pure, steppable state machine, and the exact unicycle integration that simulators apply its commands with
(:func:`integrate_unicycle`).

Robot backends call :meth:`PoseController.command` at ``rate_hz`` with the robot's current SE(2) pose and apply the
returned velocity command (simulators integrate it; real robots publish it as a Twist) until it returns ``None``.

Source of the law and constants: the original benchbot_robot_controller v2.4.1 ``robot_callbacks``: a drive
phase with the polar-coordinates law v = K_rho·ρ, ω = K_alpha·α + K_beta·β (backwards when the goal lies behind),
then a rotate-in-place phase ω = K_angle·γ; both phases time out after 30 s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from benchbot.core.geometry import wrap_angle


@dataclass(frozen=True)
class ControllerGains:
    """Gains, tolerances and limits of the pose controller (defaults: the original's, docs/original-benchbot.md)."""

    rate_hz: float = 20.0
    position_tolerance_m: float = 0.01
    yaw_tolerance_rad: float = math.radians(1.0)
    phase_timeout_s: float = 30.0
    k_rho: float = 2.0
    k_alpha: float = 10.0
    k_beta: float = -4.0
    k_angle: float = 3.0
    linear_min_mps: float = -0.6
    linear_max_mps: float = 1.5
    angular_max_radps: float = 1.0
    speed_factor: float = 1.0
    settle_s: float = 0.65


#: Phases of :class:`PoseControllers` (``phase`` array values).
DRIVE, ROTATE, DONE = 0, 1, 2
_PHASE_NAMES = ("drive", "rotate", "done")


class PoseControllers:
    """N pose controllers stepped together: the law of :class:`PoseController` on arrays (NumPy), one goal each.

    Args:
        goals: (N, 3) float64 ``[x m, y m, yaw rad]`` in the map (or odometry) frame.
        gains: controller constants, shared.

    Use: ``while (moving := ctl.command(poses)).any(): v, w = ctl.v, ctl.w; ...`` — each call returns (N,) bool,
    True where a robot still moves, and leaves its command ``(v m/s, ω rad/s)`` in :attr:`v`, :attr:`w` (0 for the
    others). :attr:`phase` (N,) int8 is :data:`DRIVE`, :data:`ROTATE` or :data:`DONE`; :meth:`stop` ends some at
    once (a collision).

    Raises:
        ValueError: ``goals`` is not (N, 3) of finite numbers (a NaN or infinite goal would otherwise end at once,
            reported as reached, or drive for the whole phase timeout).
    """

    def __init__(self, goals: np.ndarray, gains: ControllerGains = ControllerGains()) -> None:
        self.goals = np.asarray(goals, dtype=np.float64)
        if self.goals.ndim != 2 or self.goals.shape[1] != 3 or not np.all(np.isfinite(self.goals)):
            raise ValueError(f"the pose controller's goals must be (N, 3) finite numbers [x m, y m, yaw rad], got "
                             f"{goals!r}")
        n = self.goals.shape[0]
        self.gains = gains
        self.phase = np.full(n, DRIVE, dtype=np.int8)
        self._elapsed = np.zeros(n)
        self._backwards = np.full(n, -1, dtype=np.int8)  # -1: not decided yet (on the first drive command)
        self.v, self.w = np.zeros(n), np.zeros(n)

    def stop(self, which: np.ndarray) -> None:
        """End the robots selected by ``which`` ((N,) bool or indices) now: phase :data:`DONE`."""
        self.phase[which] = DONE

    def _limit(self, v: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        g = self.gains
        v, w = v * g.speed_factor, w * g.speed_factor
        scale = np.ones_like(v)
        scale = np.maximum(scale, np.where(v > g.linear_max_mps, v / g.linear_max_mps, 1.0))
        scale = np.maximum(scale, np.where(v < g.linear_min_mps, v / g.linear_min_mps, 1.0))
        scale = np.maximum(scale, np.abs(w) / g.angular_max_radps)
        return v / scale, w / scale

    def command(self, current: np.ndarray) -> np.ndarray:
        """The commands for the next 1/rate_hz seconds (in :attr:`v`, :attr:`w`); returns (N,) bool, True where a
        robot still moves (False once its phase is :data:`DONE`).

        Args:
            current: (N, 3) ``[x, y, yaw]``, the robots' poses in the goals' frame.
        """
        g = self.gains
        dt = 1.0 / g.rate_hz
        current = np.asarray(current, dtype=np.float64)
        c, s = np.cos(current[:, 2]), np.sin(current[:, 2])
        dx, dy = self.goals[:, 0] - current[:, 0], self.goals[:, 1] - current[:, 1]
        ex, ey, eyaw = c * dx + s * dy, -s * dx + c * dy, wrap_angle(self.goals[:, 2] - current[:, 2])
        v, w = np.zeros_like(ex), np.zeros_like(ex)
        drive = self.phase == DRIVE
        rho = np.hypot(ex, ey)
        timed_out = self._elapsed >= g.phase_timeout_s
        go = drive & (rho > g.position_tolerance_m) & ~timed_out
        if go.any():
            alpha = np.arctan2(ey[go], ex[go])
            beta = wrap_angle(eyaw[go] - alpha)
            undecided = self._backwards[go] < 0
            backwards = np.where(undecided, np.abs(alpha) > 1.05 * math.pi / 2, self._backwards[go] == 1)
            self._backwards[go] = backwards
            self._elapsed[go] += dt
            vf, wf = g.k_rho * rho[go], g.k_alpha * alpha + g.k_beta * beta
            vb = -g.k_rho * rho[go]
            wb = g.k_alpha * wrap_angle(alpha + math.pi) + g.k_beta * wrap_angle(beta + math.pi)
            v[go], w[go] = self._limit(np.where(backwards, vb, vf), np.where(backwards, wb, wf))
        ended = drive & ~go
        self.phase[ended & timed_out] = DONE
        to_rotate = ended & ~timed_out
        self.phase[to_rotate], self._elapsed[to_rotate] = ROTATE, 0.0
        rotate = self.phase == ROTATE
        turn = rotate & (np.abs(eyaw) > g.yaw_tolerance_rad) & (self._elapsed < g.phase_timeout_s)
        self._elapsed[turn] += dt
        w[turn] = np.clip(g.speed_factor * g.k_angle * eyaw[turn], -g.angular_max_radps, g.angular_max_radps)
        self.phase[rotate & ~turn] = DONE
        self.v, self.w = v, w
        return go | turn


class PoseController:
    """Drives a differential-drive robot to an SE(2) goal.

    Args:
        goal: (3,) ``[x m, y m, yaw rad]`` in the map (or odometry) frame.
        gains: controller constants.

    Use: ``while (cmd := ctl.command(pose)) is not None: apply(cmd, 1 / gains.rate_hz)``; ``cmd`` is
    ``(v m/s, ω rad/s)``. ``phase`` is ``'drive'``, ``'rotate'`` or ``'done'``.

    Raises:
        ValueError: ``goal`` is not three finite numbers (a NaN or infinite goal would otherwise end at once,
            reported as reached, or drive for the whole phase timeout).
    """

    def __init__(self, goal: np.ndarray, gains: ControllerGains = ControllerGains()) -> None:
        self.goal = np.asarray(goal, dtype=np.float64)
        if self.goal.shape != (3,) or not np.all(np.isfinite(self.goal)):
            raise ValueError(f"the pose controller's goal must be 3 finite numbers [x m, y m, yaw rad], got {goal!r}")
        self.gains = gains
        self._batch = PoseControllers(self.goal[None], gains)

    @property
    def phase(self) -> str:
        """``'drive'``, ``'rotate'`` or ``'done'``."""
        return _PHASE_NAMES[int(self._batch.phase[0])]

    def command(self, current: np.ndarray) -> tuple[float, float] | None:
        """The velocity command ``(v m/s, ω rad/s)`` for the next 1/rate_hz seconds, or ``None`` when done.

        Args:
            current: (3,) ``[x, y, yaw]``, the robot's pose in the goal's frame.
        """
        if not self._batch.command(np.asarray(current, dtype=np.float64).reshape(1, 3))[0]:
            return None
        return float(self._batch.v[0]), float(self._batch.w[0])


def integrate_unicycle(pose: np.ndarray, v: float, w: float, dt: float) -> np.ndarray:
    """The exact pose (3,) float64 ``[x m, y m, yaw rad]`` (map frame) after driving at a constant ``v`` (m/s) and
    ``w`` (rad/s) for ``dt`` seconds from ``pose`` (3,): :func:`integrate_unicycles` of one robot."""
    return integrate_unicycles(np.asarray(pose, dtype=np.float64).reshape(1, 3), np.array([float(v)]),
                               np.array([float(w)]), dt)[0]


def integrate_unicycles(poses: np.ndarray, v: np.ndarray, w: np.ndarray, dt: float) -> np.ndarray:
    """The exact poses (N, 3) float64 ``[x m, y m, yaw rad]`` (map frame) after driving each of ``poses`` (N, 3) at a
    constant ``v`` (N,) m/s and ``w`` (N,) rad/s for ``dt`` seconds: a straight line where ``|w|`` < 1e-9, else a
    circular arc of radius ``v / w``; yaw wrapped to [-π, π)."""
    x, y, th = poses[:, 0], poses[:, 1], poses[:, 2]
    straight = np.abs(w) < 1e-9
    w_arc = np.where(straight, 1.0, w)  # no division by ~0 on the straight lines (their arc values are not used)
    th1 = th + w * dt
    sin0, cos0 = np.sin(th), np.cos(th)
    x_new = np.where(straight, x + v * cos0 * dt, x + v / w_arc * (np.sin(th1) - sin0))
    y_new = np.where(straight, y + v * sin0 * dt, y - v / w_arc * (np.cos(th1) - cos0))
    return np.stack([x_new, y_new, wrap_angle(th1)], axis=1)
