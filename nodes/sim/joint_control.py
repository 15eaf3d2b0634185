"""The UR driver's motion controllers as the sim plays them: what ur_robot_driver accepts.

Pure logic, no PyBullet and no ROS: the sim node decodes messages into plain arrays, these
classes validate and keep them, and the world asks ``update(now, dt, ...)`` each physics step
for the joint positions and velocities to drive the motors to.

* ``TrajectoryController`` stands for ``scaled_joint_trajectory_controller``
  (ros2_controllers' joint trajectory controller with ur_controllers' speed scaling): a
  ``trajectory_msgs/JointTrajectory`` is checked the way the controller checks one (all of its
  joints and only those, in any order; points with strictly increasing times and a position per
  joint; velocities and accelerations empty or one per joint; no effort; a last point at rest;
  a stamped trajectory that ends in the past is refused), and beyond it, as a stand-in for the
  robot that would refuse to move there, no NaN and no joint past its limit. Each error is the
  reason returned (the node logs it); nothing of a refused trajectory is kept. An accepted one
  replaces the one playing ("the current implementation just forgets the old trajectory"):
  it starts at its stamp (zero: now), from the state the arm is in when it is first sampled,
  and is sampled on a clock that runs at the speed scaling (``traj_time += dt * scaling``).
  Between points it is a spline: linear with positions only, cubic with velocities, quintic
  with accelerations. After its last point the controller holds that point.
* ``ForwardPositionController`` stands for ``forward_position_controller``
  (``position_controllers/JointGroupPositionController``): a ``Float64MultiArray`` of one
  position per joint in the controller's ``joints`` order; the wrong count is an error, all-NaN
  is ignored, the last command is held. The robot (servoj) moves there no faster than its
  joints' velocity limits.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from nodes.robot import ur10e

#: ur_robot_driver's controller names (the topics are ``/<name>/joint_trajectory`` and
#: ``/<name>/commands``); only one is active, as the driver's ``initial_joint_controller``.
TRAJECTORY_CONTROLLER = "scaled_joint_trajectory_controller"
FORWARD_POSITION_CONTROLLER = "forward_position_controller"
MOTION_CONTROLLERS = (TRAJECTORY_CONTROLLER, FORWARD_POSITION_CONTROLLER)
#: The controller compares a last velocity with this (a float's epsilon).
AT_REST = float(np.finfo(np.float32).eps)


@dataclass(frozen=True, slots=True)
class TrajectoryPoint:
    """One point of a received trajectory, already in the controller's joint order."""

    time_from_start: float  #: s
    positions: np.ndarray
    velocities: np.ndarray | None = None
    accelerations: np.ndarray | None = None


@dataclass(frozen=True, slots=True)
class Trajectory:
    start_s: float  #: its stamp (s); 0: start when first sampled
    points: tuple[TrajectoryPoint, ...]

    @property
    def moves(self) -> bool:
        """Its points do not all hold one position (a commander mid-motion sent it)."""
        first = self.points[0].positions
        return any(float(np.max(np.abs(p.positions - first))) > 1e-9 for p in self.points)

    @property
    def motion_end(self) -> float:
        """When (s from its start) it reaches the position it then holds to its last point:
        a commander that pads its snippets with a hold, so a late one is not refused, has
        still only commanded the motion up to here."""
        last = self.points[-1].positions
        end = self.points[-1].time_from_start
        for point in reversed(self.points):
            if float(np.max(np.abs(point.positions - last))) > 1e-9:
                break
            end = point.time_from_start
        return end

    @property
    def hold_end(self) -> float:
        """For a trajectory that holds still: its last point's time, or the one before when
        the last only pads the hold (a commander's margin for arriving late, as the arm node's
        snippets end)."""
        points = self.points
        if len(points) >= 2 and _same(points[-1], points[-2]):
            return points[-2].time_from_start
        return points[-1].time_from_start


def _same(a: TrajectoryPoint, b: TrajectoryPoint) -> bool:
    return float(np.max(np.abs(a.positions - b.positions))) <= 1e-9


