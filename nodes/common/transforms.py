"""Rigid transforms with numpy: quaternions (x, y, z, w order), 4x4 matrices, tool poses.

Conventions shared by the sim's arm controller and the executor:

* ``world``: origin at the UR10e base on the table top, z up (REP 103).
* The tool frame (TCP) sits between the fingertips; its z axis points out of the gripper
  (down, into the table, for every densepack motion) and its x axis is the fingers'
  closing axis. ``tool_down_quaternion(yaw)`` is that frame with x at ``yaw`` in the table
  plane; yaw and yaw + pi close the fingers along the same line.
"""

from __future__ import annotations

import math

import numpy as np


def quaternion_to_matrix(q_xyzw) -> np.ndarray:
    x, y, z, w = (float(v) for v in q_xyzw)
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if n == 0.0:
        raise ValueError("zero quaternion")
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_to_quaternion(rot: np.ndarray) -> np.ndarray:
    """Rotation matrix -> unit quaternion (x, y, z, w) with w >= 0 (Shepperd's method)."""
    m = np.asarray(rot, dtype=float)
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace > 0.0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s, (m[1, 0] - m[0, 1]) / s]
    q = np.array(q)
    q /= np.linalg.norm(q)
    return -q if q[3] < 0.0 else q


def pose_matrix(position, q_xyzw) -> np.ndarray:
    """4x4 homogeneous transform from a position and a quaternion (x, y, z, w)."""
    t = np.eye(4)
    t[:3, :3] = quaternion_to_matrix(q_xyzw)
    t[:3, 3] = np.asarray(position, dtype=float)
    return t


def tool_down_matrix(yaw: float) -> np.ndarray:
    """Rotation of a tool pointing straight down with its closing axis (x) at ``yaw``."""
    c, s = math.cos(yaw), math.sin(yaw)
    x_axis = np.array([c, s, 0.0])
    z_axis = np.array([0.0, 0.0, -1.0])
    y_axis = np.cross(z_axis, x_axis)
    return np.column_stack([x_axis, y_axis, z_axis])


def tool_down_quaternion(yaw: float) -> np.ndarray:
    return matrix_to_quaternion(tool_down_matrix(yaw))


def rotation_angle(r_a: np.ndarray, r_b: np.ndarray) -> float:
    """Angle (rad) of the relative rotation between two rotation matrices."""
    cos_angle = (np.trace(np.asarray(r_a).T @ np.asarray(r_b)) - 1.0) / 2.0
    return math.acos(max(-1.0, min(1.0, cos_angle)))


def yaw_of_matrix(rot: np.ndarray) -> float:
    """Heading of the frame's x axis projected on the table plane."""
    return math.atan2(rot[1, 0], rot[0, 0])
