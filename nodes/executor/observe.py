"""Observing: a frame, and the world judged from its detection.

After an action the arm looks *on its way* to the next block (``look_on_the_way``): the
frame is taken at the first moment the arm's predicted silhouette (``visibility``) leaves
every block to judge in view (the action's block, the blocks near where it acted, and those
near where the next action will act), triggered when the measured tool gets there and the
arm's measured posture shows them (``camera``: past that moment if need be), and judged once
the detector says none of them is occluded; the blocks the arm still covers keep what was
last seen of them. Only when no moment on the way leaves them in view, or the frame shows
one covered after all, does the arm look from the look pose beside the workspace's robot-side
edge (``near``), where it hides no block, or from the park pose. Only a detection of a
frame taken after the executor's own trigger counts. From the look pose, once the camera
says the frame is taken, the arm heads for the next block at travel height (nothing is
touched before the world is judged). The frame is judged for its ``Purpose``: every block
where it should be after an action, a plan that starts from the world, every block at its
goal. Idle, without a plan, the executor looks now and then for the planner.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

from msgs_py import BlockSet, Plan
from msgs_py.status import ExecutorState as State
from nodes.executor.act import pick_opening
from nodes.executor.belief import Belief
from nodes.executor.camera import Camera
from nodes.executor.config import ExecutorConfig
from nodes.executor.decisions import (
    Decision,
    Enter,
    Finish,
    JudgeOnArrival,
    LookHere,
    NextAction,
    Observe,
    Parked,
    Replan,
    Script,
    StartPlan,
    Stop,
    TakeFrame,
)
from nodes.executor.inputs import Inbox
from nodes.executor.motion import ToolPose
from nodes.executor.primitives import hover_steps, look_steps, park_steps
from nodes.executor.replan import accept_residual
from nodes.executor.report import Report
from nodes.executor.states import Purpose, Tries
from nodes.executor.steps import Activity, Grip, Move, Rise
from nodes.executor.verify import deviations
from nodes.executor.visibility import (
    View,
    best_moment,
    footprint,
    look_waypoints,
    neighbours,
    script_samples,
    shows,
)

#: Of the look waypoints with the least detour, this many are tried (the quickest way wins:
#: 2.8 s of detours in the default run's 10 looks against 4.15 s through the first one) ...
WAYPOINTS_TRIED = 3
#: ... each rounded off within the first of these (m) that still shows what must be seen.
WAYPOINT_BLENDS = (0.12, 0.04, 0.0)
#: A failed grasp is tried again from the newly perceived pose this often, then replanned.
GRASP_RETRIES = 2
#: Idle, without a plan, with the planner waiting: the next look this soon after the last (s).
IDLE_LOOK_SOON_S = 0.5


def observe(d: Observe, camera: Camera, belief: Belief, cfg: ExecutorConfig,
            here: ToolPose | None) -> Enter:
    """Out of view (from ``here``), then a frame for ``d.purpose``."""
    camera.begin(d.purpose, d.keep_tries)
    steps = park_steps(cfg)
    if d.near and belief.scene is not None:
        assert here is not None
        steps = look_steps(cfg, belief.scene.workspace, here)
    return Enter(State.OBSERVING, Script(steps, TakeFrame()))


def look_on_the_way(camera: Camera, belief: Belief, cfg: ExecutorConfig, view: View | None,
                    here: ToolPose | None, now: float, report: Report,
                    arm_joints: Sequence[float] | None = None) -> Decision:
    """After an action: head for the next action's block at once, and take the frame at the
    moment on the way (the arm's postures from ``arm_joints``, its branch) that shows the
    blocks the next action needs judged (and most of the others not seen since an action near
    them); with none, pass a point that shows them (``via_waypoint``); else the look pose."""
    action = belief.current
    start = None if action is None else belief.expected.get(action.block)
    if view is None or action is None or start is None or here is None:
        report.count("looks_from_look_pose")
        return Observe(Purpose.AFTER_ACTION, near=True)
    steps = hover_steps(action, start, belief.geo, cfg, pick_opening(belief, cfg, action, start),
                        belief.turn_period)
    need = blocks_to_judge(belief, cfg)
    samples = script_samples(steps, here, cfg.in_safe_box, cfg.convergence_tol)
    at = best_moment(view, samples, belief.expected, need, belief.unverified - need, arm_joints)
    if at is not None:
        report.count("looks_on_the_way")
    else:
        detour = via_waypoint(view, belief, cfg, here, samples[-1][1], need, steps, arm_joints)
        if detour is None:
            report.count("looks_from_look_pose")
            return Observe(Purpose.AFTER_ACTION, near=True)
        steps, at, samples = detour
        report.count("looks_from_waypoint")
    camera.begin(Purpose.AFTER_ACTION)
    camera.on_the_way, camera.judge = True, frozenset(need)
    camera.trigger_near = next(p for t, p in samples if t >= at)
    return Enter(State.OBSERVING, Script(steps, JudgeOnArrival()))


def via_waypoint(view: View, belief: Belief, cfg: ExecutorConfig, here: ToolPose,
                 then: ToolPose, need: set[int], steps: list,
                 arm_joints: Sequence[float] | None = None) -> tuple[list, float, list] | None:
    """The quickest way to the next block through one of the WAYPOINTS_TRIED points that
    show ``need`` with the least detour, rounded off there by one of WAYPOINT_BLENDS (the
    last: stopping on it), that still shows ``need``; the way, when the arm passes the point
    (script s) and the script's dry-run samples; None without such a way. The ways are tried
    quickest first, so the first that shows ``need`` is the one: each try costs the arm's
    postures and silhouettes along it, in the tick that ends an action."""
    ws = belief.scene.workspace if belief.scene is not None else None
    if ws is None:
        return None
    up = here.with_z(max(here.z, cfg.travel_height))
    area = (ws.x_min - cfg.look_offset, ws.x_max, ws.y_min, ws.y_max)
    grips = [step for step in steps if isinstance(step, Grip)]
    moves = [step for step in steps if not isinstance(step, Grip | Rise)]  # risen already
    ways = []
    for waypoint in look_waypoints(view, up, then, belief.expected, need, area, WAYPOINTS_TRIED,
                                   arm_joints):
        for blend in WAYPOINT_BLENDS:
            # the fingers are shaped once the tool is up (``primitives.rise_then_shape``)
            way = [Rise(cfg.travel_height, cfg.vertical_limits, "look: rise",
                        activity=Activity.LOOK), *grips,
                   Move(waypoint, cfg.travel_limits, "look: on the way", converge=False,
                        blend=blend, activity=Activity.LOOK), *moves]
            ways.append((way, script_samples(way, here, cfg.in_safe_box, cfg.convergence_tol)))
    for way, samples in sorted(ways, key=lambda w: w[1][-1][0]):  # stable: ties keep order
        at = best_moment(view, samples, belief.expected, need, set(), arm_joints)
        if at is not None:
            return way, at, samples
    return None


def trigger_when_due(camera: Camera, view: View | None, inbox: Inbox, belief: Belief,
                     report: Report, now: float) -> None:
    """Observing on the way: the frame is triggered once the measured tool has reached the
    pose picked for it and the arm's measured posture leaves the blocks to judge in view."""
    if camera.due(now, inbox.tcp, posture_check(view, inbox, belief, camera)):
        report.log(f"frame on the way, the tool {camera.near_dist * 1e3:.0f} mm from the pose "
                   "picked for it" + (f", {camera.held_back} tick(s) on: the arm covered a block "
                                      "to judge there" if camera.held_back else ""))


def posture_check(view: View | None, inbox: Inbox, belief: Belief, camera: Camera
                  ) -> Callable[[], bool] | None:
    """For a look on the way: whether the arm's measured posture leaves the blocks the frame
    must show in view (``visibility.shows``); None without a camera model, joint states or
    blocks to judge (the pose picked for the frame decides alone)."""
    q, rates = inbox.arm_joints, inbox.arm_rates
    if view is None or q is None or not camera.on_the_way or camera.trigger_near is None:
        return None
    judged = {i: belief.expected[i] for i in camera.judge if i in belief.expected}
    return (lambda: shows(view, q, rates, judged)) if judged else None


def go_on(pending: Plan | None) -> Decision:
    """Nothing to judge on the way: the next action (or the plan that came meanwhile)."""
    return StartPlan(pending) if pending is not None else NextAction()


def covered_on_the_way(camera: Camera, belief: Belief, detection: BlockSet, report: Report
                       ) -> Decision | None:
    """A frame taken on the way: one that shows a block to judge covered by the arm after all
    calls for a look from the look pose; otherwise the blocks the arm covers keep what was
    last seen of them (``belief.perceived`` holds the seen ones already)."""
    covered = sorted(camera.judge & set(detection.occluded))
    if covered:
        report.count("looks_from_look_pose")
        report.log(f"block(s) {covered} covered by the arm in the frame taken on the way: "
                   "looking from the look pose")
        return Observe(Purpose.AFTER_ACTION, near=True, keep_tries=True)
    belief.perceived.update({i: belief.expected[i] for i in detection.occluded
                             if i in belief.expected})
    return None


def blocks_to_judge(belief: Belief, cfg: ExecutorConfig) -> set[int]:
    """The blocks the next action needs judged before it goes down: its own block (whatever
    moved it since the last frame, the grasp is centred on what the camera says), and those
    near where it will act that an action acted near since they were last seen."""
    nxt = belief.current
    if nxt is None or nxt.block not in belief.expected:
        return set()
    near = neighbours(belief.expected, footprint(belief.expected[nxt.block], nxt),
                      cfg.judge_radius)
    return {nxt.block} | (near & belief.unverified)


def look_here(d: LookHere, camera: Camera, now: float) -> Enter:
    """The script ended out of view: the frame for ``d.purpose`` now."""
    camera.begin(d.purpose)
    camera.trigger(now)
    return Enter(State.OBSERVING)


def await_detection(camera: Camera, belief: Belief, cfg: ExecutorConfig, report: Report,
                    now: float) -> Decision | None:
    """At rest, observing: move on once the frame is taken, or look again (from the park
    pose) when no detection comes in time, and give up after ``detection_retries``."""
    if camera.frame_taken:
        return move_on(camera, belief, cfg)
    if camera.trigger_ns is None or now - camera.trigger_time < cfg.detection_timeout_s:
        return None
    if camera.triggers >= cfg.detection_retries:
        return Stop(f"no detection after {camera.triggers} camera triggers", failed=True)
    report.log(f"no detection {cfg.detection_timeout_s:.0f} s after the trigger; "
               "looking again from the park pose")
    return Observe(camera.purpose, keep_tries=True)


def move_on(camera: Camera, belief: Belief, cfg: ExecutorConfig) -> Enter | None:
    """The frame is taken: head for the next action's block at travel height while the
    detection comes (nothing is touched before the world is judged)."""
    camera.frame_taken = False
    action = belief.current
    if (not cfg.look_while_moving or action is None or camera.on_the_way
            or camera.purpose is not Purpose.AFTER_ACTION):
        return None
    start = belief.expected.get(action.block)
    if start is None:
        return None
    steps = hover_steps(action, start, belief.geo, cfg, pick_opening(belief, cfg, action, start),
                        belief.turn_period)
    return Enter(State.OBSERVING, Script(steps, JudgeOnArrival()))


def judged_after(belief: Belief) -> str:
    """What the look judges: the camera check's grips, an action, or a recovery made
    before the plan's first action (a block let go where a protective stop left it)."""
    actions_done = belief.index - belief.probes
    if 0 < belief.index <= belief.probes:
        return "after the camera check"
    return f"after action {actions_done}" if actions_done > 0 else "before action 1"


def judge_world(belief: Belief, camera: Camera, tries: Tries, cfg: ExecutorConfig,
                report: Report, pending: Plan | None) -> Decision:
    """After an action, a recovery or a stop: the world must be as expected. A block not
    seen is looked for from the park pose, then the run stops; a block off, a new one, or
    one a recovery moved that the plan cannot take on from there (``Belief.stranded``) asks for a
    replan; else the next action (or the ``pending`` plan that came meanwhile, or
    the goal)."""
    plan = belief.plan
    assert plan is not None
    if 0 < belief.index <= belief.probes:  # a re-grip in place: judged by the detector
        probed = plan.actions[belief.index - 1].block
        if probed in belief.perceived:
            belief.expected[probed] = belief.perceived[probed]
    off, missing = deviations(belief.perceived, belief.expected, cfg.pos_tolerance,
                              cfg.yaw_tolerance)
    if missing:
        if camera.triggers < cfg.detection_retries:
            report.count("looks_again_from_park_pose")
            report.log(f"blocks {missing} not seen; looking again from the park pose")
            return Observe(camera.purpose, keep_tries=True)
        return Stop(f"block(s) {missing} are no longer seen by the camera (taken away?); "
                    "every other block is left as it stands", failed=True)
    newcomers = sorted(set(belief.perceived) - set(belief.expected))
    if not (off or newcomers) and tries.grasps > GRASP_RETRIES:
        return Replan(f"the grasp of block {plan.actions[belief.index].block} missed "
                      f"{tries.grasps} times")
    stranded = belief.stranded()
    if off or newcomers or stranded:
        why = "; ".join([d.describe() for d in off[:3]]
                        + [f"block {b} appeared" for b in newcomers[:3]]
                        + [f"block {b} moved aside by a recovery {where}"
                           for b, where in list(stranded.items())[:3]])
        return Replan(f"{judged_after(belief)}: {why}")
    belief.expected = dict(belief.perceived)
    if pending is not None:
        return StartPlan(pending)
    if belief.index < len(plan.actions):
        return NextAction()
    if camera.purpose is not Purpose.GOAL:
        return Observe(Purpose.GOAL)  # the last look is from the park pose: the run ends there
    return verify_goal(belief, cfg, report)


def verify_goal(belief: Belief, cfg: ExecutorConfig, report: Report) -> Decision:
    """Every block at its goal: done; else a replan (an empty plan that leaves blocks within
    the acceptance tolerance of their goal: done, the residual named)."""
    plan = belief.plan
    assert plan is not None
    if plan.scene is None:
        return Finish("plan has no scene to verify against")
    errors = belief.goal_errors()
    report.goal_errors(errors)
    off = [d for d in errors
           if d.position_error > cfg.pos_tolerance or d.yaw_error > cfg.yaw_tolerance]
    if off:
        if not plan.actions:
            accepted = accept_residual(belief, cfg, report,
                                       "the planner leaves them as they stand (an empty plan)")
            if accepted is not None:
                return accepted
        return Replan("goal not reached: " + "; ".join(d.describe() for d in off[:3]))
    return Finish(f"every block verified at its goal ({len(errors)} blocks)")


def look_while_idle(camera: Camera, cfg: ExecutorConfig, parked: bool, hands_full: bool,
                    wants_frame: bool, now: float) -> Enter | None:
    """No plan yet (or the planner waits for a frame): park, and show the planner the blocks
    with the arm out of view, every ``idle_look_period_s`` (every IDLE_LOOK_SOON_S while the
    planner waits). Not with a block in the fingers: parked, it would be carried out of the
    cell; it is set down once a plan gives the workspace."""
    period = cfg.idle_look_period_s
    if period <= 0 or hands_full:
        return None
    if not parked:
        return Enter(State.IDLE, Script(park_steps(cfg), Parked()))
    due = min(period, IDLE_LOOK_SOON_S) if wants_frame else period
    if camera.last_idle_look is None or now - camera.last_idle_look >= due:
        camera.last_idle_look = now
        camera.want_trigger = True
    return None