def _per_joint(values: Sequence[float], joint_count: int, what: str, index: int,
               allow_empty: bool) -> str:
    if allow_empty and len(values) == 0:
        return ""
    if len(values) != joint_count:
        return (f"mismatch between joint_names size ({joint_count}) and {what} "
                f"({len(values)}) at point #{index}")
    if not all(math.isfinite(v) for v in values):
        return f"point #{index} has a non-finite value in its {what}"
    return ""


def check_trajectory(names: Sequence[str], joints: Sequence[str], start_s: float,
                     points: Sequence[tuple[float, Sequence[float], Sequence[float],
                                            Sequence[float], Sequence[float]]],
                     now: float, position_limit: float = ur10e.JOINT_LIMIT) -> str:
    """Why the trajectory controller refuses this trajectory ("" = it accepts it).

    ``points`` are (time_from_start s, positions, velocities, accelerations, effort).
    """
    if len(names) != len(joints):
        return "Joints on incoming trajectory don't match the controller joints."
    if not names:
        return "Empty joint names on incoming trajectory."
    if not points:
        return "Empty trajectory received."
    for name in names:
        if name not in joints:
            return f"Incoming joint {name} doesn't match the controller's joints."
    if len(set(names)) != len(names):
        return "Joints on incoming trajectory don't match the controller joints."
    last_v = points[-1][2]
    for name, v in zip(names, last_v, strict=False):
        if math.isfinite(v) and abs(v) > AT_REST:
            return f"Velocity of last trajectory point of joint {name} is not zero: {v:.15f}"
    if start_s != 0.0 and start_s + points[-1][0] < now:
        return (f"Received trajectory with non-zero start time ({start_s:f}) that ends in the "
                f"past ({start_s + points[-1][0]:f})")
    previous = 0.0
    for i, (t, positions, velocities, accelerations, effort) in enumerate(points):
        if not math.isfinite(t) or (i > 0 and t <= previous):
            return (f"Time between points {i - 1} and {i} is not strictly increasing, it is "
                    f"{previous:f} and {t:f} respectively")
        previous = t
        for values, what, empty_ok in ((positions, "positions", False),
                                       (velocities, "velocities", True),
                                       (accelerations, "accelerations", True)):
            problem = _per_joint(values, len(names), what, i, empty_ok)
            if problem:
                return problem
        if len(effort):
            return ("Trajectories with effort fields are only supported for controllers "
                    "using the 'effort' command interface.")
        over = [n for n, q in zip(names, positions, strict=True) if abs(q) > position_limit]
        if over:
            return (f"point #{i} puts {', '.join(over)} past its limit of "
                    f"+-{position_limit:.4f} rad")
    return ""


def to_controller_order(names: Sequence[str], joints: Sequence[str], start_s: float,
                        points) -> Trajectory:
    """A checked trajectory with its values in the controller's joint order."""
    order = [list(names).index(j) for j in joints]

    def arranged(values) -> np.ndarray | None:
        return np.asarray(values, dtype=float)[order] if len(values) else None

    return Trajectory(float(start_s), tuple(
        TrajectoryPoint(float(t), arranged(q), arranged(v), arranged(a))
        for t, q, v, a, _ in points))


