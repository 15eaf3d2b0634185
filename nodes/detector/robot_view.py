"""The robot's pose at a frame's stamp, from the drivers' joint states, and which blocks it
covers in that frame.

The arm's joint states (ur_robot_driver's ``/joint_states``, read by name) and the gripper's
knuckle (the Robotiq driver's) come far more often than frames; both are kept for a short
while, and a frame's robot is interpolated at the frame's stamp. A frame whose stamp no joint
state brackets closely enough (``max_gap_s``) has no robot pose: then no block is judged
covered, and the frame counts only where nothing of the robot could be in view (the executor
takes frames out of view then). Pure logic, no ROS.
"""

from __future__ import annotations

import bisect
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from msgs_py import BlockPose
from nodes.common.joints import values_by_name
from nodes.robot import gripper_2f85 as g85
from nodes.robot import ur10e
from nodes.robot.silhouette import MARGIN_PX, Silhouette, robot_silhouette

#: How long joint states are kept (s of their stamps).
KEEP_S = 5.0
#: A frame further than this from the nearest joint state on either side has no robot pose.
MAX_GAP_S = 0.1


@dataclass(frozen=True, slots=True)
class RobotPose:
    """The arm's joints (rad, kinematic order) and the gap between the pads (m)."""

    q: np.ndarray
    gap: float


class _Series:
    """Stamped values, oldest first, interpolated linearly between two samples."""

    def __init__(self) -> None:
        self.stamps: deque[float] = deque()
        self.values: deque[np.ndarray] = deque()

    def add(self, stamp: float, value: np.ndarray) -> None:
        if self.stamps and stamp < self.stamps[-1]:
            self.stamps.clear()  # time went back (a sim reset): start afresh
            self.values.clear()
        self.stamps.append(stamp)
        self.values.append(value)
        while self.stamps and self.stamps[0] < stamp - KEEP_S:
            self.stamps.popleft()
            self.values.popleft()

    def at(self, stamp: float, max_gap: float) -> np.ndarray | None:
        stamps = list(self.stamps)
        k = bisect.bisect_left(stamps, stamp)
        if k < len(stamps) and stamps[k] == stamp:
            return self.values[k]
        if k == 0 or k == len(stamps):
            near = 0 if k == 0 else k - 1
            return self.values[near] if stamps and abs(stamps[near] - stamp) <= max_gap \
                else None
        t0, t1 = stamps[k - 1], stamps[k]
        if stamp - t0 > max_gap and t1 - stamp > max_gap:
            return None
        u = (stamp - t0) / (t1 - t0)
        return (1 - u) * self.values[k - 1] + u * self.values[k]


class RobotPoses:
    """The robot's recent joint states, by name."""

    def __init__(self, max_gap_s: float = MAX_GAP_S) -> None:
        self.max_gap_s = max_gap_s
        self._arm = _Series()
        self._knuckle = _Series()

    def on_joint_state(self, names: Sequence[str], positions: Sequence[float],
                       stamp_s: float) -> None:
        """A joint state of either driver (the arm's joints, or the knuckle); one that lacks
        a joint it names of these is ignored."""
        arm, _ = values_by_name(names, positions, ur10e.ARM_JOINTS)
        if arm is not None:
            self._arm.add(stamp_s, arm)
        knuckle, _ = values_by_name(names, positions, (g85.KNUCKLE_JOINT,))
        if knuckle is not None:
            self._knuckle.add(stamp_s, knuckle)

    def at(self, stamp_s: float) -> RobotPose | None:
        """The robot at ``stamp_s`` (the fingers' gap taken as wide open if the gripper says
        nothing: the widest silhouette); None without the arm's joints near that time."""
        q = self._arm.at(stamp_s, self.max_gap_s)
        if q is None:
            return None
        knuckle = self._knuckle.at(stamp_s, self.max_gap_s)
        gap = g85.knuckle_to_gap(0.0 if knuckle is None else float(knuckle[0]))
        return RobotPose(q, gap)


def covered_blocks(robot: RobotPose, project_fn: Callable[[np.ndarray], np.ndarray],
                   depth_fn: Callable[[np.ndarray], np.ndarray],
                   seen_corners: Mapping[int, np.ndarray],
                   unseen: Mapping[int, BlockPose],
                   corners_fn: Callable[[BlockPose], np.ndarray],
                   margin_px: float = MARGIN_PX) -> set[int]:
    """Ids of the blocks the robot covers: seen ones by their tag's corners in the image
    (``seen_corners``: (4, 2) pixels), unseen known ones where they were last seen
    (``unseen``, their tag's world corners by ``corners_fn``)."""
    silhouette: Silhouette = robot_silhouette(robot.q, robot.gap, project_fn, depth_fn,
                                              margin_px)
    covered = {i for i, px in seen_corners.items() if silhouette.covers(px, margin_px)}
    for block_id, pose in unseen.items():
        pixels = project_fn(corners_fn(pose))
        if not np.all(np.isfinite(pixels)) or silhouette.covers(pixels, margin_px):
            covered.add(block_id)
    return covered
