"""Looking on the way: after an action the arm heads for the next block at once and the
frame is taken at the first moment the arm leaves the blocks to judge in view; the look pose
only when it covers one of them."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from msgs_py import BlockPose, PickPlace, Plan, Pose2D
from msgs_py.camera import CameraIntrinsics
from msgs_py.cell import GripperGeometry
from nodes.common.camera_model import CameraModel
from nodes.executor import observe
from nodes.executor.belief import Belief
from nodes.executor.core import ExecutorCore
from nodes.executor.decisions import LookOnTheWay
from nodes.executor.motion import ToolPose
from nodes.executor.observe import WAYPOINTS_TRIED, via_waypoint
from nodes.executor.primitives import hover_steps, look_pose
from nodes.executor.states import State
from nodes.executor.visibility import (
    LATE_SAMPLES,
    View,
    arm_postures,
    best_moment,
    look_waypoints,
    script_samples,
)
from nodes.robot.kinematics import tcp_pose
from tests.unit.executor.world import CFG, GOAL, START, WS, World, two_action_plan

#: An overhead camera like the cell's: 1.25 m over (0.70, 0), image x along -y, y along -x.
CAMERA = CameraModel(CameraIntrinsics(1280, 960, 1400.0, 1400.0, 639.5, 479.5),
                     np.array([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]),
                     np.array([0.70, 0.0, 1.25]))
VIEW = View(CAMERA, 0.0508)


class NearTool(View):
    """A stand-in view: the arm covers the blocks within ``radius`` of its tool (x, y)."""

    def __init__(self, radius: float = 0.07) -> None:
        super().__init__(CAMERA, 0.0508)
        object.__setattr__(self, "radius", radius)

    def covered(self, q, blocks):
        x, y = tcp_pose(q)[:2, 3]
        return {i for i, p in blocks.items() if math.hypot(p.x - x, p.y - y) < self.radius}


def is_look_pose(tool: ToolPose) -> bool:
    return tool.distance_to(look_pose(CFG, WS, tool)) < 1e-6


def on_the_way(blocks: set[int]):
    """The detector reports ``blocks`` covered in every frame taken at travel height."""
    return lambda tool: blocks if abs(tool.z - CFG.travel_height) < 1e-6 else set()


def hover(here: ToolPose, target: Pose2D) -> list[tuple[float, ToolPose]]:
    """The dry-run samples of heading from ``here`` to above a block at ``target``."""
    action = PickPlace(2, target, Pose2D(0.7, 0.0, 0.0), 0)
    return script_samples(hover_steps(action, target, GripperGeometry(), CFG), here,
                          CFG.in_safe_box, CFG.convergence_tol)


def test_the_frame_is_taken_where_the_silhouette_leaves_the_blocks_in_view():
    """From over a block at the far corner to over one at the near side (the forearm then
    lies over neither): a moment between leaves both in view."""
    here = ToolPose(0.92, -0.30, CFG.travel_height, 0.0)
    target = Pose2D(0.50, 0.30, 0.0)
    samples = hover(here, target)
    assert samples[-1][1].distance_to(ToolPose(0.50, 0.30, CFG.travel_height, 0.0)) < 0.01
    blocks = {1: Pose2D(here.x, here.y, 0.0), 2: target}
    at = best_moment(VIEW, samples, blocks, {1, 2}, set())
    assert at is not None and 0.0 < at < samples[-1][0]
    # the next block needs judging, the last one may wait: the earliest moment clearing it
    early = best_moment(VIEW, samples, blocks, {2}, {1})
    assert early is not None and early <= at


def test_no_moment_when_the_arm_over_one_block_always_covers_the_other():
    here = ToolPose(0.55, -0.20, CFG.travel_height, 0.0)
    close = {1: Pose2D(here.x, here.y, 0.0), 2: Pose2D(here.x + 0.054, here.y, 0.0)}
    assert best_moment(VIEW, hover(here, close[2]), close, {1, 2}, set()) is None
    # the forearm lies over a block between the base and the tool
    behind = {1: Pose2D(0.55, -0.20, 0.0), 2: Pose2D(0.85, 0.20, 0.0)}
    samples = hover(ToolPose(0.55, -0.20, CFG.travel_height, 0.0), behind[2])
    assert best_moment(VIEW, samples, behind, {1, 2}, set()) is None


def run_on_the_way(occludes=lambda tool: set(), disturb=None, view=None):
    core = ExecutorCore(CFG)
    core.view = view if view is not None else NearTool()
    world = World(core, START, occludes=occludes)
    if disturb is not None:
        world.disturb = disturb(world)
    world.on_replan = lambda: replan_from(world)
    core.on_plan(two_action_plan())
    world.run(lambda: core.state is State.DONE)
    return core, world


def replan_from(world: World) -> Plan:
    """The planner's answer: block 2's two actions from where it stands (block 1 placed)."""
    blocks = [BlockPose(i, p.x, p.y, p.theta) for i, p in sorted(world.blocks.items())]
    plan = two_action_plan("p2", blocks)
    return dataclasses.replace(plan, actions=plan.actions[1:])


def test_an_action_is_judged_from_a_frame_taken_while_the_arm_travels_on():
    core, world = run_on_the_way()
    assert world.blocks[1].distance_to(GOAL[1]) < 1e-9
    assert world.blocks[2].distance_to(GOAL[2]) < 1e-9
    # after action 1: a frame on the way to block 2, off the placed block, at travel height
    first = world.trigger_poses[1]  # (the first: the start, from the park pose)
    assert not is_look_pose(first) and abs(first.z - CFG.travel_height) < 1e-6
    assert math.hypot(first.x - GOAL[1].x, first.y - GOAL[1].y) > 0.07
    assert core.report.metrics["looks_on_the_way"] >= 1
    assert core.state is State.DONE and not core.belief.unverified


def test_a_block_to_judge_covered_in_that_frame_is_looked_at_from_the_look_pose():
    def occludes(tool: ToolPose) -> set[int]:
        return on_the_way({2})(tool)

    core, world = run_on_the_way(occludes)
    assert any(is_look_pose(t) for t in world.trigger_poses)
    assert core.report.metrics["looks_from_look_pose"] >= 1
    assert world.blocks[2].distance_to(GOAL[2]) < 1e-9


def test_a_block_knocked_while_the_arm_covers_it_is_caught_before_it_is_picked():
    """Block 2 is knocked 12 mm during action 1 and covered in the frame on the way: the look
    pose shows where it stands, and the pick goes down on it there."""
    knocked = Pose2D(START[1].x + 0.010, START[1].y - 0.007, START[1].theta)

    def disturb(world):
        def at(actions_done: int) -> None:
            if actions_done == 1:
                world.blocks[2] = knocked
        return at

    def occludes(tool: ToolPose) -> set[int]:
        return on_the_way({2})(tool)

    _, world = run_on_the_way(occludes, disturb)
    descents = [p for _, _, p in world.setpoints if p.z < 0.02]
    assert any(math.hypot(p.x - knocked.x, p.y - knocked.y) < 1e-6 for p in descents)
    assert world.blocks[2].distance_to(GOAL[2]) < 1e-9


def test_without_a_camera_model_the_arm_looks_from_the_look_pose():
    core = ExecutorCore(CFG)
    world = World(core, START)
    core.on_plan(two_action_plan())
    world.run(lambda: core.state is State.DONE)
    assert any(is_look_pose(t) for t in world.trigger_poses)
    assert core.report.metrics.get("looks_on_the_way", 0.0) == 0.0


def test_a_detection_seconds_after_its_trigger_is_counted_and_explained():
    """A slow link shows in the run's metrics and log: each detection 2 s or more after its
    trigger is counted, with the wait before the frame was taken and after it; one in time
    is not."""
    patient = dataclasses.replace(CFG, detection_timeout_s=6.0)  # the cell's (CFG's: 1 s)
    for delay in (0.3, 3.0):
        core = ExecutorCore(patient)
        world = World(core, START, camera_delay=delay)
        core.on_plan(two_action_plan())
        world.run(lambda c=core: c.state is State.DONE)
        late = [line for line in world.logs if "after the camera trigger" in line]
        counted = core.report.metrics.get("late_detections", 0)
        assert counted == (0 if delay < 1.0 else core.report.metrics["observations"])
        assert counted - 1 <= len(late) <= counted  # the last line would leave on a next tick
    assert late and "the frame taken 0.0 s after the trigger, its detection here 3.0 s" in late[0]


def test_the_way_through_a_waypoint_is_the_quickest_of_the_points_tried(monkeypatch):
    """The forearm covers the next block on the whole direct way (over block 1, heading for
    block 2 beyond it): the arm passes a point that shows both, the quickest way of the
    WAYPOINTS_TRIED points with the least detour (each rounded off as widely as still shows
    them), here quicker than through the first point; every point tried shows both."""
    here = ToolPose(0.55, -0.20, CFG.travel_height, 0.0)
    blocks = {1: Pose2D(0.55, -0.20, 0.0), 2: Pose2D(0.85, 0.20, 0.0)}
    steps = hover_steps(PickPlace(2, blocks[2], Pose2D(0.7, 0.0, 0.0), 0), blocks[2],
                        GripperGeometry(), CFG)
    then = script_samples(steps, here, CFG.in_safe_box, CFG.convergence_tol)[-1][1]
    area = (WS.x_min - CFG.look_offset, WS.x_max, WS.y_min, WS.y_max)
    points = look_waypoints(VIEW, here, then, blocks, {1, 2}, area, WAYPOINTS_TRIED)
    assert len(points) == WAYPOINTS_TRIED
    detours = [here.distance_to(w) + w.distance_to(then) for w in points]
    assert detours == sorted(detours)
    for w in points:
        assert not VIEW.covered(arm_postures([w])[0], blocks)
    belief = Belief(plan=two_action_plan(), expected=dict(blocks))
    _, at, samples = via_waypoint(VIEW, belief, CFG, here, then, {1, 2}, steps)
    assert best_moment(VIEW, samples, blocks, {1, 2}, set()) == at
    monkeypatch.setattr(observe, "WAYPOINTS_TRIED", 1)
    _, _, through_first = via_waypoint(VIEW, belief, CFG, here, then, {1, 2}, steps)
    assert samples[-1][0] < through_first[-1][0]  # here: 1.05 s against 1.10 s


def test_the_moment_picked_leaves_the_blocks_in_view_a_little_later_too():
    """The frame comes up to a sample after the measured tool passed the moment picked (a
    joint-state period and the trigger's way to the camera): the blocks to judge must stay
    in view for LATE_SAMPLES samples after it. Heading from over block 1 to over block 2,
    three samples between leave both in view: too short; four: the second of them."""
    for far_x, moment in ((0.80, None), (0.85, 0.15)):
        samples = [(0.05 * k, ToolPose(0.50 + 0.05 * k, 0.0, CFG.travel_height, 0.0))
                   for k in range(9)]
        blocks = {1: Pose2D(0.50, 0.0, 0.0), 2: Pose2D(far_x, 0.0, 0.0)}
        at = best_moment(NearTool(), samples, blocks, {1, 2}, set())
        assert at == (None if moment is None else pytest.approx(moment))
    assert LATE_SAMPLES == 2


#: Joints the arm had in a 25-block run after a far reach took it off the working branch
#: (the wrist turned over: wrist 2 at -pi/2 where the working branch has +pi/2).
OTHER_BRANCH = (2.595, -1.441, 2.21, 3.943, -1.571, -2.125)


def test_the_arm_is_predicted_on_the_branch_its_joints_are_on():
    """The arm node solves each setpoint nearest the joints before it, so an arm that left
    the working branch stays on the other one: its silhouette is predicted from its joints.
    A block the turned-over wrist covers (and the working branch does not), or the reverse,
    decides the moment only as the arm's own branch sees it."""
    tool = ToolPose(0.62, -0.20, CFG.travel_height, 0.0)
    working = arm_postures([tool])[0]
    other = arm_postures([tool], OTHER_BRANCH)[0]
    assert working[4] > 0.0 > other[4]
    samples = [(0.05 * k, tool) for k in range(5)]
    spots = [Pose2D(float(x), float(y), 0.0) for x in np.arange(0.30, 1.10, 0.02)
             for y in np.arange(-0.60, 0.60, 0.02)]
    differ = [p for p in spots
              if VIEW.covered(working, {1: p}) != VIEW.covered(other, {1: p})]
    assert differ  # the two postures cover different parts of the table
    for spot in differ[::max(len(differ) // 5, 1)]:
        covered_by_other = bool(VIEW.covered(other, {1: spot}))
        at = best_moment(VIEW, samples, {1: spot}, {1}, set(), OTHER_BRANCH)
        assert (at is None) == covered_by_other
        assert (best_moment(VIEW, samples, {1: spot}, {1}, set()) is None) != covered_by_other


def test_the_core_predicts_the_way_from_the_joints_the_arm_reports(monkeypatch):
    """The joints the driver reports reach the look on the way (none yet: the working
    branch)."""
    seen = []
    monkeypatch.setattr(observe, "look_on_the_way",
                        lambda *args: seen.append(args[-1]) or None)
    core = ExecutorCore(CFG)
    core._decide(LookOnTheWay())
    core.on_arm_joints(OTHER_BRANCH)
    core._decide(LookOnTheWay())
    assert seen == [None, OTHER_BRANCH]
