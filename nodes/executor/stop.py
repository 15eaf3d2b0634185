"""Stopping safely: the arm never parks with a block in its fingers.

A stop (asked for, or after an error) sets down a held block where it was picked up, or at
the nearest free spot, then parks (the gripper's word on a hold counts where the belief has
not recorded it yet: a stop while the grip closes); fingers that do not open set the block
back where they stalled and stop there instead (parking would carry it off). Once parked the
executor is ``stopped`` (a start resumes) or ``failed`` (the last error says why).
"""

from __future__ import annotations

from msgs_py import Pose2D
from msgs_py.cell import table_margin_of
from msgs_py.status import ExecutorState as State
from nodes.executor.belief import Belief
from nodes.executor.config import ExecutorConfig
from nodes.executor.decisions import Enter, Halt, Script, Stop, Stopped
from nodes.executor.inputs import Inbox
from nodes.executor.motion import ToolPose
from nodes.executor.primitives import park_steps
from nodes.executor.recovery import free_spot, holds_block, let_go_steps, set_down_steps
from nodes.executor.report import Report
from nodes.executor.states import Held
from nodes.executor.steps import Move, Rise, Step
from nodes.executor.supervision import GraspSupervisor


def stop_safely(d: Stop, belief: Belief, supervisor: GraspSupervisor, cfg: ExecutorConfig,
                report: Report, tool: ToolPose | None, inbox: Inbox | None = None) -> Enter:
    """Stop, set down whatever the fingers hold (where it was picked up, or the nearest free
    spot to the ``tool``), then park. What the fingers hold is the belief's, or the
    gripper's newest word in the ``inbox`` (a stop while a grip closes, before the belief
    records the hold)."""
    if d.failed:
        report.last_error = d.reason
    report.detail = d.reason
    report.log(f"stopping: {d.reason}")
    supervisor.stop_judging()
    if belief.held is None and inbox is not None and closed_on_something(
            supervisor, inbox, belief.geo.block_size):
        belief.held = _unrecorded_hold(belief, report)
    held = belief.held
    if held is not None and held.block is not None and belief.scene is not None:
        assert tool is not None
        where = held.picked_from or _spot_near(belief, tool)
        if where is not None:
            report.detail = (f"{report.detail}; setting block {held.block} down at "
                             f"({where.x:.3f}, {where.y:.3f}) first")
            belief.expected[held.block] = where
            steps = [*set_down_steps(held.block, where, tool.yaw, belief.geo, cfg),
                     *park_steps(cfg)[1:]]
            return Enter(State.STOPPING, Script(steps, Stopped()))
    steps: list[Step] = [Rise(cfg.travel_height, cfg.vertical_limits, "stop: lift"),
                         *park_steps(cfg)[1:]]
    if held is not None:  # an unknown thing in the fingers: let go before parking
        steps = [*let_go_steps(belief.geo, cfg, "stop"), *park_steps(cfg)[1:]]
    return Enter(State.STOPPING, Script(steps, Stopped()))


def closed_on_something(supervisor: GraspSupervisor, inbox: Inbox, block_size: float) -> bool:
    """The executor's last gripper command closed the fingers and the newest report (one
    not yet ticked in, too: a stop comes between ticks) says they hold something; a report
    of a hold just released does not count, its command opened."""
    commanded = supervisor.commanded
    if commanded is None or commanded >= block_size:
        return False
    newest = inbox.readings[-1] if inbox.readings else supervisor.last
    if newest is not None:
        return supervisor.holds_something(newest)
    return holds_block(inbox.finger_gap, block_size)


def _unrecorded_hold(belief: Belief, report: Report) -> Held:
    """The fingers hold something the belief has not recorded: the block the script was
    picking up (a recovery's, else the current action's), picked from where it stood."""
    action = belief.current
    block = belief.handling if belief.handling is not None else (
        action.block if action is not None else None)
    if belief.picked_from is None:
        block = None
    report.log("the fingers hold something the executor had not recorded"
               + (f": block {block}, the one it was picking up" if block is not None else ""))
    return Held(block, belief.picked_from if block is not None else None)


def _spot_near(belief: Belief, tool: ToolPose) -> Pose2D | None:
    assert belief.plan is not None and belief.plan.scene is not None
    return free_spot(belief.perceived, belief.plan.scene.workspace, belief.geo, tool.yaw,
                     (tool.x, tool.y), table_margin_of(belief.plan.params))


def stop_in_place(why: str, belief: Belief, tool: ToolPose, stall_z: float,
                  supervisor: GraspSupervisor, cfg: ExecutorConfig, report: Report) -> Enter:
    """Fingers that will not open: set what they hold back down where they stalled (the
    ``tool`` at ``stall_z``) and stop there."""
    block = belief.held.block if belief.held is not None else None
    what = "the fingers" if block is None else f"block {block} in the fingers"
    report.last_error = (f"{why}; the fingers do not open: stopped with {what} at "
                         f"({tool.x:.3f}, {tool.y:.3f})")
    report.detail = report.last_error
    report.log(f"stopping: {report.last_error}")
    supervisor.stop_judging()
    down = tool.with_z(stall_z)
    return Enter(State.STOPPING, Script([Move(down, cfg.approach_limits, "stop: set it back down")],
                                        Stopped(in_place=True)))


def failed_while_stopping(why: str, report: Report) -> Halt:
    """The stop's own script failed: stream nothing more, the first error first."""
    report.last_error = f"{report.last_error}; then {why}"
    return Halt(State.FAILED)


def stopped(then: Stopped, belief: Belief, report: Report) -> Enter:
    """The stop's script ran: parked (or stopped over the block the fingers hold)."""
    belief.held = belief.handling = None
    state = State.FAILED if report.last_error else State.STOPPED
    where = "stopped over the block it holds" if then.in_place else "parked"
    report.log(f"arm {where}: {state.value}")
    return Enter(state)
