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

from benchbot.core.geometry import se2_relative, wrap_angle


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
        self.phase = "drive"
        self._elapsed = 0.0
        self._backwards: bool | None = None

    def _limit(self, v: float, w: float) -> tuple[float, float]:
        g = self.gains
        v, w = v * g.speed_factor, w * g.speed_factor
        scale = 1.0
        if v > g.linear_max_mps:
            scale = max(scale, v / g.linear_max_mps)
        if v < g.linear_min_mps:
            scale = max(scale, v / g.linear_min_mps)
        scale = max(scale, abs(w) / g.angular_max_radps)
        return v / scale, w / scale

    def command(self, current: np.ndarray) -> tuple[float, float] | None:
        """The velocity command ``(v m/s, ω rad/s)`` for the next 1/rate_hz seconds, or ``None`` when done.

        Args:
            current: (3,) ``[x, y, yaw]``, the robot's pose in the goal's frame.
        """
        g = self.gains
        dt = 1.0 / g.rate_hz
        error = se2_relative(np.asarray(current, dtype=np.float64), self.goal)
        if self.phase == "drive":
            rho = math.hypot(error[0], error[1])
            if rho > g.position_tolerance_m and self._elapsed < g.phase_timeout_s:
                alpha = math.atan2(error[1], error[0])
                beta = wrap_angle(error[2] - alpha)
                if self._backwards is None:
                    self._backwards = abs(alpha) > 1.05 * math.pi / 2
                self._elapsed += dt
                if self._backwards:
                    return self._limit(
                        -g.k_rho * rho,
                        g.k_alpha * wrap_angle(alpha + math.pi) + g.k_beta * wrap_angle(beta + math.pi),
                    )
                return self._limit(g.k_rho * rho, g.k_alpha * alpha + g.k_beta * beta)
            if self._elapsed >= g.phase_timeout_s:
                self.phase = "done"
                return None
            self.phase, self._elapsed = "rotate", 0.0
        if self.phase == "rotate":
            gamma = error[2]
            if abs(gamma) > g.yaw_tolerance_rad and self._elapsed < g.phase_timeout_s:
                self._elapsed += dt
                w = max(-g.angular_max_radps, min(g.angular_max_radps, g.speed_factor * g.k_angle * gamma))
                return (0.0, w)
            self.phase = "done"
        return None


def integrate_unicycle(pose: np.ndarray, v: float, w: float, dt: float) -> np.ndarray:
    """The exact pose (3,) float64 ``[x m, y m, yaw rad]`` (map frame) after driving at a constant ``v`` (m/s) and
    ``w`` (rad/s) for ``dt`` seconds from ``pose`` (3,): a straight line for ``w`` ≈ 0, else a circular arc of radius
    ``v / w``; yaw wrapped to [-π, π)."""
    x, y, th = float(pose[0]), float(pose[1]), float(pose[2])
    if abs(w) < 1e-9:
        x += v * math.cos(th) * dt
        y += v * math.sin(th) * dt
    else:
        th1 = th + w * dt
        x += v / w * (math.sin(th1) - math.sin(th))
        y -= v / w * (math.cos(th1) - math.cos(th))
    return np.array([x, y, wrap_angle(th + w * dt)])
