"""When, on its way, the arm leaves the blocks to judge in the camera's view.

After an action the executor judges the world from a frame taken while the arm already
travels to the next block (``observe``). Which moment: the executor knows the script it is
about to play, so it plays it dry (``script_samples``: the tool poses the setpoints will
take, every ``SAMPLE_S``), puts the arm into each pose (the UR10e's IK, on the branch the arm
works on), and asks the robot's silhouette (``nodes.robot.silhouette``) which top faces of
the blocks it covers. The frame is taken at the sample that covers none of the blocks the
next action needs judged and the fewest of the others not yet seen since an action near them
(``best_moment``); with none such, the arm has to look from beside the workspace.

The detector says what the robot really covered in the frame it took (its joint states at
the frame's stamp); this prediction only picks the moment, so it may be rough: the camera
pose from the calibration file, the fingers taken wide open.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from msgs_py import Pose2D
from msgs_py.cell import GRIPPER_STROKE
from nodes.common.camera_model import CameraModel
from nodes.common.transforms import pose_matrix, tool_down_quaternion
from nodes.executor.motion import ToolPose
from nodes.executor.steps import Step, StepRunner
from nodes.robot import ur10e
from nodes.robot.kinematics import solve_tcp_ik
from nodes.robot.silhouette import MARGIN_PX, block_top_corners, robot_silhouette

#: The dry run's setpoints are looked at this often (s of script time).
SAMPLE_S = 0.1
#: A dry run longer than this (s) is cut (a script that does not end by itself).
MAX_SCRIPT_S = 20.0


@dataclass(frozen=True)
class View:
    """The camera as the executor knows it, and the blocks' size."""

    camera: CameraModel
    block_size: float
    margin_px: float = MARGIN_PX

    def covered(self, q: Sequence[float], blocks: Mapping[int, Pose2D]) -> set[int]:
        """The blocks whose top face the arm at joints ``q`` (fingers wide open) covers."""
        silhouette = robot_silhouette(q, GRIPPER_STROKE, self.camera.project,
                                      lambda p: self.camera.to_camera(p)[:, 2], self.margin_px)
        return {i for i, p in blocks.items()
                if silhouette.covers(self.camera.project(
                    block_top_corners(p.x, p.y, p.theta, self.block_size)), self.margin_px)}


def script_samples(steps: Sequence[Step], start: ToolPose, in_safe_box: Callable[[ToolPose],
                   bool], tol: float) -> list[tuple[float, ToolPose]]:
    """(script time s, tool pose) every SAMPLE_S of ``steps`` played from ``start`` with the
    arm taken to follow its setpoints exactly and the gripper to answer at once."""
    runner = StepRunner(steps, start, tol, MAX_SCRIPT_S, in_safe_box)
    samples: list[tuple[float, ToolPose]] = []
    t, measured = 0.0, start
    while t <= MAX_SCRIPT_S:
        tick = runner.update(t, measured)
        if tick.fault is not None:
            break
        samples.append((t, tick.setpoint))
        measured = tick.setpoint
        if tick.done and runner.finished:
            break
        t += SAMPLE_S
    return samples


def arm_postures(poses: Sequence[ToolPose], q_start: Sequence[float] | None = None
                 ) -> list[np.ndarray | None]:
    """The arm's joints at each tool pose (None where the IK finds none), each solved
    nearest the one before, from the branch the arm works on."""
    q_ref = np.asarray(ur10e.WORKING_BRANCH_JOINTS if q_start is None else q_start, float)
    out: list[np.ndarray | None] = []
    for pose in poses:
        ik = solve_tcp_ik(pose_matrix(pose.position, tool_down_quaternion(pose.yaw)), q_ref)
        out.append(ik.q)
        if ik.q is not None:
            q_ref = ik.q
    return out


def best_moment(view: View, samples: Sequence[tuple[float, ToolPose]],
                blocks: Mapping[int, Pose2D], need: set[int], wanted: set[int]
                ) -> float | None:
    """The sample time at which the arm covers none of ``need`` and the fewest of ``wanted``
    (the earliest of those), their poses in ``blocks``; None if it covers one of ``need`` at
    every sample, or, with nothing needed, every one of ``wanted`` at every sample."""
    looked = {i: blocks[i] for i in need | wanted if i in blocks}
    best: tuple[int, float] | None = None
    postures = arm_postures([pose for _, pose in samples])
    for (t, _), q in zip(samples, postures, strict=True):
        if q is None:
            continue
        covered = view.covered(q, looked)
        if covered & need or (not need and covered >= set(looked)):
            continue
        score = len(covered & wanted)
        if best is None or score < best[0]:
            best = (score, t)
        if score == 0:
            break
    return None if best is None else best[1]


def footprint(start: Pose2D, end: Pose2D, step: float = 0.025) -> list[tuple[float, float]]:
    """Points along an action's way from ``start`` to ``end`` (a pick-and-place acts at the
    two ends, a push all along; the points between cost a pick-and-place nothing but a few
    more neighbours judged)."""
    n = max(1, math.ceil(math.hypot(end.x - start.x, end.y - start.y) / step))
    return [(start.x + (end.x - start.x) * k / n, start.y + (end.y - start.y) * k / n)
            for k in range(n + 1)]


def neighbours(blocks: Mapping[int, Pose2D], points: Sequence[tuple[float, float]],
               radius: float) -> set[int]:
    """The blocks standing within ``radius`` (m) of any of ``points`` (x, y)."""
    return {i for i, p in blocks.items()
            if any(math.hypot(p.x - x, p.y - y) <= radius for x, y in points)}
