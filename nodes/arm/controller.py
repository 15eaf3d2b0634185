"""The arm node's controller: setpoint validation, IK and streamed playback, in joint space.

Pure logic, no ROS and no simulator: the arm node hands over Cartesian setpoints, steps
``step(dt, now)`` ahead of the arm and sends the joint positions and velocities it yields to
the robot driver's motion controller (``nodes.arm.commands``). It plays a stream the way a UR
plays ``servoj`` commands, which is what the cell's executor expects of its arm:

* A Cartesian setpoint (TCP pose in ``world``, stamped) is validated (frame, finite, unit-able
  quaternion, above the safety plane ``min_tcp_z``), solved by closed-form IK with the branch
  nearest the previous one (yaw and yaw + pi are the same grasp, so the nearer of the two is
  taken: streaming never asks for a 180-degree wrist flip), and joins the stream. A setpoint
  that fails any check is rejected with the reason, the stream is dropped and the arm holds
  still where it is commanded now.
* A stream of setpoints is played back ``servo_delay_s`` behind their stamps, the joint
  positions interpolated between setpoints, so a smooth Cartesian trajectory is followed
  exactly however coarsely it was sampled. Where it would ask a joint for more speed or
  acceleration than the UR10e has, playback slows down: the tool stays on its path and
  arrives late. Where playback fell behind the clock (setpoints that came later than the
  servo delay, a loaded machine; the joints' limits; a commander that paused), it catches up
  at up to ``CATCH_UP`` times the stream's pace (ramped up and down, no jump in speed),
  within the same limits, and no closer than ``CATCH_UP_MARGIN_S`` to the newest setpoint.
  Before, a lag once taken was kept: in the cell it grew to 0.5-0.8 s within a run, and
  every move that waits for the measured tool waited that long.
* The teach pendant's speed slider (``set_speed_scaling``, a fraction) stretches time the way
  ur_robot_driver's scaled trajectory controller does: the same path, every speed times the
  fraction, every acceleration times its square; at 0 the arm stands still on its path. The
  time the slider takes is not caught up afterwards (a UR does not either).
* A setpoint that starts a stream (after a pause, or the first one) is reached point to
  point: a straight line in joint space, each joint within its velocity and acceleration
  limits, braking to a stop on the target without overshoot.
* A protective stop (the driver reports it) holds the command where the arm is measured and
  rejects every setpoint until ``unlock``: the UR's safety system does the same, and its
  dashboard unlocks it.
"""

from __future__ import annotations

import collections
import math
from dataclasses import dataclass

import numpy as np

from nodes.common.transforms import pose_matrix
from nodes.robot import ur10e
from nodes.robot.kinematics import solve_tcp_ik, tcp_pose

ACCEPTED_FRAMES = ("world", "")


@dataclass(frozen=True)
class SetpointResult:
    accepted: bool
    reason: str = ""


#: Setpoints further apart than this (s) do not belong to one stream.
STREAM_GAP_S = 0.25
#: Playback that fell behind the clock runs up to this many times the stream's pace until it
#: is a servo delay behind the stamps again (joint limits still apply) ...
CATCH_UP = 1.25
#: ... its pace changing by at most this fraction a control step, up and back down, so the
#: tool's speed ramps (a step to 1.5x, or from 1.25x back to 1x, put the simulated TCP 1-2 mm
#: off a straight path for a moment).
CATCH_UP_RAMP = 0.01
#: ... and it catches up no closer than this (s) to the newest setpoint: a commander whose
#: setpoints come later than the servo delay is followed at a steady lag, not in stop and go.
CATCH_UP_MARGIN_S = 0.05


