"""The executor's fault handling: grasp supervision, recoveries, and stopping safely.

Part of ``ExecutorCore`` (a mixin: the same state, the same ``TRANSITIONS``), kept apart so
the loop in core.py reads on its own. Every way the executor deals with what goes wrong is
here: a grasp fault stops the arm by braking along its path, lets go of what the fingers hold
and looks again; a block found in the fingers is set down at a free spot; a block outside the
workspace is brought back in; a stop sets down a held block before parking, so the arm never
parks with a block in its fingers.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from msgs_py import Plan, Pose2D, Workspace
from msgs_py.cell import table_margin_of
from msgs_py.placement import Placement
from msgs_py.status import SafetyMode
from nodes.executor.primitives import park_steps
from nodes.executor.recovery import (
    bring_in_steps,
    free_grasp,
    free_spot,
    let_go_steps,
    outside,
    overlapping_ids,
    set_down_steps,
)
from nodes.executor.states import After, Held, Purpose, State
from nodes.executor.steps import Grip, Move, Rise, Step, StepRunner
from nodes.executor.supervision import Expect, FaultKind, GraspFault

if TYPE_CHECKING:
    from nodes.executor.core import ExecutorCore

    _Base = ExecutorCore
else:
    _Base = object

#: A block brought back in is set down this far inside the workspace's edge (m): a camera
#: a centimetre off (before its check) then still sees it inside.
BRING_IN_INSET = 0.015
#: Tries to bring the same block in before giving up.
MAX_BRING_INS = 3
#: Tries to set overlapping blocks apart before giving up (each is a pick-and-place and a look).
MAX_SEPARATIONS = 3
#: Openings that may stall before an action finishes, each tried again after gripping the block
#: again where it stands; one more stops the run there.
MAX_RELEASE_STALLS = 2
#: With nothing held, a stalled opening is tried again after lifting the tool this far (m).
UNLOAD_LIFT_M = 0.003
#: Deceleration when a fault stops the arm mid-move (m/s^2).
BRAKE_DECEL = 5.0
#: A protective stop not unlocked this long after asking is asked again (s).
UNLOCK_RETRY_S = 1.0
#: A held block that stops the arm with the tool below grasp height + this many block sizes
#: stands on the table (on another block the tool would stand a whole block higher).
ON_THE_TABLE = 0.75


class FaultHandling(_Base):
    """Grasp supervision, recoveries and the safe stop of ``ExecutorCore``."""

    # --- grasp supervision ------------------------------------------------------------------------
    def _supervise(self, runner: StepRunner, gripper: float | None) -> GraspFault | None:
        """Tell the supervisor what the script did to the fingers, judge their reports. With
        no gripper status (a gripper that reports only its finger joints), a grip is taken to
        hold its block and a release to let go."""
        fault = None
        for reading in self._new_readings:  # taken before this tick's command
            if fault is None and (self.supervisor.expect is not Expect.NOTHING
                                  or self.supervisor.commanded is not None):
                fault = self.supervisor.on_reading(reading)
            else:
                self.supervisor.last = reading
        self._new_readings.clear()
        last = self.supervisor.last
        for step in runner.finished_steps:
            if not isinstance(step, Grip) or not step.wait:
                continue
            if step.holds is not None:
                fault = fault or (None if last is None else self.supervisor.after_grip(last))
                if fault is None:
                    self.supervisor.expect_hold(step.holds)
                    self.held = Held(step.holds, self._picked_from, step.squares)
            else:  # a release, or the fingers opened before a descent
                if last is not None and self.held is not None:
                    fault = fault or self.supervisor.after_release(last)
                if fault is None:
                    self.supervisor.expect_open()
                    self._released()
        if gripper is not None:
            self.supervisor.commanding(gripper, self._now)
        return fault

    def _released(self) -> None:
        """The fingers let go of a held block: it stands where the arm set it down (reported,
        so perception can be checked against the arm). Only a plan action's (or the camera
        check's) release is reported: a recovery picks blocks knocked, tilted or leaning on
        another, whose perceived pick pose says nothing about the camera."""
        held = self.held
        if (held is not None and held.block is not None and held.picked_from is not None
                and self.state is State.RUNNING):
            where = self.expected.get(held.block)
            tool = self.commanded or self.tcp
            if where is not None and tool is not None:
                self._out.placement = Placement(held.block, where, held.picked_from, tool.yaw,
                                                round(self._now * 1e9), held.squared)
        self.held = None

    def _on_grasp_fault(self, fault: GraspFault) -> None:
        """Stop the motion, let go of whatever the fingers hold, look again (a stray command
        that left a held block held is only undone)."""
        assert self.runner is not None
        self._count_fault(fault.kind)
        if fault.kind is FaultKind.MISFIRE and self.supervisor.commanded is not None:
            self._out.gripper = self.supervisor.commanded  # ours again, at once
            if self.supervisor.expect is Expect.HOLD and self.supervisor.holds_block():
                self.supervisor.reassert(self._now)
                self._log(f"{fault.describe()}: the block is still held; command restored")
                return
        self._log(f"{fault.describe()}: stopping, letting go, looking again")
        self.detail = fault.describe()
        block = self.held.block if self.held is not None else None
        if fault.kind in (FaultKind.MISSED, FaultKind.MISFIRE):
            self._grasp_tries += 1
        if block is not None:
            self.expected.pop(block, None)  # it is wherever it fell: the camera will tell
        elif self.plan is not None and self.index < len(self.plan.actions):
            moved = self.plan.actions[self.index].block
            if fault.holding_something or self._picked_from is None:
                self.expected.pop(moved, None)  # let go of where the fingers were: look
            else:
                self.expected[moved] = self._picked_from  # untouched: it should still be there
        self.held = None
        self.supervisor.stop_judging()
        self._enter(State.RECOVERING)
        self._look_after_recovery = Purpose.RECOVERY
        self.runner.brake(self._now - self._script_lag, BRAKE_DECEL,
                          let_go_steps(self.geo, self.cfg, "recover"))
        self._after = After.RECOVERED

    # --- protective stops ----------------------------------------------------------------------
    def on_safety_mode(self, mode: SafetyMode) -> None:
        """The arm's controller stopped the arm (it pressed on something harder than its
        limit: a block knocked into the path of a descending finger, say), or the stop ended.
        Handled by the next tick."""
        if mode.stopped and self._arm_stop is None:
            self._arm_stop = mode.reason or "protective stop"
            self._unlock_asked_at = None
            self.metrics["protective_stops"] = self.metrics.get("protective_stops", 0.0) + 1
        elif not mode.stopped and self._arm_stop is not None:
            self._stop_cleared, self._arm_stop = self._arm_stop, None

    def _handle_protective_stop(self) -> None:
        """While stopped: stream nothing (the arm refuses setpoints), ask for the unlock.
        Unlocked: drop the script and go on from where the arm stands, as after a descent
        stopped by something below: back up, look, and plan from what the camera sees."""
        if self._arm_stop is not None:
            asked = self._unlock_asked_at
            if asked is None or self._now - asked >= UNLOCK_RETRY_S:
                if asked is None:
                    self._log(f"protective stop: {self._arm_stop}; unlocking the arm")
                self._unlock_asked_at = self._now
                self._out.unlock_arm = True
            self.detail = f"protective stop: {self._arm_stop}"
            return
        why, self._stop_cleared = f"protective stop: {self._stop_cleared}", None
        self.commanded = self.tcp  # the arm stands here: the next script starts from it
        if self.runner is None:
            return  # nothing was moving (a hand pressed on the tool): carry on
        if self._held_block_on_the_table():
            self._let_go_on_the_table(why)
        elif self.state is State.STOPPING:
            self._start_runner(park_steps(self.cfg), After.STOPPED)
        elif self.state is State.RECOVERING and self._setting_apart is not None:
            self._on_blocked_set_apart(why)
        elif self.state is State.RUNNING:
            self._on_blocked_descent(why)
        else:
            self._log(f"{why}: backing up and looking again")
            self._observe(self._purpose if self.state is State.OBSERVING else Purpose.RECOVERY,
                          near=True)

    def _held_block_on_the_table(self) -> bool:
        """A held block stopped the arm this low: it stands on the table. (On another block
        the tool would stand a block higher: above grasp height + a block.)"""
        return (self.held is not None and self.tcp is not None
                and self.state in (State.RUNNING, State.RECOVERING)
                and self.tcp.z < self.cfg.grasp_height + ON_THE_TABLE * self.geo.block_size)

    def _let_go_on_the_table(self, why: str) -> None:
        """The held block met the table above its place height: it slid down in the fingers
        (a slip). Pressing on would push it up through the pads; another spot would be met
        the same way. It stands on the table here: let go, rise, look, go on from there."""
        assert self.held is not None
        block = self.held.block
        self._log(f"{why}: block {block} stands on the table (it slid down in the fingers); "
                  "letting go here and looking again")
        if block is not None:
            self.expected.pop(block, None)  # where it stands now: the camera will tell
        if self.state is State.RUNNING:
            self._look_after_recovery = Purpose.RECOVERY
        self._enter(State.RECOVERING)
        self._start_runner(let_go_steps(self.geo, self.cfg, "recover"), After.RECOVERED)

    def _count_fault(self, kind: FaultKind) -> None:
        """One more fault, in the total and in its kind's count (``faults_<kind>``)."""
        self.metrics["faults"] += 1
        key = f"faults_{kind.name.lower()}"
        self.metrics[key] = self.metrics.get(key, 0.0) + 1.0

    def _on_release_stall(self, why: str) -> bool:
        """The fingers stopped opening short of the opening, still pressing on the block they
        had just let go. Seen in the cell and reproduced in the scripted sim: the block turns
        a degree or two about one pad as the fingers part, and the simulated contact then
        presses that pad into it (43 N). Gripping it again where it stands squares it between
        the pads, and the next opening lets go cleanly (the same repro). Rising with a block
        the fingers will not let go would carry it off (at 4eb4bf7 it ended 0.28 m away):
        after MAX_RELEASE_STALLS the tool stays and the run stops there, the block named.
        False while stopping (the stop's own error stands)."""
        runner = self.runner
        if self.state not in (State.RUNNING, State.RECOVERING) or runner is None:
            return False
        self._count_fault(FaultKind.NOT_RELEASED)
        if self._release_stalls == 0:
            self._stall_z = runner.commanded.z
        self._release_stalls += 1
        if self._release_stalls > MAX_RELEASE_STALLS:
            self._stop_with_fingers_stuck(why)
            return True
        held = self.held.block if self.held is not None else None
        if held is None:  # nothing to grip: lift off whatever presses and open again
            self._log(f"{why}: lifting {UNLOAD_LIFT_M * 1e3:.0f} mm and opening again")
            up = runner.commanded.with_z(runner.commanded.z + UNLOAD_LIFT_M)
            runner.retry_current([Move(up, self.cfg.approach_limits, "unload the fingers")])
            return True
        self._log(f"{why}: gripping block {held} again where it stands and opening again")
        self.supervisor.stop_judging()
        runner.retry_current([Grip(self.cfg.grip_command, self.cfg.gripper_settle_s,
                                   f"block {held}: grip again", holds=held)])
        return True

    def _stop_with_fingers_stuck(self, why: str) -> None:
        """Fingers that will not open: set what they hold back where they stalled and stop
        there (parking would carry it off)."""
        runner = self.runner
        assert runner is not None
        block = self.held.block if self.held is not None else None
        what = "the fingers" if block is None else f"block {block} in the fingers"
        tool = runner.commanded
        self.last_error = (f"{why}; the fingers do not open: stopped with {what} at "
                           f"({tool.x:.3f}, {tool.y:.3f})")
        self.detail = self.last_error
        self._log(f"stopping: {self.last_error}")
        self._enter(State.STOPPING)
        self.supervisor.stop_judging()
        self._stopped_in_place = True
        down = tool.with_z(self._stall_z)
        self._start_runner([Move(down, self.cfg.approach_limits, "stop: set it back down")],
                           After.STOPPED)

    # --- recovery -------------------------------------------------------------------------------
    def _recover_held_block(self) -> None:
        """The fingers hold a block (found at start-up, say): find which, set it down."""
        plan = self.plan
        assert plan is not None and self.held is not None
        block = self.held.block
        if block is None:
            known = ({b.id for b in plan.scene.blocks} if plan.scene else set()) | set(
                self.expected)
            unseen = sorted(known - set(self.perceived))
            if len(unseen) != 1:
                self._log(f"the fingers hold something, but {len(unseen)} blocks are unseen; "
                          "letting go here, out of the workspace, and looking again")
                self.held = None
                self._look_after_recovery = self._purpose
                self._enter(State.RECOVERING)
                self._start_runner(let_go_steps(self.geo, self.cfg, "recover"), After.RECOVERED)
                return
            block = unseen[0]
        near = self.held.picked_from or (plan.scene.blocks and next(
            (b.pose for b in plan.scene.blocks if b.id == block), None))
        tool = self.commanded or self.tcp
        assert tool is not None
        target = near or Pose2D(tool.x, tool.y, 0.0)
        workspace = plan.scene.workspace if plan.scene else None
        spot = None if workspace is None else free_spot(
            self.perceived, workspace, self.geo, tool.yaw, (target.x, target.y),
            table_margin_of(plan.params))
        if spot is None:
            self._fail(f"holding block {block} and no free spot to set it down")
            return
        self._set_down(block, spot)

    def _set_down(self, block: int, where: Pose2D) -> None:
        self.detail = f"setting block {block} down at ({where.x:.3f}, {where.y:.3f})"
        self._log(self.detail)
        self.held = Held(block)
        self.expected[block] = where
        yaw = (self.commanded or self.tcp).yaw
        self._look_after_recovery = self._purpose  # then judge what was being judged
        self._enter(State.RECOVERING)
        self._start_runner(set_down_steps(block, where, yaw, self.geo, self.cfg), After.RECOVERED)

    def _separate_overlapping_blocks(self, plan: Plan) -> bool:
        """Two perceived blocks overlap (one knocked against or onto another, leaning on it):
        no plan starts from that, so one of them is picked up and set down at the nearest free
        spot: the one that moved furthest from where it was expected first (the knocked one,
        which lies on the other if either does). False when no two blocks overlap."""
        assert plan.scene is not None
        pairs = overlapping_ids(self.perceived, self.geo.block_size)
        if not pairs:
            self._separations = 0
            self._apart_blocked = set()
            return False
        if self._separations >= MAX_SEPARATIONS:
            self._fail(f"blocks {list(pairs[0])} still overlap after {self._separations} tries "
                       "to set one of them apart")
            return True
        a, b = max(pairs, key=lambda pair: max(self._moved(pair[0]), self._moved(pair[1])))
        first, second = (a, b) if self._moved(a) >= self._moved(b) else (b, a)
        if first in self._apart_blocked and second not in self._apart_blocked:
            first, second = second, first  # the tool stopped on the other: it is on top
        for block, partner in ((first, second), (second, first)):  # the other if no grasp
            rest = {k: p for k, p in self.perceived.items() if k != partner}
            grasp = free_grasp(rest, block, self.geo, self._table(plan))
            if grasp is not None:
                break
        at = self.perceived[block]
        spot = free_spot({k: p for k, p in self.perceived.items() if k != block},
                         plan.scene.workspace, self.geo, at.theta, (at.x, at.y),
                         table_margin_of(plan.params))
        if grasp is None or spot is None:
            self._fail(f"blocks {block} and {partner} overlap and neither can be " + (
                "grasped" if grasp is None else "set down anywhere free"))
            return True
        self._separations += 1
        self._setting_apart = block
        self._move_aside(block, spot, grasp, rest, self._table(plan),
                         f"blocks {block} and {partner} overlap: setting block {block} apart")
        return True

    def _moved(self, block: int) -> float:
        """How far (m) ``block`` is seen from where it was expected (inf: not expected
        anywhere, as a block let go of after a grasp fault)."""
        was = self.expected.get(block)
        return math.inf if was is None else self.perceived[block].distance_to(was)

    def _bring_in_outside_block(self, plan: Plan) -> bool:
        """A perceived block outside the workspace (dropped, knocked): pick it up and set it
        down at the nearest free spot inside. False when every block is inside."""
        assert plan.scene is not None
        away = outside(self.perceived, plan.scene.workspace, self.geo.block_size)
        if not away:
            self._bring_ins = 0
            return False
        block = away[0]
        self._bring_ins = self._bring_ins + 1 if self._bring_ins_of == block else 1
        self._bring_ins_of = block
        at = self.perceived[block]
        if self._bring_ins > MAX_BRING_INS:
            self._fail(f"block {block} is still seen outside the workspace at ({at.x:.3f}, "
                       f"{at.y:.3f}) after {MAX_BRING_INS} tries to bring it in")
            return True
        margin = table_margin_of(plan.params)
        table = plan.scene.workspace
        reach = table.grown(3 * margin)
        grasp = free_grasp(self.perceived, block, self.geo, reach)
        spot = free_spot({b: p for b, p in self.perceived.items() if b != block},
                         table.grown(-BRING_IN_INSET), self.geo, at.theta, (at.x, at.y),
                         margin + BRING_IN_INSET)
        if grasp is None or spot is None:
            self._fail(f"block {block} lies outside the workspace at ({at.x:.3f}, {at.y:.3f})"
                       " and cannot be " + ("grasped there" if grasp is None else
                                             "set down anywhere free inside"))
            return True
        self._move_aside(block, spot, grasp, self.perceived, reach,
                         f"bringing block {block} back into the workspace")
        return True

    def _move_aside(self, block: int, spot: Pose2D, grasp: int, around: dict[int, Pose2D],
                    table: Workspace, why: str) -> None:
        """Recover by picking ``block`` where it is seen and setting it down at ``spot``, the
        fingers wide open where they clear ``around`` on ``table``; then look again."""
        at = self.perceived[block]
        self.detail = f"{why}, from ({at.x:.3f}, {at.y:.3f}) to ({spot.x:.3f}, {spot.y:.3f})"
        self._log(self.detail)
        self._picked_from = at
        self.expected[block] = spot
        self._look_after_recovery = self._purpose
        self._enter(State.RECOVERING)
        opening = self._wide_opening(dict(around), block, grasp, table)
        self._start_runner(bring_in_steps(block, at, spot, grasp, self.geo, self.cfg, opening,
                                          self._turn_period), After.RECOVERED)

    # --- stopping -------------------------------------------------------------------------------
    def _stop_safely(self, reason: str, failed: bool) -> None:
        """Stop, set down whatever the fingers hold (where it was picked up, or the nearest free
        spot), then park: the arm never parks with a block in its fingers."""
        if failed:
            self.last_error = reason
        self.detail = reason
        self._log(f"stopping: {reason}")
        self._enter(State.STOPPING)
        held = self.held
        self.runner = None
        self.supervisor.stop_judging()
        if held is not None and held.block is not None and self.plan is not None \
                and self.plan.scene is not None:
            where = held.picked_from or self._spot_near_tool()
            if where is not None:
                self._set_down_then_park(held.block, where)
                return
        steps: list[Step] = [Rise(self.cfg.travel_height, self.cfg.vertical_limits, "stop: lift"),
                             *park_steps(self.cfg)[1:]]
        if held is not None:  # an unknown thing in the fingers: let go before parking
            steps = [*let_go_steps(self.geo, self.cfg, "stop"), *park_steps(self.cfg)[1:]]
        self._start_runner(steps, After.STOPPED)

    def _spot_near_tool(self) -> Pose2D | None:
        assert self.plan is not None and self.plan.scene is not None
        tool = self.commanded or self.tcp
        assert tool is not None
        return free_spot(self.perceived, self.plan.scene.workspace, self.geo, tool.yaw,
                         (tool.x, tool.y), table_margin_of(self.plan.params))

    def _set_down_then_park(self, block: int, where: Pose2D) -> None:
        self.detail = f"{self.detail}; setting block {block} down at ({where.x:.3f}, " \
                      f"{where.y:.3f}) first"
        self.expected[block] = where
        yaw = (self.commanded or self.tcp).yaw
        steps = [*set_down_steps(block, where, yaw, self.geo, self.cfg),
                 *park_steps(self.cfg)[1:]]
        self._start_runner(steps, After.STOPPED)
