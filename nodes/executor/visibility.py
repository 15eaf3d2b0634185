"""When, on its way, the arm leaves the blocks to judge in the camera's view.

After an action the executor judges the world from a frame taken while the arm already
travels to the next block (``observe``). Which moment: the executor knows the script it is
about to play, so it plays it dry (``script_samples``: the tool poses the setpoints will
take, every ``SAMPLE_S``), puts the arm into each pose (the UR10e's IK, on the branch of the
joints the arm reported last), and asks the robot's silhouette (``nodes.robot.silhouette``)
which top faces of the blocks it covers. The frame is taken at the sample that covers none
of the blocks the next action needs judged and the fewest of the others not yet seen since an
action near them (``best_moment``); with none such, the arm has to look from beside the
workspace.

The detector says what the robot really covered in the frame it took (its joint states at
the frame's stamp); this prediction only picks the moment, so it may be rough: the camera
pose from the calibration file, the fingers taken wide open.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from msgs_py import PickPlace, Pose2D, Push
from msgs_py.cell import GRIPPER_STROKE, TAG_SIZE
from nodes.common.camera_model import CameraModel
from nodes.common.transforms import pose_matrix, tool_down_quaternion
from nodes.executor.motion import ToolPose
from nodes.executor.steps import Step, StepRunner
from nodes.robot import ur10e
from nodes.robot.kinematics import solve_tcp_ik
from nodes.robot.silhouette import MARGIN_PX, hulls_cover, robot_hulls, top_square

#: The dry run's setpoints are looked at this often (s of script time).
SAMPLE_S = 0.05
#: A dry run longer than this (s) is cut (a script that does not end by itself).
MAX_SCRIPT_S = 20.0
#: The frame must show what it is taken for this many samples after the moment picked too.
LATE_SAMPLES = 2


@dataclass(frozen=True)
class View:
    """The camera as the executor knows it, and the blocks' size."""

    camera: CameraModel
    block_size: float
    tag_size: float = TAG_SIZE
    margin_px: float = MARGIN_PX

    def covered(self, q: Sequence[float], blocks: Mapping[int, Pose2D]) -> set[int]:
        """The blocks whose tag the arm at joints ``q`` (fingers wide open) covers, as the
        detector judges it (the same solids, the same margin; ``hulls_cover``)."""
        hulls = robot_hulls(q, GRIPPER_STROKE, self.camera.project,
                            lambda p: self.camera.to_camera(p)[:, 2])
        ids = list(blocks)
        squares = [self.camera.project(top_square(blocks[i].x, blocks[i].y, blocks[i].theta,
                                                  self.tag_size, self.block_size))
                   for i in ids]
        return {i for i, hit in zip(ids, hulls_cover(hulls, squares, self.margin_px),
                                    strict=True) if hit}


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


def chained_postures(poses: Iterable[ToolPose], q_start: Sequence[float] | None = None
                     ) -> Iterator[np.ndarray | None]:
    """The arm's joints at each tool pose in turn (None where the IK finds none), each solved
    nearest the one before, from ``q_start``: the joints the arm has now (the arm node solves
    each setpoint nearest the joints before it, so it keeps its branch; one that left the
    working branch on a far reach stays on the other), else the branch the arm works on."""
    q_ref = np.asarray(ur10e.WORKING_BRANCH_JOINTS if q_start is None else q_start, float)
    for pose in poses:
        ik = solve_tcp_ik(pose_matrix(pose.position, tool_down_quaternion(pose.yaw)), q_ref)
        if ik.q is not None:
            q_ref = ik.q
        yield ik.q


def arm_postures(poses: Sequence[ToolPose], q_start: Sequence[float] | None = None
                 ) -> list[np.ndarray | None]:
    """``chained_postures`` of every pose at once."""
    return list(chained_postures(poses, q_start))


class CoveredAlong:
    """What the arm covers of ``blocks`` at each of ``poses`` (None: no IK), the postures
    chained from ``q_start`` as ``arm_postures`` chains them, worked out only as far as it
    is asked: the search for a moment mostly ends early, and a way's every posture and
    silhouette cost the look through a waypoint 0.2 s of the tick that ends an action."""

    def __init__(self, view: View, poses: Sequence[ToolPose], blocks: Mapping[int, Pose2D],
                 q_start: Sequence[float] | None = None) -> None:
        self.view, self.count, self.blocks = view, len(poses), blocks
        self.postures = chained_postures(poses, q_start)
        self.known: list[set[int] | None] = []

    def __getitem__(self, k: int) -> set[int] | None:
        while len(self.known) <= k:
            q = next(self.postures)
            self.known.append(None if q is None else self.view.covered(q, self.blocks))
        return self.known[k]

    def span(self, start: int, stop: int) -> list[set[int] | None]:
        return [self[j] for j in range(start, min(stop, self.count))]


