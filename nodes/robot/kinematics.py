"""UR10e kinematics in ``world`` (= the UR's DH base frame): DH forward kinematics, the TCP,
and closed-form IK through ``ur_analytic_ik`` with the branch choice the controller needs.

Branch choice: of the (up to 8) closed-form solutions of a pose *and* of the same pose
turned by pi about the tool z axis (a two-finger grasp at yaw and at yaw + pi is the same
grasp), each joint is moved by whole turns to the value nearest the current joint (inside
+-2 pi), and the solution the arm reaches soonest (largest per-joint travel / velocity
limit) wins. So a stream of nearby setpoints never asks for a wrist flip or an elbow swap.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from ur_analytic_ik import ur10e as ur10e_ik

from nodes.robot import gripper_2f85 as g85
from nodes.robot import ur10e

TWO_PI = 2.0 * math.pi
#: Flange -> TCP: straight out of the flange to the fingertips; x stays the closing axis.
FLANGE_TO_TCP = np.eye(4)
FLANGE_TO_TCP[2, 3] = g85.TCP_OFFSET
TCP_TO_FLANGE = np.linalg.inv(FLANGE_TO_TCP)
#: Turning the tool by pi about its z axis swaps the fingers: the same two-finger grasp.
FLIP_Z = np.diag([-1.0, -1.0, 1.0, 1.0])
#: Closed-form solutions are checked against FK; anything worse is discarded (m, rad).
IK_CHECK_POS = 1e-6
IK_CHECK_ROT = 1e-6
#: Branches that put the elbow or a wrist joint this close to the table top are discarded (m).
MIN_JOINT_HEIGHT = 0.05


def dh_transform(theta: float, d: float, a: float, alpha: float) -> np.ndarray:
    """Standard DH: Rz(theta) Tz(d) Tx(a) Rx(alpha)."""
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array([
        [ct, -st * ca, st * sa, a * ct],
        [st, ct * ca, -ct * sa, a * st],
        [0.0, sa, ca, d],
        [0.0, 0.0, 0.0, 1.0],
    ])


def flange_pose(q) -> np.ndarray:
    """4x4 pose of the tool flange (DH frame 6) in ``world``."""
    t = np.eye(4)
    for i in range(6):
        t = t @ dh_transform(float(q[i]), ur10e.DH_D[i], ur10e.DH_A[i], ur10e.DH_ALPHA[i])
    return t


def tcp_pose(q) -> np.ndarray:
    """4x4 pose of the TCP (between the fingertips) in ``world``."""
    return flange_pose(q) @ FLANGE_TO_TCP


def pose_error(t_a: np.ndarray, t_b: np.ndarray) -> tuple[float, float]:
    """(position error m, rotation error rad) between two 4x4 poses."""
    dp = float(np.linalg.norm(t_a[:3, 3] - t_b[:3, 3]))
    cos_angle = (np.trace(t_a[:3, :3].T @ t_b[:3, :3]) - 1.0) / 2.0
    return dp, math.acos(max(-1.0, min(1.0, cos_angle)))


def nearest_turn(q: np.ndarray, q_ref: np.ndarray, limit: float = ur10e.JOINT_LIMIT) -> np.ndarray:
    """Each joint of ``q`` moved by whole turns to the value nearest ``q_ref`` within +-limit."""
    out = q_ref + np.remainder(q - q_ref + math.pi, TWO_PI) - math.pi
    out = np.where(out > limit, out - TWO_PI, out)
    return np.where(out < -limit, out + TWO_PI, out)


@dataclass(frozen=True)
class IkResult:
    """A solution ``q`` (rad) or ``None`` with ``reason`` saying why there is none."""

    q: np.ndarray | None
    reason: str = ""
    flipped: bool = False  # the solution reaches the pose turned by pi about the tool z

    @property
    def ok(self) -> bool:
        return self.q is not None


def joint_origins(q) -> np.ndarray:
    """(6, 3) positions of DH frames 1..6 in world (shoulder, elbow, wrists, flange)."""
    t = np.eye(4)
    out = np.empty((6, 3))
    for i in range(6):
        t = t @ dh_transform(float(q[i]), ur10e.DH_D[i], ur10e.DH_A[i], ur10e.DH_ALPHA[i])
        out[i] = t[:3, 3]
    return out


def joint_heights(qs: np.ndarray) -> np.ndarray:
    """(n, 4) world z of the elbow, wrist 1, wrist 2 and wrist 3 joint centres (closed form).

    Vectorised over solutions: the elbow at d1 + a2 sin q2, wrist 1 a3 sin(q2 + q3) higher,
    wrist 2 at the same height (d4 is horizontal), wrist 3 -d5 cos(q2 + q3 + q4) from there.
    """
    qs = np.atleast_2d(qs)
    q2, q23, q234 = qs[:, 1], qs[:, 1] + qs[:, 2], qs[:, 1] + qs[:, 2] + qs[:, 3]
    elbow = ur10e.DH_D[0] + ur10e.DH_A[1] * np.sin(q2)
    wrist1 = elbow + ur10e.DH_A[2] * np.sin(q23)
    wrist3 = wrist1 - ur10e.DH_D[4] * np.cos(q234)
    return np.column_stack([elbow, wrist1, wrist1, wrist3])


def _solutions(t_flange: np.ndarray) -> tuple[np.ndarray, int]:
    """(n, 6) checked closed-form solutions, and how many went below the table."""
    sols = ur10e_ik.inverse_kinematics(np.ascontiguousarray(t_flange, dtype=float))
    if not sols:
        return np.empty((0, 6)), 0
    qs = np.asarray(sols, dtype=float)
    qs = qs[np.all(np.isfinite(qs), axis=1)]
    if not len(qs):
        return qs, 0
    error = np.abs(np.stack([ur10e_ik.forward_kinematics(*q) for q in qs]) - t_flange)
    ok = (error[:, :3, 3].max(axis=1) <= IK_CHECK_POS) & (
        error[:, :3, :3].reshape(len(qs), -1).max(axis=1) <= IK_CHECK_ROT)
    qs = qs[ok]
    above = joint_heights(qs).min(axis=1) >= MIN_JOINT_HEIGHT
    return qs[above], int(np.count_nonzero(~above))


def travel_time(q: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
    """Seconds the slowest joint needs at its velocity limit (per row of ``q``): the
    branch-choice metric."""
    return np.max(np.abs(q - q_ref) / np.asarray(ur10e.JOINT_VELOCITY_LIMIT), axis=-1)


def solve_tcp_ik(t_tcp: np.ndarray, q_ref, allow_flip: bool = True) -> IkResult:
    """Joint angles that put the TCP at ``t_tcp`` (4x4 in world), nearest ``q_ref``."""
    if not np.all(np.isfinite(t_tcp)):
        return IkResult(None, "setpoint is not finite")
    q_ref = np.asarray(q_ref, dtype=float)
    targets = [(t_tcp, False)] + ([(t_tcp @ FLIP_Z, True)] if allow_flip else [])
    below = 0
    found, flags = [], []
    for target, flipped in targets:
        sols, dropped = _solutions(target @ TCP_TO_FLANGE)
        below += dropped
        found.append(sols)
        flags += [flipped] * len(sols)
    candidates = nearest_turn(np.concatenate(found), q_ref) if flags else np.empty((0, 6))
    if not len(candidates):
        reach = float(np.linalg.norm(t_tcp[:3, 3]))
        if below:
            return IkResult(None, f"no IK solution keeps the elbow and wrists above the table "
                                  f"(TCP {reach:.3f} m from the base)")
        return IkResult(None, f"no IK solution: TCP pose out of the UR10e's reach "
                              f"({reach:.3f} m from the base)")
    best = int(np.argmin(travel_time(candidates, q_ref)))
    return IkResult(candidates[best], flipped=flags[best])
