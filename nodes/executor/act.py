"""Acting: the plan's next action as a script from the perceived poses, and what follows it.

An action starts from where the camera last saw its block (the grasp centred on it, a push
lengthened or shortened to end where planned); after it the arm looks on its way to the next
block (``look_while_moving``) or from the look pose beside the workspace, and after the last
one from the park pose.
"""

from __future__ import annotations

from msgs_py import PickPlace, Pose2D
from msgs_py.actions import Action
from msgs_py.status import ExecutorState as State
from nodes.executor.belief import Belief
from nodes.executor.camera_check import PROBE_GRASPS, probe_steps
from nodes.executor.config import ExecutorConfig
from nodes.executor.decisions import (
    ActionDone,
    Decision,
    Enter,
    LookHere,
    LookOnTheWay,
    NextAction,
    Observe,
    Replan,
    Script,
    Stop,
)
from nodes.executor.motion import ToolPose
from nodes.executor.primitives import action_steps, expected_after, look_steps
from nodes.executor.recovery import tight_opening, wide_opening
from nodes.executor.report import Report
from nodes.executor.states import Purpose, Tries
from nodes.executor.visibility import footprint, neighbours


def next_action(belief: Belief, cfg: ExecutorConfig, report: Report) -> Decision:
    """Run the current action on its block where it is expected (the camera check's re-grips
    in place, or the plan's), then look from the look pose unless it is the last."""
    plan, action = belief.plan, belief.current
    assert plan is not None and action is not None
    start = belief.expected.get(action.block)
    if start is None:  # (let go of after a fault, under the arm in the last frame): plan anew
        return Replan(f"action {belief.index + 1} moves block {action.block}, which is not "
                      "seen where the plan has it")
    if belief.checking_camera:
        report.say(f"camera check: block {action.block} gripped in place along both of its axes")
    else:
        report.say(f"action {belief.index - belief.probes + 1}/"
                   f"{len(plan.actions) - belief.probes}: {action.type} block {action.block}")
    opening = pick_opening(belief, cfg, action, start)
    if belief.checking_camera:
        steps = probe_steps(action.block, start, belief.geo, cfg,
                            opening if opening is not None else belief.geo.approach_opening)
    else:
        steps = action_steps(action, start, belief.geo, cfg, opening, belief.turn_period)
    belief.picked_from, belief.handling = start, None  # a recovery's block is named no more
    belief.moved_aside.discard(action.block)  # the plan takes it from where it stands now
    belief.expected[action.block] = end = expected_after(action, start, belief.geo)
    if looks_after(belief, cfg) and plan.scene is not None:
        steps += look_steps(cfg, plan.scene.workspace,
                            ToolPose(end.x, end.y, cfg.travel_height, 0.0))
    return Enter(State.RUNNING, Script(steps, ActionDone()))


def pick_opening(belief: Belief, cfg: ExecutorConfig, action: Action, start: Pose2D
                 ) -> float | None:
    """The fingers open wider than the plan asks (``pick_clearance``) to go down around a
    block whose neighbours leave room: a perception a centimetre off still grips it; and
    less (``release_clearance``) where the plan's opening would bring a finger within a
    millimetre of a neighbour. None: the plan's opening."""
    if not isinstance(action, PickPlace) or belief.scene is None:
        return None
    around, table = {**belief.expected, action.block: start}, belief.table()
    wide = wide_opening(around, action.block, action.grasp, table, belief.geo,
                        cfg.pick_clearance)
    if wide is not None:
        return wide
    return tight_opening(around, action.block, action.grasp, table, belief.geo,
                         cfg.release_clearance)


def looks_after(belief: Belief, cfg: ExecutorConfig) -> bool:
    """Whether the current action's script ends at the look pose, for the camera to look from
    there (without looking on the way; the last action is looked at from the park pose)."""
    assert belief.plan is not None
    return (cfg.observe_every_action and not cfg.look_while_moving
            and belief.index + 1 < len(belief.plan.actions))


def action_done(belief: Belief, cfg: ExecutorConfig, report: Report, tries: Tries,
                stop_requested: bool) -> Decision:
    """Count the action, go on to the next: look first (from where the script ended, at the
    look pose, or from the park pose after the last), or stop if asked to."""
    plan = belief.plan
    assert plan is not None
    if belief.checking_camera:
        report.count("camera_check_regrips", len(PROBE_GRASPS))
    else:
        report.count("actions_executed")
        report.count(f"{plan.actions[belief.index].type}_executed")  # pick_place_executed, ...
    tries.grasps = 0
    tries.release_stalls = 0
    belief.held = None
    done = plan.actions[belief.index]
    if belief.picked_from is not None:
        ended = belief.expected.get(done.block, done.to)
        belief.unverified |= neighbours(belief.expected, footprint(belief.picked_from, done),
                                        cfg.judge_radius) | {done.block}
        belief.unverified |= neighbours(belief.expected, [(ended.x, ended.y)], cfg.judge_radius)
    looked_from_here = looks_after(belief, cfg) and plan.scene is not None
    belief.index += 1
    if stop_requested:
        return Stop("stop requested", failed=False)
    if looked_from_here:  # the script ended at the look pose
        return LookHere(Purpose.AFTER_ACTION)
    if belief.index >= len(plan.actions):
        return Observe(Purpose.GOAL)
    if cfg.observe_every_action:
        return LookOnTheWay() if cfg.look_while_moving else Observe(Purpose.AFTER_ACTION,
                                                                      near=True)
    return NextAction()