class ArmController:
    """Streams joint commands along the accepted TCP setpoints."""

    def __init__(self, q_start, min_tcp_z: float = 0.0, speed_scale: float = 1.0,
                 servo_delay_s: float = 0.04) -> None:
        if not 0.0 < speed_scale <= 1.0:
            raise ValueError(f"speed_scale must be in (0, 1], got {speed_scale}")
        self.v_max = np.asarray(ur10e.JOINT_VELOCITY_LIMIT) * speed_scale
        self.a_max = np.asarray(ur10e.JOINT_ACCELERATION_LIMIT)
        self.min_tcp_z = float(min_tcp_z)
        self.servo_delay_s = float(servo_delay_s)
        self.speed_scaling = 1.0  #: the speed slider (fraction, 0 = stand still)
        self.reset(q_start)

    def reset(self, q_start) -> None:
        self.q_cmd = np.array(q_start, dtype=float)
        self.v_cmd = np.zeros(6)
        self.q_target = self.q_cmd.copy()
        self.now = 0.0
        self.stream: collections.deque[tuple[float, np.ndarray]] = collections.deque()
        self.playback: float | None = None  # stream time being played; None: point to point
        self._slider_lag = 0.0  # stream time the speed slider has held playback back (s)
        self._catch = 1.0  # the playback's pace, as a multiple of the stream's
        self._stream_start = -math.inf
        self.accepted = 0
        self.rejected = 0
        self.scaled_steps = 0  # steps in which playback was slowed for the joints
        self.last_reason = ""
        self.stopped = ""  #: why the arm is in a protective stop ("" = it is not)

    # --- setpoints ------------------------------------------------------------------------------
    def set_setpoint(self, position, quat_xyzw, frame_id: str = "world",
                     stamp_s: float | None = None) -> SetpointResult:
        """Accept a TCP pose stamped ``stamp_s`` (s, the sim's clock; None or implausible:
        now) into the stream, or reject it and hold still."""
        if self.stopped:
            self.rejected += 1
            return SetpointResult(False, f"protective stop ({self.stopped}): unlock it first")
        result = self._solve(position, quat_xyzw, frame_id, stamp_s)
        if result.accepted:
            self.accepted += 1
        else:
            self.rejected += 1
            self.last_reason = result.reason
            self.hold()
        return result

    def _solve(self, position, quat_xyzw, frame_id: str, stamp_s: float | None = None
               ) -> SetpointResult:
        reference = self.stream[-1][1] if self.stream else self.q_cmd
        q, reason = self._check_and_solve(position, quat_xyzw, frame_id, reference)
        if q is None:
            return SetpointResult(False, reason)
        self._enqueue(self._stamp(stamp_s), q)
        return SetpointResult(True)

    def _check_and_solve(self, position, quat_xyzw, frame_id: str, reference: np.ndarray
                         ) -> tuple[np.ndarray | None, str]:
        """The joints for a TCP pose, nearest ``reference``, or None and why not."""
        if frame_id not in ACCEPTED_FRAMES:
            return None, f"frame_id '{frame_id}' is not 'world'"
        pos = np.asarray(position, dtype=float)
        quat = np.asarray(quat_xyzw, dtype=float)
        if pos.shape != (3,) or quat.shape != (4,):
            return None, "a pose needs 3 position and 4 quaternion values"
        if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(quat))):
            return None, f"non-finite pose {pos.tolist()} {quat.tolist()}"
        norm = float(np.linalg.norm(quat))
        if abs(norm - 1.0) > 0.1:
            return None, f"quaternion norm {norm:.3f} is not ~1"
        if pos[2] < self.min_tcp_z:
            return None, f"TCP z = {pos[2]:.4f} m is below the safety plane {self.min_tcp_z} m"
        ik = solve_tcp_ik(pose_matrix(pos, quat / norm), reference)
        if not ik.ok:
            return None, ik.reason
        return ik.q, ""

    def _stamp(self, stamp_s: float | None) -> float:
        """The setpoint's time on the stream: its stamp, unless missing or far from now."""
        if stamp_s is None or not math.isfinite(stamp_s) or abs(stamp_s - self.now) > 5.0:
            return self.now
        return float(stamp_s)

    def _enqueue(self, t: float, q: np.ndarray) -> None:
        if self.stream and t <= self.stream[-1][0]:
            self.stream[-1] = (self.stream[-1][0], q)  # same instant: the newer pose wins
            return
        if not self.stream or t - self.stream[-1][0] > STREAM_GAP_S:
            # a new stream: reach its first point point-to-point, then play it back
            self.stream.clear()
            self.playback = None
            self._slider_lag = 0.0
            self._catch = 1.0
            self.q_target = q
            self._stream_start = t
        self.stream.append((t, q))

    def hold(self) -> None:
        """Stop where the arm is commanded now (the stream is dropped)."""
        self.stream.clear()
        self.playback = None
        self.q_target = self.q_cmd.copy()
        self.v_cmd = np.zeros(6)

    def protective_stop(self, q_measured, why: str) -> None:
        """Stop at once where the arm is measured (not where it was commanded: that may lie
        further into what it hit) and take no setpoint until ``unlock``."""
        self.hold()
        self.q_cmd = np.array(q_measured, dtype=float)
        self.q_target = self.q_cmd.copy()
        self.stopped = why or "stopped"

    def unlock(self) -> bool:
        """Leave a protective stop; False when there was none."""
        was, self.stopped = bool(self.stopped), ""
        return was

    def set_speed_scaling(self, fraction: float) -> None:
        """The speed slider, as a fraction (the driver reports percent): clipped to [0, 1]."""
        if not math.isfinite(fraction):
            raise ValueError(f"speed scaling {fraction} is not finite")
        self.speed_scaling = min(max(float(fraction), 0.0), 1.0)

    @property
    def stream_time(self) -> float | None:
        """The stamp time (s) of the stream the arm is commanded at now: where playback stands,
        or the stream's first stamp while the arm still travels to its first point; None when
        no stream is left to play (what a commander paces itself on)."""
        if self.playback is not None:
            return self.playback
        return self.stream[0][0] if self.stream else None

    def set_joint_target(self, q) -> None:
        """Move to a joint configuration (home/park) point to point, with the same limits."""
        self.stream.clear()
        self.playback = None
        self.q_target = np.array(q, dtype=float)

    # --- stepping -------------------------------------------------------------------------------
    def step(self, dt: float, now: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Advance the command by ``dt`` seconds to time ``now`` (s; default: the controller's
        own clock + dt); returns (q_cmd, v_cmd)."""
        self.now = self.now + dt if now is None else float(now)
        if self.playback is None and self.stream and self._at(self.stream[0][1]):
            self.playback = self.stream[0][0]  # on the stream's first point: play it back
        if self.playback is not None:
            self._play(dt)
        else:  # towards the first point of a stream, or a joint target, point to point
            self._point_to_point(dt)
        return self.q_cmd.copy(), self.v_cmd.copy()

    def _at(self, q: np.ndarray) -> bool:
        return float(np.max(np.abs(q - self.q_cmd))) < 1e-12

    def _play(self, dt: float) -> None:
        """Follow the stream ``servo_delay_s`` behind its stamps, slowed where the joints
        cannot keep up (the path is kept, the timing stretched), catching up where it fell
        behind (``CATCH_UP``) but not the time the speed slider took."""
        assert self.playback is not None
        pace = dt * self.speed_scaling
        self._slider_lag += dt - pace
        due = self.now - self.servo_delay_s - self._slider_lag
        behind = due - self.playback
        # the lag to catch up on: up to what is due, but never closer to the newest setpoint
        # than CATCH_UP_MARGIN_S, and none while the stream is starved (its newest setpoint
        # older than what is due): chasing a commander that sends late runs the playback into
        # the stream's end faster, stop and go, the tool off its path (a block set down 2 mm
        # low, a protective stop, in the arm calibration test)
        newest = self.stream[-1][0]
        catchable = min(due, newest - CATCH_UP_MARGIN_S) - self.playback if newest >= due else 0.0
        self._catch += self._catch_step(catchable, pace)
        pace = min(pace * self._catch, max(behind, pace))
        goal = min(due, self.stream[-1][0])
        advance = max(0.0, min(pace, goal - self.playback))
        if advance <= 0.0:
            if self.playback >= self.stream[-1][0]:
                self._settle(dt)  # played to the newest setpoint: stop on it
            else:
                self.v_cmd = np.zeros(6)  # the next setpoint's time has not come yet
            return
        scale = 1.0
        for _ in range(4):  # the stream is piecewise linear: refine the scale on its kinks
            q = self._sample(self.playback + advance * scale)
            fraction = self._feasible_scale((q - self.q_cmd) / dt, dt)
            if fraction >= 1.0 - 1e-9:
                break
            scale *= fraction
        else:
            q = self._sample(self.playback + advance * scale)
        if scale < 1.0:
            self.scaled_steps += 1
        self.playback += advance * scale
        self.v_cmd = (q - self.q_cmd) / dt
        self.q_cmd = q
        while len(self.stream) > 2 and self.stream[2][0] <= self.playback:
            self.stream.popleft()  # (one setpoint before the current one stays, for tangents)

    def _catch_step(self, lag_s: float, pace: float) -> float:
        """The change of the catch-up factor this step, at most ``CATCH_UP_RAMP`` either way:
        towards the largest factor from which ramping back down to 1 still lands on the
        stream's pace as the lag closes (so the speed never jumps), capped at ``CATCH_UP``."""
        lag_steps = max(0.0, lag_s / pace - 1.0) if pace > 0.0 else 0.0  # (on pace: 1 step)
        # ramping down from an excess of n ramps closes r * n (n + 1) / 2 steps of lag
        ramps = math.floor((math.sqrt(1.0 + 8.0 * lag_steps / CATCH_UP_RAMP) - 1.0) / 2.0 + 1e-9)
        wanted = 1.0 + min(CATCH_UP - 1.0, ramps * CATCH_UP_RAMP)
        return max(-CATCH_UP_RAMP, min(CATCH_UP_RAMP, wanted - self._catch))

    def _settle(self, dt: float) -> None:
        """Played up to the newest setpoint: stop on it."""
        self.q_target = self.stream[-1][1]
        self._point_to_point(dt)

    def _feasible_scale(self, v_full: np.ndarray, dt: float) -> float:
        """Largest fraction of this step's playback the joints' velocity and acceleration
        limits allow (velocity taken as proportional to the fraction)."""
        scale = 1.0
        with np.errstate(divide="ignore", invalid="ignore"):
            speed = np.abs(v_full)
            scale = min(scale, float(np.min(np.where(speed > 0, self.v_max / speed, np.inf))))
            room = self.a_max * dt
            upper = np.where(v_full > 0, (self.v_cmd + room) / v_full,
                             np.where(v_full < 0, (self.v_cmd - room) / v_full, np.inf))
        return max(0.0, min(scale, float(np.min(upper))))

    def _sample(self, t: float) -> np.ndarray:
        """The stream's joint positions at stream time ``t``: a cubic Hermite curve through
        the setpoints with finite-difference tangents (Catmull-Rom), so joint velocities
        change smoothly between setpoints instead of jumping at each one."""
        stream = self.stream
        if t <= stream[0][0]:
            return stream[0][1]
        if t >= stream[-1][0]:
            return stream[-1][1]
        k = next(i for i in range(1, len(stream)) if t <= stream[i][0])
        (t0, q0), (t1, q1) = stream[k - 1], stream[k]
        h = t1 - t0
        m0 = self._tangent(k - 1) * h
        m1 = self._tangent(k) * h
        u = (t - t0) / h
        u2, u3 = u * u, u * u * u
        return ((2 * u3 - 3 * u2 + 1) * q0 + (u3 - 2 * u2 + u) * m0
                + (-2 * u3 + 3 * u2) * q1 + (u3 - u2) * m1)

    def _tangent(self, i: int) -> np.ndarray:
        """dq/dt at setpoint ``i``: central difference; zero at the stream's first point (the
        arm starts from rest) and at its newest one (where it stops if no more come)."""
        stream = self.stream
        if i == len(stream) - 1 or stream[i][0] == self._stream_start:
            return np.zeros(6)
        before = stream[max(i - 1, 0)]
        after = stream[i + 1]
        return (after[1] - before[1]) / (after[0] - before[0])

    def _point_to_point(self, dt: float) -> None:
        """One step towards ``q_target``."""
        error = self.q_target - self.q_cmd
        dist = np.abs(error)
        if float(np.max(dist)) < 1e-12:
            self.v_cmd = np.zeros(6)
            return
        # Per-joint speed we may have now: the limit, what still brakes to a stop on the target
        # (discrete-time bound), what reaches it this step; one common scale keeps the motion
        # on a straight line in joint space, and one common fraction of the velocity change
        # keeps every joint inside its acceleration limit.
        s = self.speed_scaling
        if s <= 0.0:
            self.v_cmd = np.zeros(6)
            return
        a_dt = self.a_max * (s * s) * dt
        brake = a_dt * (np.sqrt(0.25 + 2.0 * dist / (a_dt * dt)) - 0.5)
        allowed = np.minimum(np.minimum(self.v_max * s, brake), dist / dt)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(dist > 0, allowed / dist, np.inf)
        dv = error * float(np.min(ratio)) - self.v_cmd
        with np.errstate(divide="ignore", invalid="ignore"):
            room = np.where(np.abs(dv) > 0, a_dt / np.abs(dv), np.inf)
        v = self.v_cmd + dv * min(1.0, float(np.min(room)))
        step = v * dt
        # Never step past the target (possible only right after the target jumped back).
        over = np.abs(step) > dist
        step = np.where(over, error, step)
        v = np.where(over, error / dt, v)
        self.q_cmd = self.q_cmd + step
        self.v_cmd = v

    def target_tcp(self) -> np.ndarray:
        q = self.stream[-1][1] if self.stream else self.q_target
        return tcp_pose(q)

    @property
    def settled(self) -> bool:
        q = self.stream[-1][1] if self.stream else self.q_target
        return bool(np.max(np.abs(q - self.q_cmd)) < 1e-9)
