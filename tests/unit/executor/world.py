"""The scripted world the executor's behaviour tests run in: a perfectly tracking arm, a
camera that sees what is there (less what the arm hides), a planner answering a second late,
and a 2F-85-like gripper that reports like its driver (one whose release sticks, too)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

from msgs_py import BlockPose, BlockSet, Goal, GoalSlot, PickPlace, Plan, Pose2D, Push, Scene
from msgs_py.scene import Workspace
from msgs_py.status import GripperStatus
from nodes.executor.config import ExecutorConfig
from nodes.executor.core import ExecutorCore
from nodes.executor.motion import ToolPose

WS = Workspace(0.45, 0.95, -0.35, 0.35)
CFG = ExecutorConfig(gripper_settle_s=0.2, detection_timeout_s=1.0, replan_timeout_s=5.0,
                     camera_check=False)
CHECKING = dataclasses.replace(CFG, camera_check=True)
DT = 0.02


def scene(blocks, goal_poses):
    return Scene(WS, 0.0508, tuple(blocks),
                 Goal(slots=tuple(GoalSlot(p.x, p.y, p.theta, i) for i, p in goal_poses.items())))


START = [BlockPose(1, 0.55, -0.2, 0.3), BlockPose(2, 0.80, 0.2, 0.0)]
GOAL = {1: Pose2D(0.70, 0.0, 0.0), 2: Pose2D(0.7538, 0.0, 0.0)}


def two_action_plan(plan_id="p1", blocks=START):
    by_id = {b.id: b.pose for b in blocks}
    push_from = Pose2D(0.8538, 0.0, 0.0)
    return Plan(
        (PickPlace(1, by_id[1], GOAL[1], 0),
         PickPlace(2, by_id[2], push_from, 1),
         Push(2, push_from, GOAL[2], (-1.0, 0.0), 0.1)),
        plan_id=plan_id, scene=scene(blocks, GOAL),
        params={"block_size": 0.0508, "approach_clearance": 0.008},
    )


class World:
    """Perfect arm tracking; the camera sees what the executor expects, plus any disturbance."""

    def __init__(self, core: ExecutorCore, blocks, camera_delay=0.3, camera_works=True,
                 answers_trigger=False, hides: Callable[[ToolPose], set[int]] | None = None,
                 occludes: Callable[[ToolPose], set[int]] | None = None):
        self.core = core
        self.answers_trigger = answers_trigger  # the camera's answer: "frame taken at ..."
        self.hides = hides or (lambda tool: set())  # blocks the arm hides from the camera
        #: blocks the detector reports the robot covering (occluded) with the tool here
        self.occludes = occludes or (lambda tool: set())
        self.trigger_poses: list[ToolPose] = []
        self.setpoints: list[tuple[float, str, ToolPose]] = []
        self.gripper: Gripper | None = None
        self.blocks = {b.id: b.pose for b in blocks}
        self.camera_delay = camera_delay
        self.camera_works = camera_works
        self.pending: list[tuple[float, int]] = []
        self.frames_asked: list[float] = []  # moments (s) the camera is to take a frame of
        self.replan_requests = 0
        self.on_replan: Callable[[], Plan | None] = lambda: None
        self.disturb: Callable[[int], None] = lambda actions_done: None
        self.states: list[str] = []
        self.progress: list[tuple[str, int, int]] = []  # (state, action k, of n) as published
        #: (state, the block the status names) at each setpoint, in order, without repeats
        self.named: list[tuple[str, int | None]] = []
        self.gripper_commands: list[tuple[str, float]] = []  # (executor detail, opening)
        self.logs: list[str] = []
        self.placements = []  # what the executor reports it set down
        self.floor: Callable[[ToolPose], float] = lambda tool: 0.0  # the TCP stops on it
        self.max_speed = 0.0
        core.on_tcp(ToolPose(0.3, -0.55, 0.45, 0.0))

    def _held_block(self) -> int | None:
        held = self.core.belief.held
        return None if held is None else held.block

    def run(self, until: Callable[[], bool], max_t: float = 600.0) -> None:
        """Run until ``until()``, for at most ``max_t`` more seconds (time goes on from the
        previous run)."""
        t = self.t_end + DT if hasattr(self, "t_end") else 0.0
        max_t += t
        last = None
        done_before = 0
        plans: list[tuple[float, Plan | None]] = []
        held = self._held_block()
        while t < max_t and not until():
            out = self.core.tick(t)
            self.logs += out.log
            if out.placement is not None:
                self.placements.append(out.placement)
            if out.setpoint is not None:
                status = self.core.status()
                self.setpoints.append((t, status.state, out.setpoint))
                if not self.named or self.named[-1] != (status.state, status.block):
                    self.named.append((status.state, status.block))
                if last is not None:
                    self.max_speed = max(self.max_speed, out.setpoint.distance_to(last) / DT)
                last = out.setpoint
                floor = self.floor(out.setpoint)
                self.core.on_tcp(out.setpoint if out.setpoint.z >= floor
                                 else out.setpoint.with_z(floor))
            holding = self._held_block()
            if held is not None and holding is None and self.gripper is None:  # set down
                self.blocks[held] = self.core.belief.expected[held]
            held = holding
            if out.gripper is not None:
                self.gripper_commands.append((self.core.report.detail, out.gripper))
            if self.gripper is not None:
                self.gripper.tick(t, out.gripper)
            done = int(self.core.report.metrics["actions_executed"])
            if done > done_before:
                action = self.core.plan.actions[self.core.belief.index - 1]
                if self.gripper is None or isinstance(action, Push):  # where it was sent
                    self.blocks[action.block] = self.core.belief.expected[action.block]
                done_before = done
                self.disturb(done)
            if out.trigger_camera and self.camera_works:
                self.frames_asked.append(t)
            for at in [a for a in self.frames_asked if a <= t + 1e-9]:
                self.frames_asked.remove(at)
                tool = self.core.player.commanded
                self.trigger_poses.append(tool)
                hidden = frozenset(self.hides(tool))
                covered = frozenset(self.occludes(tool)) - hidden
                self.pending.append((t + self.camera_delay, round(t * 1e9), hidden, covered))
                if self.answers_trigger:
                    self.core.on_frame_taken(round(t * 1e9))
            for frame in list(self.pending):
                due, stamp, hidden, covered = frame
                if t >= due:
                    self.pending.remove(frame)
                    blocks = tuple(BlockPose(i, p.x, p.y, p.theta) for i, p in self.blocks.items()
                                   if i not in hidden | covered)
                    self.core.on_detection(BlockSet(blocks, stamp, missing=tuple(sorted(hidden)),
                                                    occluded=tuple(sorted(covered))))
            if out.request_replan:  # the planner answers a second later
                self.replan_requests += 1
                plans.append((t + 1.0, self.on_replan()))
            for due, plan in list(plans):
                if t >= due:
                    plans.remove((due, plan))
                    if plan is not None:
                        self.core.on_plan(plan)
            status = self.core.status()
            state = status.state
            if not self.states or self.states[-1] != state:
                self.states.append(state)
            progress = (state, status.action_index, status.action_total)
            if not self.progress or self.progress[-1] != progress:
                self.progress.append(progress)
            t += DT
        self.t_end = t - DT
        assert until(), f"timed out in {self.core.state}: {self.logs[-5:]}"
        state = self.core.status().state
        if self.states[-1] != state:
            self.states.append(state)


class Gripper:
    """A 2F-85 in the scripted world: it closes on a block under the fingers at grasp height,
    carries it with the tool and sets it down where it opens; it reports like the driver."""

    def __init__(self, world: World) -> None:
        self.world = world
        self.requested = 0.085
        self.gap = 0.085
        self.holding: int | None = None
        world.gripper = self

    def command(self, gap: float) -> None:
        self.requested = gap

    def tick(self, t: float, command: float | None) -> None:
        if command is not None:
            self.command(command)
        tool = self.world.core.player.commanded or self.world.core.inbox.tcp
        if self.requested < self.gap - 1e-9 and self.holding is None:  # closing
            under = [b for b, p in self.world.blocks.items()
                     if math.hypot(p.x - tool.x, p.y - tool.y) < 0.004 and tool.z < 0.03
                     and self.requested < 0.0508]  # narrower than a block: on it
            self.holding = under[0] if under else None
            self.gap = 0.0508 if self.holding is not None else self.requested
            if self.holding is not None:  # the block turns with the tool from here
                self.grip = (tool.yaw, self.world.blocks[self.holding].theta)
        elif self.requested > self.gap + 1e-9:  # opening: let go where the tool is
            if self.holding is not None:
                p = self.world.blocks[self.holding]
                self.world.blocks[self.holding] = Pose2D(tool.x, tool.y, p.theta)
            self.holding = None
            self.gap = self.requested
        if self.holding is not None:  # carried along, turning with the tool
            tool_yaw0, theta0 = self.grip
            self.world.blocks[self.holding] = Pose2D(tool.x, tool.y,
                                                     theta0 + tool.yaw - tool_yaw0)
        status = "stopped_closing" if self.holding is not None else "at_position"
        self.world.core.on_gripper(GripperStatus(self.gap, self.requested, status,
                                                 round(t * 1e9)))

    def drop(self) -> None:
        """The held block slips out of the fingers: they close on nothing."""
        self.holding = None
        self.gap = self.requested


class StallingGripper(Gripper):
    """Its first release sticks: the fingers stay on the block, pressing (seen in the cell),
    until it is gripped again (``freed_by_grip``; else never)."""

    def __init__(self, world: World, freed_by_grip: bool) -> None:
        super().__init__(world)
        self.freed_by_grip = freed_by_grip
        self.stuck = False
        self.stuck_once = False
        self.stuck_z: float | None = None

    def tick(self, t: float, command: float | None) -> None:
        if command is not None:
            self.requested = command
        tool = self.world.core.player.commanded or self.world.core.inbox.tcp
        if (not self.stuck_once and self.holding is not None
                and self.requested > self.gap + 1e-9):
            self.stuck_once, self.stuck, self.stuck_z = True, True, tool.z
        if self.stuck and self.requested < self.gap and self.freed_by_grip:
            self.stuck = False  # gripped again: squared between the pads, held as before
        if self.stuck:
            tool_yaw0, theta0 = self.grip  # still in the fingers, going where they go
            self.world.blocks[self.holding] = Pose2D(tool.x, tool.y,
                                                     theta0 + tool.yaw - tool_yaw0)
            status = "stopped_closing" if self.requested < self.gap else "stopped_opening"
            self.world.core.on_gripper(GripperStatus(self.gap, self.requested, status,
                                                     round(t * 1e9)))
            return
        super().tick(t, None)


def supervised_run_at(step_suffix: str, holding: bool = False) -> tuple[ExecutorCore, World]:
    """The two-action plan under way with a reporting gripper, stopped at the first tick of
    the step whose label ends with ``step_suffix`` (with a block in the fingers if
    ``holding``)."""
    core = ExecutorCore(CFG)
    world = World(core, START)
    Gripper(world)
    core.on_plan(two_action_plan())
    world.run(lambda: step_is(core, step_suffix)
              and (core.belief.held is not None or not holding))
    return core, world


def step_is(core: ExecutorCore, suffix: str) -> bool:
    """The step the arm plays now is the one labelled ``...suffix``."""
    step = core.player.step
    return step is not None and step.label.endswith(suffix)


def xyt(p: Pose2D) -> tuple[float, float, float]:
    return p.x, p.y, p.theta
