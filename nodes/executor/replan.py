"""Plans: taking one, running it only if it starts from the perceived world, asking for a new
one when the world drifted, and ending the run when no correction is possible but every
block is within the acceptance tolerance of its goal.

A plan that comes while the arm is busy waits until the arm is done; one the executor found
not to fit is never taken again. Before the first action of the executor's first run, the
camera check's re-grips go in front of the plan (``nodes.executor.camera_check``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from msgs_py import Plan
from msgs_py.status import ExecutorState as State
from nodes.executor.belief import Belief
from nodes.executor.camera_check import probe_actions, probe_block
from nodes.executor.config import ExecutorConfig
from nodes.executor.decisions import (
    Decision,
    Enter,
    Finish,
    NextAction,
    Observe,
    Replan,
    StartPlan,
    Stop,
    VerifyGoal,
)
from nodes.executor.report import Report
from nodes.executor.states import Purpose, Tries
from nodes.executor.verify import deviations


@dataclass
class PlannerLink:
    """What the executor and the planner have between them: the replans asked for, when
    the last was, plans refused, a plan waiting for the arm, and whether the planner waits
    for a detection."""

    replans: int = 0
    asked_at: float | None = None
    rejected: set[str] = field(default_factory=set)
    pending: Plan | None = None  #: came while the arm was busy: taken once it is done
    wants_frame: bool = False  #: the planner waits for a detection (to plan from)
    #: why the planner last said it waits (a block hidden or gone, say): a run that gives up
    #: names it, not only the drift it asked a correction for
    waiting_why: str = ""
    want_replan: bool = False  #: for the next tick's outputs
    #: a look was made because the planner waited for a frame: the replan that follows it is
    #: the same correction asked again (``frame_looks`` such since the last counted replan)
    shown_frame: bool = False
    frame_looks: int = 0

    def hear(self, wants_frame: bool, why: str) -> None:
        """The planner's word on its status: whether it waits for a frame, and why."""
        self.wants_frame = wants_frame
        if wants_frame:
            self.waiting_why = why

    def ask(self, now: float) -> None:
        self.asked_at = now
        self.want_replan = True


def adopt(plan: Plan, belief: Belief, planner: PlannerLink, tries: Tries, report: Report
          ) -> None:
    """Take ``plan`` from its first action."""
    belief.adopt(plan)
    tries.grasps = 0
    report.last_error = ""
    planner.pending = None
    planner.shown_frame, planner.frame_looks = False, 0
    planner.waiting_why = ""
    report.say(f"plan {plan.plan_id or '?'}: {len(plan.actions)} actions")


def start_plan(d: StartPlan, belief: Belief, planner: PlannerLink, tries: Tries,
               cfg: ExecutorConfig, report: Report) -> Decision:
    """A plan is run only if it starts from the world we see now: one naming a block not
    seen (a tag a noisy frame dropped, or a plan for another scene) or from another state is
    replanned from a new look, at most ``max_replans`` times."""
    if d.plan is not None:
        adopt(d.plan, belief, planner, tries, report)
    plan = belief.plan
    assert plan is not None
    unknown = sorted({a.block for a in plan.actions} - set(belief.perceived))
    if unknown and belief.perceived:
        why = f"plan names block(s) {unknown} the camera has not seen"
        report.log(f"plan {plan.plan_id}: {why}; replanning")
        planner.rejected.add(plan.plan_id)
        return Replan(why)
    start = ({b.id: b.pose for b in plan.scene.blocks} if plan.scene
             else dict(belief.perceived))
    off, missing = deviations(belief.perceived, start, cfg.pos_tolerance, cfg.yaw_tolerance)
    if off or missing:
        why = "; ".join(d.describe() for d in off[:3]) or f"blocks {missing} not seen"
        report.log(f"plan {plan.plan_id} starts from another state ({why}); replanning")
        planner.rejected.add(plan.plan_id)
        return Replan(f"plan start differs from perception: {why}")
    belief.expected = dict(belief.perceived)
    belief.index = 0
    if not belief.camera_checked:
        add_camera_check(belief, cfg, report)
    return NextAction() if belief.plan.actions else VerifyGoal()


