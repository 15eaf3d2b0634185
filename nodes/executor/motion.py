"""Straight-line tool motions, time-optimal under speed and acceleration limits.

Every densepack setpoint is a downward-pointing tool at (x, y, z) with its closing axis at
``yaw`` (docs/contracts.md), so a tool pose here is four numbers. A move interpolates the
position along the segment and the yaw along the shorter arc with one speed profile: a
trapezoid whose ramps are half cosines, v(t) = V (1 - cos(pi t / Ta)) / 2. It cruises at the
speed limit like the UR's own ``movel`` but, unlike a plain trapezoid, its acceleration is
continuous (finite jerk), so a carried block is not jolted at the start and end of a ramp.
With peak acceleration A a ramp lasts Ta = pi V / (2 A) and covers V Ta / 2; a move too
short to reach V peaks at V' = sqrt(2 A D / pi). The slowest degree of freedom (translation or
yaw) sets the profile, and both follow it, so the tool moves on the straight line.

Two moves may overlap at a corner (``blend_overlap``: one slows down while the next speeds
up), and a move under way can be braked to rest along its line (``braking_move``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


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
        return math.dist((self.x, self.y, self.z), (other.x, other.y, other.z))

    def with_z(self, z: float) -> ToolPose:
        return ToolPose(self.x, self.y, z, self.yaw)

    def offset(self, dx: float = 0.0, dy: float = 0.0, dz: float = 0.0) -> ToolPose:
        return ToolPose(self.x + dx, self.y + dy, self.z + dz, self.yaw)

    def plus(self, dx: float, dy: float, dz: float, dyaw: float) -> ToolPose:
        return ToolPose(self.x + dx, self.y + dy, self.z + dz, self.yaw + dyaw)


def equivalent_yaw_near(yaw: float, reference: float) -> float:
    """``yaw + k*pi`` nearest ``reference``: a two-finger grasp is symmetric under a half turn."""
    return reference + math.remainder(yaw - reference, math.pi)


@dataclass(frozen=True, slots=True)
class Limits:
    """Tool limits: linear speed (m/s) and acceleration (m/s^2), yaw rate (rad/s) and yaw
    acceleration (rad/s^2)."""

    speed: float
    accel: float
    yaw_rate: float = 3.0
    yaw_accel: float = 12.0


@dataclass(frozen=True, slots=True)
class Profile:
    """The cosine-ramp trapezoid of a unit distance: peak speed ``v`` (1/s), ramp time ``ramp``
    and cruise time ``cruise`` (s)."""

    v: float
    ramp: float
    cruise: float

    @classmethod
    def fastest(cls, speed: float, accel: float) -> Profile:
        """The shortest profile over a unit distance with peak speed and acceleration limits
        ``speed`` (1/s) and ``accel`` (1/s^2)."""
        if speed == math.inf:
            return cls(0.0, 0.0, 0.0)
        v = min(speed, math.sqrt(2.0 * accel / math.pi))
        ramp = math.pi * v / (2.0 * accel)
        return cls(v, ramp, max(0.0, 1.0 / v - ramp))

    @property
    def duration(self) -> float:
        return 2.0 * self.ramp + self.cruise

    def position(self, t: float) -> float:
        """Fraction of the distance covered ``t`` seconds in (clamped to [0, 1])."""
        if self.v == 0.0 or t >= self.duration:
            return 1.0
        if t <= 0.0:
            return 0.0
        if t > self.ramp + self.cruise:
            return 1.0 - self._ramp_position(self.duration - t)
        if t > self.ramp:
            return self._ramp_position(self.ramp) + self.v * (t - self.ramp)
        return self._ramp_position(t)

    def _ramp_position(self, t: float) -> float:
        return 0.5 * self.v * (t - self.ramp / math.pi * math.sin(math.pi * t / self.ramp))


def move_duration(distance: float, speed: float, accel: float) -> float:
    """Shortest duration of a move of ``distance`` under the speed and acceleration limits."""
    if distance <= 0.0:
        return 0.0
    return Profile.fastest(speed / distance, accel / distance).duration


@dataclass(frozen=True, slots=True)
class LinearMove:
    """A straight move from ``start`` to ``end`` (yaw along the shorter arc)."""

    start: ToolPose
    end: ToolPose
    profile: Profile

    @classmethod
    def plan(cls, start: ToolPose, end: ToolPose, limits: Limits) -> LinearMove:
        end = ToolPose(end.x, end.y, end.z,
                       start.yaw + math.remainder(end.yaw - start.yaw, 2 * math.pi))
        distance, turn = start.distance_to(end), abs(end.yaw - start.yaw)
        # In the unit of the move (the fraction done), each degree of freedom limits speed
        # and acceleration; the tighter limit of the two sets one profile for both.
        speed = min(_per(limits.speed, distance), _per(limits.yaw_rate, turn))
        accel = min(_per(limits.accel, distance), _per(limits.yaw_accel, turn))
        return cls(start, end, Profile.fastest(speed, accel))

    @property
    def duration(self) -> float:
        return self.profile.duration

    @property
    def length(self) -> float:
        return self.start.distance_to(self.end)

    def sample(self, t: float) -> ToolPose:
        """The setpoint ``t`` seconds after the move began (clamped to its ends)."""
        u = self.profile.position(t)
        if u >= 1.0:
            return self.end
        a, b = self.start, self.end
        return a.plus(u * (b.x - a.x), u * (b.y - a.y), u * (b.z - a.z), u * (b.yaw - a.yaw))

    def time_left_within(self, distance: float) -> float:
        """How long before its end the move comes within ``distance`` (m) of its end point."""
        if self.length <= distance:
            return self.duration
        fraction = 1.0 - distance / self.length
        lo, hi = 0.0, self.duration
        for _ in range(40):  # bisection on the monotone profile
            mid = 0.5 * (lo + hi)
            if self.profile.position(mid) < fraction:
                lo = mid
            else:
                hi = mid
        return self.duration - hi


def _per(limit: float, extent: float) -> float:
    """A limit in units of the move's fraction: inf when the degree of freedom does not move."""
    return limit / extent if extent > 1e-12 else math.inf


