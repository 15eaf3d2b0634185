"""Straight-line tool motions with a minimum-jerk time law, under speed and acceleration limits.

Every densepack setpoint is a downward-pointing tool at (x, y, z) with its closing axis at
``yaw`` (docs/contracts.md), so a tool pose here is four numbers. A move interpolates
position along the segment and yaw along the shorter arc with the same normalised
minimum-jerk profile u(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5, whose peak speed is 1.875 D/T
and peak acceleration 5.7735 D/T^2 for a distance D covered in T: the duration is the
smallest T that keeps both under the limits, for the translation and the rotation alike.
Minimum-jerk keeps a carried block from slipping in the fingers at the start and end.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Peak speed and peak acceleration of the unit minimum-jerk profile (per D/T and D/T^2).
MJ_PEAK_SPEED = 1.875
MJ_PEAK_ACCEL = 10.0 / math.sqrt(3.0)


@dataclass(frozen=True, slots=True)
class ToolPose:
    """A gripper-down tool pose in ``world``: position (m) and closing-axis yaw (rad)."""

    x: float
    y: float
    z: float
    yaw: float

    @property
    def position(self) -> np.ndarray:
        return np.array([self.x, self.y, self.z])

    def distance_to(self, other: ToolPose) -> float:
        return float(np.linalg.norm(self.position - other.position))

    def with_z(self, z: float) -> ToolPose:
        return ToolPose(self.x, self.y, z, self.yaw)

    def offset(self, dx: float = 0.0, dy: float = 0.0, dz: float = 0.0) -> ToolPose:
        return ToolPose(self.x + dx, self.y + dy, self.z + dz, self.yaw)


def equivalent_yaw_near(yaw: float, reference: float) -> float:
    """``yaw + k*pi`` nearest ``reference``: a two-finger grasp is symmetric under a half turn."""
    return reference + math.remainder(yaw - reference, math.pi)


def minimum_jerk(tau: float) -> float:
    tau = min(max(tau, 0.0), 1.0)
    return tau**3 * (10.0 + tau * (-15.0 + 6.0 * tau))


def minimum_jerk_duration(distance: float, max_speed: float, max_accel: float) -> float:
    """Shortest duration of a minimum-jerk move of ``distance`` under both limits."""
    if distance <= 0.0:
        return 0.0
    return max(MJ_PEAK_SPEED * distance / max_speed,
               math.sqrt(MJ_PEAK_ACCEL * distance / max_accel))


@dataclass(frozen=True, slots=True)
class Limits:
    """Tool speed limits: linear (m/s, m/s^2) and yaw (rad/s, rad/s^2)."""

    speed: float
    accel: float
    yaw_rate: float = 1.5
    yaw_accel: float = 3.0


@dataclass(frozen=True, slots=True)
class LinearMove:
    """A straight move from ``start`` to ``end`` (yaw along the shorter arc) over ``duration``."""

    start: ToolPose
    end: ToolPose
    duration: float

    @classmethod
    def plan(cls, start: ToolPose, end: ToolPose, limits: Limits) -> LinearMove:
        end = ToolPose(end.x, end.y, end.z, start.yaw + math.remainder(end.yaw - start.yaw,
                                                                        2 * math.pi))
        duration = max(
            minimum_jerk_duration(start.distance_to(end), limits.speed, limits.accel),
            minimum_jerk_duration(abs(end.yaw - start.yaw), limits.yaw_rate, limits.yaw_accel),
        )
        return cls(start, end, duration)

    def sample(self, t: float) -> ToolPose:
        """The setpoint ``t`` seconds after the move began (clamped to its ends)."""
        if self.duration <= 0.0:
            return self.end
        u = minimum_jerk(t / self.duration)
        a, b = self.start, self.end
        return ToolPose(
            a.x + u * (b.x - a.x),
            a.y + u * (b.y - a.y),
            a.z + u * (b.z - a.z),
            a.yaw + u * (b.yaw - a.yaw),
        )
