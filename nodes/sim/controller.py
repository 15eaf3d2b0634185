"""The arm's own controller (like the UR's): setpoint validation, IK, joint rate limiting.

Pure logic, no PyBullet and no ROS: the world asks ``step(dt)`` for the joint position and
velocity to command each physics step; the node hands over setpoints and gripper commands.

* A Cartesian setpoint (TCP pose in ``world``) is validated (frame, finite, unit-able
  quaternion, above the safety plane ``min_tcp_z``), solved by closed-form IK with the branch
  nearest the current command (yaw and yaw + pi are the same grasp, so the nearer of the two
  is taken: streaming never asks for a 180-degree wrist flip), and becomes the joint target.
  A setpoint that fails any check is rejected with the reason and the arm holds still where
  it is commanded now.
* ``step`` moves the commanded joints towards the target on a straight line in joint space,
  no faster than each joint's velocity limit, with a per-joint acceleration limit and a
  braking profile that stops on the target without overshoot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from nodes.common.transforms import pose_matrix
from nodes.sim import robot_model as rm
from nodes.sim.kinematics import solve_tcp_ik, tcp_pose

ACCEPTED_FRAMES = ("world", "")


@dataclass(frozen=True)
class SetpointResult:
    accepted: bool
    reason: str = ""


class ArmController:
    """Streams joint commands towards the latest accepted TCP setpoint."""

    def __init__(self, q_start, min_tcp_z: float = 0.0, speed_scale: float = 1.0) -> None:
        if not 0.0 < speed_scale <= 1.0:
            raise ValueError(f"speed_scale must be in (0, 1], got {speed_scale}")
        self.v_max = np.asarray(rm.JOINT_VELOCITY_LIMIT) * speed_scale
        self.a_max = np.asarray(rm.JOINT_ACCELERATION_LIMIT)
        self.min_tcp_z = float(min_tcp_z)
        self.reset(q_start)

    def reset(self, q_start) -> None:
        self.q_cmd = np.array(q_start, dtype=float)
        self.v_cmd = np.zeros(6)
        self.q_target = self.q_cmd.copy()
        self.accepted = 0
        self.rejected = 0
        self.last_reason = ""

    # --- setpoints ------------------------------------------------------------------------------
    def set_setpoint(self, position, quat_xyzw, frame_id: str = "world") -> SetpointResult:
        """Accept a TCP pose as the new target, or reject it and hold still."""
        result = self._solve(position, quat_xyzw, frame_id)
        if result.accepted:
            self.accepted += 1
        else:
            self.rejected += 1
            self.last_reason = result.reason
            self.hold()
        return result

    def _solve(self, position, quat_xyzw, frame_id: str) -> SetpointResult:
        if frame_id not in ACCEPTED_FRAMES:
            return SetpointResult(False, f"frame_id '{frame_id}' is not 'world'")
        pos = np.asarray(position, dtype=float)
        quat = np.asarray(quat_xyzw, dtype=float)
        if pos.shape != (3,) or quat.shape != (4,):
            return SetpointResult(False, "a pose needs 3 position and 4 quaternion values")
        if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(quat))):
            return SetpointResult(False, f"non-finite pose {pos.tolist()} {quat.tolist()}")
        norm = float(np.linalg.norm(quat))
        if abs(norm - 1.0) > 0.1:
            return SetpointResult(False, f"quaternion norm {norm:.3f} is not ~1")
        if pos[2] < self.min_tcp_z:
            return SetpointResult(
                False, f"TCP z = {pos[2]:.4f} m is below the safety plane {self.min_tcp_z} m")
        ik = solve_tcp_ik(pose_matrix(pos, quat / norm), self.q_cmd)
        if not ik.ok:
            return SetpointResult(False, ik.reason)
        self.q_target = ik.q
        return SetpointResult(True)

    def hold(self) -> None:
        """Stop where the arm is commanded now."""
        self.q_target = self.q_cmd.copy()
        self.v_cmd = np.zeros(6)

    def set_joint_target(self, q) -> None:
        """Move to a joint configuration (home/park) with the same rate limits."""
        self.q_target = np.array(q, dtype=float)

    # --- stepping -------------------------------------------------------------------------------
    def step(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Advance the command by ``dt`` seconds; returns (q_cmd, v_cmd)."""
        error = self.q_target - self.q_cmd
        dist = np.abs(error)
        if float(np.max(dist)) < 1e-12:
            self.v_cmd = np.zeros(6)
            return self.q_cmd.copy(), self.v_cmd.copy()
        # Per-joint speed we may have now: the limit, what still brakes to a stop on the target
        # (discrete-time bound), what reaches it this step; one common scale keeps the motion
        # on a straight line in joint space, and one common fraction of the velocity change
        # keeps every joint inside its acceleration limit.
        a_dt = self.a_max * dt
        brake = a_dt * (np.sqrt(0.25 + 2.0 * dist / (a_dt * dt)) - 0.5)
        allowed = np.minimum(np.minimum(self.v_max, brake), dist / dt)
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
        return self.q_cmd.copy(), self.v_cmd.copy()

    def target_tcp(self) -> np.ndarray:
        return tcp_pose(self.q_target)

    @property
    def settled(self) -> bool:
        return bool(np.max(np.abs(self.q_target - self.q_cmd)) < 1e-9)


def clip_gripper_gap(gap: float) -> float:
    """Commanded pad gap (m) clipped to the 2F-85 stroke; refuses non-finite values."""
    if not math.isfinite(gap):
        raise ValueError(f"gripper command {gap} is not finite")
    return min(max(float(gap), 0.0), rm.GRIPPER_STROKE)