def hermite(t: float, t0: float, t1: float, q0: np.ndarray, v0: np.ndarray, a0: np.ndarray,
            q1: np.ndarray, v1: np.ndarray, a1: np.ndarray, quintic: bool
            ) -> tuple[np.ndarray, np.ndarray]:
    """Position and velocity at ``t`` of the cubic (or quintic) spline from (q0, v0[, a0]) at
    ``t0`` to (q1, v1[, a1]) at ``t1``."""
    h = t1 - t0
    if h <= 0.0:
        return q1.copy(), v1.copy()
    u = min(max((t - t0) / h, 0.0), 1.0)
    if not quintic:
        h00, h10, h01, h11 = (2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u,
                              -2 * u**3 + 3 * u**2, u**3 - u**2)
        d00, d10, d01, d11 = (6 * u**2 - 6 * u, 3 * u**2 - 4 * u + 1, -6 * u**2 + 6 * u,
                              3 * u**2 - 2 * u)
        q = h00 * q0 + h10 * h * v0 + h01 * q1 + h11 * h * v1
        v = (d00 * q0 + d10 * h * v0 + d01 * q1 + d11 * h * v1) / h
        return q, v
    # quintic Hermite basis (position, velocity, acceleration at both ends)
    b = [1 - 10 * u**3 + 15 * u**4 - 6 * u**5, u - 6 * u**3 + 8 * u**4 - 3 * u**5,
         0.5 * u**2 - 1.5 * u**3 + 1.5 * u**4 - 0.5 * u**5,
         10 * u**3 - 15 * u**4 + 6 * u**5, -4 * u**3 + 7 * u**4 - 3 * u**5,
         0.5 * u**3 - u**4 + 0.5 * u**5]
    db = [-30 * u**2 + 60 * u**3 - 30 * u**4, 1 - 18 * u**2 + 32 * u**3 - 15 * u**4,
          u - 4.5 * u**2 + 6 * u**3 - 2.5 * u**4, 30 * u**2 - 60 * u**3 + 30 * u**4,
          -12 * u**2 + 28 * u**3 - 15 * u**4, 1.5 * u**2 - 4 * u**3 + 2.5 * u**4]
    terms = (q0, h * v0, h * h * a0, q1, h * v1, h * h * a1)
    q = sum(c * x for c, x in zip(b, terms, strict=True))
    v = sum(c * x for c, x in zip(db, terms, strict=True)) / h
    return q, v