def best_moment(view: View, samples: Sequence[tuple[float, ToolPose]],
                blocks: Mapping[int, Pose2D], need: set[int], wanted: set[int],
                q_start: Sequence[float] | None = None) -> float | None:
    """The sample time at which the arm covers none of ``need``, nor at the sample before it
    and the LATE_SAMPLES after it (the frame is taken when the measured tool passes the pose,
    a joint-state period and the trigger's way to the camera later: up to 48 mm further at
    travel speed; frames taken that late covered a block to judge, the look pose then, in 10
    of 103 frames on the way in ten 9-block scenes), and the fewest of ``wanted`` (the
    earliest of those), their poses in ``blocks``; None if it covers one of ``need`` around
    every sample, or, with nothing needed, every one of ``wanted`` at every sample. The arm's
    postures are chained from ``q_start`` (``arm_postures``)."""
    looked = {i: blocks[i] for i in need | wanted if i in blocks}
    covered = CoveredAlong(view, [pose for _, pose in samples], looked, q_start)
    best: tuple[int, float] | None = None
    for k, (t, _) in enumerate(samples):
        around = covered.span(max(k - 1, 0), k + 1 + LATE_SAMPLES)
        now = covered[k]
        if now is None or any(c is None or c & need for c in around):
            continue
        if not need and now >= set(looked):
            continue
        score = len(now & wanted)
        if best is None or score < best[0]:
            best = (score, t)
        if score == 0:
            break
    return None if best is None else best[1]


#: A frame triggered now is taken this much later (s): the joint states' age at the tick, the
#: tick, and the trigger's way to the camera (a tick and a half of the sim's clock).
FRAME_DELAY_S = 0.06


def shows(view: View, q: Sequence[float], rates: Sequence[float] | None,
          blocks: Mapping[int, Pose2D]) -> bool:
    """Whether the arm at joints ``q``, and where its joint ``rates`` (rad/s; None: at rest)
    take it FRAME_DELAY_S later, covers none of ``blocks``' tags."""
    postures = [np.asarray(q, float)]
    if rates is not None:
        postures.append(postures[0] + FRAME_DELAY_S * np.asarray(rates, float))
    return not any(view.covered(p, blocks) for p in postures)


#: Waypoints to look from lie on a grid this fine (m) over the workspace and its robot side.
WAYPOINT_STEP = 0.05


def look_waypoints(view: View, here: ToolPose, then: ToolPose, blocks: Mapping[int, Pose2D],
                   need: set[int], area: tuple[float, float, float, float], count: int,
                   q_start: Sequence[float] | None = None) -> list[ToolPose]:
    """Where to pass on the way from ``here`` to ``then`` (both at travel height) for the
    camera to see ``need``: of the points of a grid over ``area`` (x_min, x_max, y_min,
    y_max) at ``here``'s height and yaw where the arm covers none of them, the ``count``
    that add the least way (fewer where there are fewer), the least first; the arm's posture
    at each on the branch of ``q_start`` (``arm_postures``)."""
    x0, x1, y0, y1 = area
    candidates = [ToolPose(x, y, here.z, here.yaw)
                  for x in np.arange(x0, x1 + 1e-9, WAYPOINT_STEP)
                  for y in np.arange(y0, y1 + 1e-9, WAYPOINT_STEP)]
    candidates.sort(key=lambda w: here.distance_to(w) + w.distance_to(then))
    wanted = {i: blocks[i] for i in need if i in blocks}
    found: list[ToolPose] = []
    for w in candidates:
        q = arm_postures([w], q_start)[0]
        if q is not None and not view.covered(q, wanted):
            found.append(w)
            if len(found) >= count:
                break
    return found


def footprint(start: Pose2D, action: PickPlace | Push, step: float = 0.025
              ) -> list[tuple[float, float]]:
    """Where an action acts, its block standing at ``start``: a pick-and-place at its two
    ends (it carries the block above the others), a push all along its line."""
    end = action.to
    if isinstance(action, PickPlace):
        return [(start.x, start.y), (end.x, end.y)]
    n = max(1, math.ceil(math.hypot(end.x - start.x, end.y - start.y) / step))
    return [(start.x + (end.x - start.x) * k / n, start.y + (end.y - start.y) * k / n)
            for k in range(n + 1)]


def neighbours(blocks: Mapping[int, Pose2D], points: Sequence[tuple[float, float]],
               radius: float) -> set[int]:
    """The blocks standing within ``radius`` (m) of any of ``points`` (x, y)."""
    return {i for i, p in blocks.items()
            if any(math.hypot(p.x - x, p.y - y) <= radius for x, y in points)}