def add_camera_check(belief: Belief, cfg: ExecutorConfig, report: Report) -> None:
    """Before the first action of the executor's first run: the camera check's grips in
    place go in front of the plan (``nodes.executor.camera_check``)."""
    plan = belief.plan
    if plan is None or plan.scene is None or not plan.actions:
        return
    belief.camera_checked = True
    block = probe_block(belief.expected, belief.geo, belief.table(), cfg.pick_clearance,
                        cfg.camera_check_margin)
    if block is None:
        report.log("camera check skipped: no block has room for the fingers on all sides")
        return
    probes = probe_actions(block, belief.expected[block])
    belief.plan = dataclasses.replace(plan, actions=probes + tuple(plan.actions))
    belief.probes = len(probes)
    report.log(f"camera check: block {block} to be gripped in place along both of its axes")


def replan(d: Replan, belief: Belief, planner: PlannerLink, cfg: ExecutorConfig,
           report: Report, now: float) -> Decision:
    """Ask the planner for a plan from the perceived world (the current one will not be
    taken again); after ``max_replans``, give up. After a look the planner waited for (it
    refused to plan from a frame the arm covered), the correction is asked again once, not
    counted anew (a refusal the look did not cure, a block in the fingers hidden, counts)."""
    shown, planner.shown_frame = planner.shown_frame, False
    if shown and planner.frame_looks <= 1:
        return _ask(f"asking again, from the frame the planner waited for: {d.reason}",
                    d, belief, planner, report, now)
    planner.frame_looks = 0
    if planner.replans >= cfg.max_replans:
        why = f"; the planner: {planner.waiting_why}" if planner.waiting_why else ""
        return Stop(f"gave up after {planner.replans} replans; last: {d.reason}{why}",
                    failed=True)
    planner.replans += 1
    return _ask(f"replanning ({planner.replans}/{cfg.max_replans}): {d.reason}", d, belief,
                planner, report, now)


def _ask(line: str, d: Replan, belief: Belief, planner: PlannerLink, report: Report,
         now: float) -> Decision:
    """Ask the planner for a plan from the perceived world; the current plan is not taken
    again."""
    report.detail = d.reason
    report.log(line)
    if belief.plan is not None and belief.plan.plan_id:
        planner.rejected.add(belief.plan.plan_id)
    planner.ask(now)
    return Enter(State.REPLANNING)


def await_plan(belief: Belief, planner: PlannerLink, cfg: ExecutorConfig, report: Report,
               now: float) -> Decision | None:
    """At rest, replanning: take the plan that came; look again for a planner restarted
    meanwhile (it has no frame to plan a correction from); ask again when none comes."""
    if planner.pending is not None:
        return StartPlan(planner.pending)
    if planner.wants_frame:
        planner.wants_frame = False
        planner.shown_frame, planner.frame_looks = True, planner.frame_looks + 1
        report.log("the planner waits for a detection; looking again")
        return Observe(Purpose.RESUME, near=True)
    if planner.asked_at is not None and now - planner.asked_at > cfg.replan_timeout_s:
        accepted = accept_residual(belief, cfg, report, "no correcting plan came")
        if accepted is not None:
            return accepted
        report.log("no new plan yet; asking again")
        planner.ask(now)
    return None


def accept_residual(belief: Belief, cfg: ExecutorConfig, report: Report, why: str
                    ) -> Finish | None:
    """Done when every block is within the acceptance tolerance of its goal, the residual
    named in the detail; None (nothing changed) otherwise."""
    scene = belief.scene
    if scene is None or scene.goal is None:
        return None
    errors = belief.goal_errors()
    report.goal_errors(errors)
    if not errors or any(d.position_error > cfg.accept_pos_tolerance
                         or d.yaw_error > cfg.accept_yaw_tolerance for d in errors):
        return None
    worst = max(errors, key=lambda d: (d.position_error / cfg.accept_pos_tolerance
                                       + d.yaw_error / cfg.accept_yaw_tolerance))
    return Finish(f"every block within the acceptance tolerance of its goal "
                  f"({len(errors)} blocks; worst {worst.describe()}); {why}")


def finish(d: Finish, report: Report) -> Enter:
    report.say(d.detail)
    return Enter(State.DONE)