class TrajectoryController:
    """``scaled_joint_trajectory_controller``: plays the newest accepted trajectory."""

    name = TRAJECTORY_CONTROLLER

    def __init__(self, q_start: Sequence[float], joints: Sequence[str] = ur10e.ARM_JOINTS
                 ) -> None:
        self.joints = tuple(joints)
        self.hold(q_start)

    def hold(self, q: Sequence[float]) -> None:
        """Forget any trajectory and hold ``q`` (activation, a stop, a reset)."""
        self.q_cmd = np.array(q, dtype=float)
        self.v_cmd = np.zeros(len(self.joints))
        self._pending: Trajectory | None = None
        self._current: Trajectory | None = None
        self._before: tuple[float, np.ndarray, np.ndarray] | None = None
        self._traj_time = 0.0

    def receive(self, names: Sequence[str], start_s: float, points, now: float) -> str:
        """A trajectory message (decoded); returns why it is refused ("" = accepted: it
        replaces the current one at the next update)."""
        error = check_trajectory(names, self.joints, start_s, points, now)
        if not error:
            self._pending = to_controller_order(names, self.joints, start_s, points)
        return error

    @property
    def active(self) -> bool:
        """A trajectory is being played (not holding after its last point)."""
        return self._current is not None or self._pending is not None

    def ends_at(self, now: float) -> tuple[float, bool, float] | None:
        """How far ahead the trajectory playing (or about to) commands the arm (s, unscaled),
        whether the sim is to wait there as for a motion, and when it starts; None: none.

        A moving one commands up to the end of its motion (the pad that may follow only keeps
        a late snippet from being refused); one that holds still, up to its last point before
        the pad (``Trajectory.hold_end``). A moving one that comes to rest before its last
        unpadded point (the end of a move) is waited on as a hold: its commander reacts to
        the arm arriving, and no clock tick comes while the sim waits to make it send the
        next snippet, so the sim waits for it no longer than for a hold (waited on as a
        motion, the sim sat out its 0.5 s stall patience at the end of most moves)."""
        traj = self._pending or self._current
        if traj is None:
            return None
        moves, start = traj.moves, traj.start_s or now
        if not moves:
            return start + traj.hold_end, False, start
        comes_to_rest = traj.motion_end < traj.hold_end - 1e-9
        return start + traj.motion_end, not comes_to_rest, start

    def update(self, now: float, dt: float, scaling: float, q_measured: np.ndarray,
               v_measured: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The command for the physics step ending at ``now`` (s)."""
        if self._pending is not None:
            traj, self._pending = self._pending, None
            if traj.start_s == 0.0:
                traj = Trajectory(now, traj.points)
            self._current = traj
            # interpolate from the state the arm is in (interpolate_from_desired_state: false)
            self._before = (now, np.array(q_measured, dtype=float),
                            np.array(v_measured, dtype=float))
            self._traj_time = now
        elif self._current is not None:
            self._traj_time += dt * scaling
        if self._current is not None:
            self.q_cmd, self.v_cmd = self._sample(self._current, self._traj_time)
            end = self._current.start_s + self._current.points[-1].time_from_start
            if self._traj_time >= end:
                self._current = None  # past the last point: hold it
                self.v_cmd = np.zeros(len(self.joints))
        return self.q_cmd.copy(), self.v_cmd.copy()

    def _sample(self, traj: Trajectory, t: float) -> tuple[np.ndarray, np.ndarray]:
        """The spline through the state before the trajectory and its points, at ``t``."""
        assert self._before is not None
        zero = np.zeros(len(self.joints))
        times = [traj.start_s + p.time_from_start for p in traj.points]
        if t >= times[-1]:
            return traj.points[-1].positions.copy(), zero
        k = next(i for i, t_point in enumerate(times) if t < t_point)
        end = traj.points[k]
        if k == 0:
            t0, q0, v0 = self._before
            a0 = zero
            if times[0] <= t0:
                return end.positions.copy(), _or(end.velocities, zero).copy()
        else:
            start = traj.points[k - 1]
            t0, q0 = times[k - 1], start.positions
            v0, a0 = _or(start.velocities, zero), _or(start.accelerations, zero)
        if end.velocities is None and end.accelerations is None:  # positions only: linear
            h = times[k] - t0
            u = min(max((t - t0) / h, 0.0), 1.0)
            return q0 + u * (end.positions - q0), (end.positions - q0) / h
        return hermite(t, t0, times[k], q0, v0, a0, end.positions, _or(end.velocities, zero),
                       _or(end.accelerations, zero), end.accelerations is not None)


def _or(values: np.ndarray | None, default: np.ndarray) -> np.ndarray:
    return default if values is None else values


class ForwardPositionController:
    """``forward_position_controller``: one position per joint, held until the next."""

    name = FORWARD_POSITION_CONTROLLER

    def __init__(self, q_start: Sequence[float], joints: Sequence[str] = ur10e.ARM_JOINTS,
                 velocity_limit: Sequence[float] = ur10e.JOINT_VELOCITY_LIMIT) -> None:
        self.joints = tuple(joints)
        self.v_max = np.asarray(velocity_limit, dtype=float)
        self.hold(q_start)

    def hold(self, q: Sequence[float]) -> None:
        self.q_cmd = np.array(q, dtype=float)
        self.v_cmd = np.zeros(len(self.joints))
        self.target = self.q_cmd.copy()
        self.last_command_at: float | None = None

    def receive(self, values: Sequence[float], now: float,
                position_limit: float = ur10e.JOINT_LIMIT) -> str:
        """A command; returns why it is refused ("" = accepted). All-NaN is ignored, as the
        controller ignores it (returns "" and keeps the last command)."""
        if len(values) != len(self.joints):
            return (f"command size ({len(values)}) does not match number of interfaces "
                    f"({len(self.joints)})")
        array = np.asarray(values, dtype=float)
        if np.all(np.isnan(array)):
            return ""
        if not np.all(np.isfinite(array)):
            return f"command {array.tolist()} has a non-finite value"
        if np.any(np.abs(array) > position_limit):
            return f"command {array.tolist()} puts a joint past +-{position_limit:.4f} rad"
        self.target = array
        self.last_command_at = now
        return ""

    @property
    def active(self) -> bool:
        return bool(np.max(np.abs(self.target - self.q_cmd)) > 1e-12)

    def update(self, now: float, dt: float, scaling: float, q_measured: np.ndarray,
               v_measured: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Towards the last command within the joints' velocity limits (the speed slider
        does not scale streamed positions: the UR moves where it is told)."""
        step = np.clip(self.target - self.q_cmd, -self.v_max * dt, self.v_max * dt)
        self.q_cmd = self.q_cmd + step
        self.v_cmd = step / dt
        return self.q_cmd.copy(), self.v_cmd.copy()