def braking_move(start: ToolPose, velocity: tuple[float, float, float], decel: float
                 ) -> LinearMove:
    """A straight stop from ``velocity`` (m/s) at ``decel`` (m/s^2): the distance v^2 / (2 a)
    along it, covered in v / a (a constant deceleration, written as the second half of a
    move)."""
    vx, vy, vz = velocity
    speed = math.sqrt(vx * vx + vy * vy + vz * vz)
    if speed < 1e-6:
        return LinearMove(start, start, Profile.fastest(math.inf, math.inf))
    distance = speed * speed / (2.0 * decel)
    end = start.offset(vx / speed * distance, vy / speed * distance, vz / speed * distance)
    return BrakingMove(start, end, Profile.fastest(math.inf, math.inf), speed, decel)


@dataclass(frozen=True, slots=True)
class BrakingMove(LinearMove):
    """Constant deceleration from ``speed`` to rest over the segment start-end."""

    speed: float = 0.0
    decel: float = 1.0

    @property
    def duration(self) -> float:
        return self.speed / self.decel

    def sample(self, t: float) -> ToolPose:
        t = min(max(t, 0.0), self.duration)
        covered = self.speed * t - 0.5 * self.decel * t * t
        length = self.length
        u = covered / length if length > 0 else 1.0
        if u >= 1.0 - 1e-12:
            return self.end
        a, b = self.start, self.end
        return a.plus(u * (b.x - a.x), u * (b.y - a.y), u * (b.z - a.z), 0.0)


@dataclass(slots=True)
class Blending:
    """A blended move's last part, still added to the setpoints while the next one starts."""

    move: LinearMove
    t0: float

    def offset(self, now: float) -> ToolPose:
        """Where this move still is relative to its end point."""
        p, e = self.move.sample(now - self.t0), self.move.end
        return ToolPose(p.x - e.x, p.y - e.y, p.z - e.z, p.yaw - e.yaw)


def blend_overlap(current: LinearMove, following: LinearMove, radius: float) -> float:
    """How long (s) the two moves may overlap: ``current`` within ``radius`` of its end,
    ``following`` no further than ``radius`` from its start, and no longer than either's
    speed ramp (so one slows down while the other speeds up)."""
    if radius <= 0.0 or current.duration <= 0.0 or following.duration <= 0.0:
        return 0.0
    ending = current.time_left_within(radius)
    starting = following.duration - following.time_left_within(
        max(0.0, following.length - radius))
    return min(ending, starting, current.profile.ramp, following.profile.ramp)


#: A descent counts as stopped by something below when the TCP came down at least this far
#: (m) over its end's x, y (within BLOCKED_XY_M): an arm that does not move at all is not.
BLOCKED_DROP_M = 0.005
BLOCKED_XY_M = 0.01


def stopped_on_the_way_down(top: float, end: ToolPose, measured: ToolPose, tol: float
                             ) -> bool:
    """The TCP went down from height ``top`` over ``end`` and stopped above it (it stands on
    something)."""
    over = math.hypot(measured.x - end.x, measured.y - end.y) <= BLOCKED_XY_M
    return over and end.z + tol < measured.z < top - BLOCKED_DROP_M
