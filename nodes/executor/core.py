"""The executor's closed loop, free of ROS: plan in, setpoints and requests out.

The node feeds ``ExecutorCore`` with plans, detections, the measured TCP, the gripper's
reports and start/stop requests, and calls ``tick(now)`` at the streaming rate; the core
answers with the setpoint and gripper command to publish and whether to trigger the camera
or ask the planner for a new plan. The loop, per the paper's cell plus perception feedback:

    observe -> check the world is as expected -> run action k -> observe -> ...

Every state the executor can be in, and every change between them with its reason, is in
``TRANSITIONS`` (the one table; docs/nodes.md prints it); ``state`` is also what
``/executor/status`` publishes:

* idle: parked; without a plan it looks now and then, for the planner.
* observing: out of the camera's view (the look pose after an action, else the park pose)
  while a frame is taken and judged; may already move on above the next block.
* running: streams action k; the grasp is supervised.
* recovering: sets a block down, lets go, or brings a block back into the workspace.
* replanning: at rest, waits for the planner.
* stopping: sets down what the fingers hold, parks.
* stopped: parked, fingers empty, until a start. done, failed: parked until a new plan.

Grasp supervision (``GraspSupervisor``): after a grip a block of the expected width must
be held, while lifting, carrying and lowering it must stay held, after a release the fingers
must be empty, and nobody else may command the gripper. A fault stops the motion at once
(braking along the path), lets go of anything in the fingers and looks again; the run then
resumes from what the camera sees: the same action again, a new plan, or a dropped block
brought back into the workspace. A block seen nowhere stops the run with its name; the arm
parks with empty fingers and every block left where it stands.
"""

from __future__ import annotations

import dataclasses
import math

from msgs_py import BlockSet, ExecutorStatus, PickPlace, Plan, Pose2D, Workspace
from msgs_py.actions import Action
from msgs_py.cell import GRIPPER_STROKE, GripperGeometry, table_margin_of
from msgs_py.status import GripperStatus
from nodes.executor.camera_check import PROBE_GRASPS, probe_actions, probe_block, probe_steps
from nodes.executor.config import ExecutorConfig
from nodes.executor.faults import FaultHandling
from nodes.executor.ledger import TimeLedger
from nodes.executor.motion import ToolPose
from nodes.executor.primitives import (
    GRASP_SYMMETRY,
    action_steps,
    expected_after,
    hover_steps,
    look_steps,
    park_steps,
)
from nodes.executor.recovery import fingers_clear, holds_block
from nodes.executor.states import TRANSITIONS, After, Held, Outputs, Purpose, State
from nodes.executor.steps import Step, StepRunner
from nodes.executor.supervision import GraspSupervisor
from nodes.executor.verify import Deviation, deviations, goal_errors

#: A tick advances the running script by at most this many tick periods (see ``_run``).
MAX_TICKS_PER_STEP = 2.0
#: A failed grasp is tried again from the newly perceived pose this often, then replanned.
GRASP_RETRIES = 2
#: Idle, without a plan, with the planner waiting: the next look this soon after the last (s).
IDLE_LOOK_SOON_S = 0.5




class ExecutorCore(FaultHandling):
    def __init__(self, cfg: ExecutorConfig) -> None:
        self.cfg = cfg
        self.state = State.IDLE
        self.plan: Plan | None = None
        self.geo = GripperGeometry()
        self.supervisor = GraspSupervisor(self.geo.block_size)
        self.index = 0  # next action to run (0-based)
        self.tcp: ToolPose | None = None
        self.tcp_stamp: float | None = None
        self.perceived: dict[int, Pose2D] = {}
        self.expected: dict[int, Pose2D] = {}
        self.held: Held | None = None
        self._picked_from: Pose2D | None = None  # where the current action's block stood
        self.commanded: ToolPose | None = None  # last setpoint streamed
        self.finger_gap: float | None = None
        self._new_gaps: list[tuple[float, float]] = []  # (time, gap) since the last tick
        self._new_readings: list[GripperStatus] = []
        self._checked_fingers = False
        self.last_error = ""
        self.detail = ""
        self.runner: StepRunner | None = None
        self._after = After.LOOK
        self._purpose = Purpose.START
        self._look_after_recovery = Purpose.RECOVERY  # what the look after a recovery judges
        self._trigger_ns: int | None = None
        self._trigger_time = 0.0
        self._triggers = 0
        self._frame_taken = False  # the camera answered the trigger: the arm may move on
        self._pending_detection: BlockSet | None = None  # arrived while the arm was moving
        self._script_lag = 0.0  # how far the runner's script time trails the clock (s)
        self._last_run: float | None = None
        self._replans = 0
        self._grasp_tries = 0
        self._release_stalls = 0  # openings that stalled since the last finished action
        self._stall_z = 0.0  # the tool height where the first of them began (m)
        self._stopped_in_place = False  # a stop that does not park (fingers that do not open)
        self._camera_checked = not cfg.camera_check  # the start-of-run check, once a lifetime
        self._probes = 0  # the plan's first actions that are the camera check's re-grips
        self._separations = 0  # overlapping blocks set apart in a row
        self._setting_apart: int | None = None  # the block a set-apart is going down for
        self._apart_blocked: set[int] = set()  # ... whose descent stopped on its partner
        self._bring_ins, self._bring_ins_of = 0, -1  # tries to bring block _of in, in a row
        self._replan_sent_at: float | None = None
        self._rejected_plans: set[str] = set()
        self._pending_plan: Plan | None = None
        self._stop_requested = False
        self._start_requested = cfg.auto_start
        self.metrics: dict[str, float] = {
            "actions_executed": 0.0, "replans": 0.0, "observations": 0.0,
            "execution_time_s": 0.0, "faults": 0.0,
        }
        self.ledger = TimeLedger()
        self._started_at: float | None = None
        self._last_idle_look: float | None = None
        self._planner_wants_frame = False  # the planner waits for a detection (to plan from)
        self._now = 0.0
        self._out = Outputs()
        self._pending_log: list[str] = []  # lines logged outside tick(), handed on by the next
        self._want_trigger = False
        self._want_replan = False
        self._arm_stop: str | None = None  # the arm's protective stop, while it lasts
        self._stop_cleared: str | None = None  # ... once unlocked, until handled
        self._unlock_asked_at: float | None = None

    # --- inputs ---------------------------------------------------------------------------------
    def on_tcp(self, pose: ToolPose, stamp_s: float | None = None) -> None:
        """The measured TCP, taken at ``stamp_s`` (ROS time, s; None: now)."""
        self.tcp = pose
        self.tcp_stamp = stamp_s

    def on_finger_gap(self, gap: float, stamp_s: float | None = None) -> None:
        """The measured gap between the pads (m), taken at ``stamp_s`` (ROS time, s): when a
        gripper command is done (with no gripper status, also whether a block is held)."""
        self.finger_gap = gap
        if stamp_s is not None:
            self._new_gaps.append((stamp_s, gap))

    def on_gripper(self, reading: GripperStatus) -> None:
        """A gripper status (the 2F-85 driver's): position, request, object detection."""
        self.finger_gap = reading.gap
        self._new_gaps.append((reading.stamp_ns * 1e-9, reading.gap))
        self._new_readings.append(reading)

    def on_frame_taken(self, stamp_ns: int) -> None:
        """The camera answered our trigger: the frame was taken at ``stamp_ns``."""
        if self.state is State.OBSERVING and self._trigger_ns is not None:
            self._trigger_ns = max(self._trigger_ns, stamp_ns)
            self._frame_taken = True

    def on_detection(self, detection: BlockSet) -> None:
        """Take a detection; only one taken after our camera trigger counts as an observation."""
        if self.state is not State.OBSERVING or self._trigger_ns is None:
            return
        if detection.stamp_ns < self._trigger_ns:
            return
        self._trigger_ns = None
        self.metrics["observations"] += 1
        if self.runner is not None:  # moving on towards the next block: judge on arrival
            self._pending_detection = detection
            return
        self._take_detection(detection)

    def on_plan(self, plan: Plan) -> None:
        if self.plan is not None and plan.plan_id and plan.plan_id == self.plan.plan_id:
            return  # the same latched plan again
        if plan.plan_id in self._rejected_plans:
            return
        if self.state in (State.RUNNING, State.OBSERVING, State.RECOVERING, State.STOPPING):
            self._pending_plan = plan  # finish what the arm is doing first
            return
        self._adopt(plan)

    def on_planner_waiting(self, for_detection: bool) -> None:
        """The planner says whether it waits for a detection. One that started after the
        executor's last idle look (or whose subscription had not met the detector's yet)
        would wait for the next, up to ``idle_look_period_s``, with the simulated clock
        running: while idle without a plan, and as long as it waits, look every
        IDLE_LOOK_SOON_S. One restarted while the executor waits for a correcting plan has
        nothing to plan from either: the executor looks again (``_wait_for_plan``)."""
        self._planner_wants_frame = for_detection

    def on_planner_failed(self, reason: str) -> None:
        """The planner found no plan for our replan request: what is left may be beyond its
        reach (a block a degree off in the middle of a dense grid can be neither grasped nor
        pushed), and blocks within the acceptance tolerance of their goal then end the run."""
        if self.state is not State.REPLANNING:
            return
        if not self._accept_residual(f"the planner found no correction ({reason})"):
            self._replan(f"the planner found no plan: {reason}")

    def request_start(self) -> str:
        self._start_requested = True
        self._stop_requested = False
        if self.state is State.STOPPED:
            self._enter(State.IDLE)
        return "starting" if self.plan is not None else "waiting for a plan"

    def request_stop(self) -> str:
        self._stop_requested = True
        self._start_requested = False
        if self.state in (State.RUNNING, State.OBSERVING, State.REPLANNING, State.RECOVERING):
            self._stop_safely("stop requested", failed=False)
        elif self.state is State.IDLE:
            self._enter(State.STOPPED)
        return "stopping"

    # --- the loop -------------------------------------------------------------------------------
    def tick(self, now: float) -> Outputs:
        self._out = Outputs()
        self._now = now
        if self.tcp is None:
            return self._out  # the arm has not reported yet: nothing safe to stream
        if self._started_at is None and self.state is State.RUNNING:
            self._started_at = now
        if (self.state is State.IDLE and self.runner is None and self.plan is not None
                and self._start_requested):
            self._begin_run()
        if self.state is State.IDLE and self.runner is None and self._holding_unawares():
            self._set_down_found_block()
        elif self.state is State.IDLE and (self.plan is None or self._planner_wants_frame):
            self._look_while_idle(now)
        if self._arm_stop is not None or self._stop_cleared is not None:
            self._handle_protective_stop()
        elif self.runner is not None:
            self._run(now)
        elif self.state is State.OBSERVING:
            self._wait_for_detection(now)
        elif self.state is State.REPLANNING:
            self._wait_for_plan(now)
        if self._new_readings:  # judged while a script runs; otherwise only the latest counts
            self.supervisor.last = self._new_readings[-1]
            self._new_readings.clear()
        if self._started_at is not None:
            self.metrics["execution_time_s"] = now - self._started_at
        self.ledger.charge(now, self._activity())
        # Requests made by input callbacks (a detection that calls for a replan, say) since the
        # last tick are handed on here: tick() is the only place outputs leave the core.
        self._out.log, self._pending_log = self._pending_log, []
        self._out.trigger_camera, self._want_trigger = self._want_trigger, False
        self._out.request_replan, self._want_replan = self._want_replan, False
        return self._out

    def _begin_run(self) -> None:
        """Start (or resume) with a plan: first make sure the fingers are empty."""
        if not self._checked_fingers:
            self._checked_fingers = True
            if self.held is None and self._fingers_hold_something():
                self._log(f"the fingers hold something ({self.finger_gap * 1e3:.1f} mm apart):"
                          " parking with it, then looking which block it is")
                self.held = Held(None)
        self._observe(Purpose.RESUME if self.index > 0 else Purpose.START)

    def _fingers_hold_something(self) -> bool:
        if self.supervisor.last is not None:
            return self.supervisor.holds_something()
        return holds_block(self.finger_gap, self.geo.block_size)

    def _activity(self) -> str:
        """What the time since the last tick went to (for the per-kind time metrics)."""
        if self.state is State.REPLANNING:
            return "replan"
        if self.state is State.RECOVERING:
            return "recover"
        if self.index < self._probes:
            return "camera_check"
        label = self.runner.current_label if self.runner is not None else ""
        if label.startswith("block ") and self.plan is not None and self.state in (
                State.RUNNING, State.OBSERVING):
            kinds = {a.block: a.type for a in self.plan.actions[self.index:self.index + 1]}
            block = int(label.split()[1].rstrip(":"))
            return kinds.get(block, "other")
        if self.state is State.OBSERVING or label.startswith(("look", "park")):
            return "look"
        return "other"

    def _holding_unawares(self) -> bool:
        """The fingers hold a block no run put there (an executor restarted mid-carry), and a
        plan (even one whose goal is gone) says where the workspace is."""
        return (self.held is None and self.plan is not None and self.plan.scene is not None
                and self._fingers_hold_something())

    def _set_down_found_block(self) -> None:
        """Take it beside the workspace (not to the park pose: out of view, it would stay
        there), look which block is missing, set it down at a free spot, look, then idle.
        Until then the planner, waiting for a frame that shows every block, has none."""
        self._log(f"the fingers hold something ({self.finger_gap * 1e3:.1f} mm apart) and no "
                  "run is going: looking which block it is, to set it down")
        self.held = Held(None)
        self._observe(Purpose.IDLE, near=True)

    def _look_while_idle(self, now: float) -> None:
        """No plan yet (or the planner waits for a frame): park, and show the planner the
        blocks with the arm out of view. Not with a block in the fingers: parked, it would be
        carried out of the cell; it is set down once a plan gives the workspace."""
        period = self.cfg.idle_look_period_s
        if period <= 0 or self.runner is not None or self._fingers_hold_something():
            return
        if self.commanded is None or self.commanded.distance_to(self.cfg.park) > 1e-6:
            self._start_runner(park_steps(self.cfg), After.IDLE_PARKED)
            return
        due = min(period, IDLE_LOOK_SOON_S) if self._planner_wants_frame else period
        if self._last_idle_look is None or now - self._last_idle_look >= due:
            self._last_idle_look = now
            self._want_trigger = True

    def _enter(self, state: State) -> None:
        """Change state, as ``TRANSITIONS`` allows (anything else is a bug: stop safely)."""
        if state is not self.state and state not in TRANSITIONS[self.state]:
            reason = f"internal error: no transition from {self.state.value} to {state.value}"
            self._log(reason)
            self.last_error = reason
            state = State.STOPPING if self.state is not State.STOPPING else State.FAILED
        self.state = state

    # --- status ---------------------------------------------------------------------------------
    def status(self) -> ExecutorStatus:
        """What ``/executor/status`` says: action k of n counts the plan's actions only (the
        camera check's re-grips show in the detail)."""
        total = len(self.plan.actions) if self.plan else 0
        block = None
        if self.plan and self.state is State.RUNNING and self.index < total:
            block = self.plan.actions[self.index].block
        running = self.state is State.RUNNING and self.index >= self._probes
        if self.held is not None and self.held.block is not None:
            block = self.held.block
        return ExecutorStatus(
            state=self.state.value,
            plan_id=self.plan.plan_id if self.plan else "",
            action_index=min(max(0, self.index - self._probes) + (1 if running else 0),
                             total - self._probes),
            action_total=total - self._probes,
            block=block,
            last_error=self.last_error,
            detail=self.detail,
            metrics=dict(self.metrics, replans=float(self._replans), **self.ledger.metrics()),
        )

    # --- plans ----------------------------------------------------------------------------------
    def _adopt(self, plan: Plan) -> None:
        self.plan = plan
        self.geo = GripperGeometry.from_params(plan.params)
        self.supervisor.block_size = self.geo.block_size
        self.index = 0
        self._grasp_tries = 0
        self._probes = 0
        self.last_error = ""
        self._pending_plan = None
        self.detail = f"plan {plan.plan_id or '?'}: {len(plan.actions)} actions"
        self._log(self.detail)
        if self.state is State.REPLANNING:
            self._check_plan_start()
        elif self.state in (State.DONE, State.FAILED):
            self._enter(State.IDLE)
            self._replans = 0

    def _check_plan_start(self) -> None:
        """A plan is run only if it starts from the world we see now."""
        plan = self.plan
        assert plan is not None
        unknown = sorted({a.block for a in plan.actions} - set(self.perceived))
        if unknown and self.perceived:
            self._rejected_plans.add(plan.plan_id)
            self._fail(f"plan names block(s) {unknown} the camera has not seen")
            return
        start = {b.id: b.pose for b in plan.scene.blocks} if plan.scene else dict(self.perceived)
        off, missing = deviations(self.perceived, start, self.cfg.pos_tolerance,
                                  self.cfg.yaw_tolerance)
        if off or missing:
            why = "; ".join(d.describe() for d in off[:3]) or f"blocks {missing} not seen"
            self._log(f"plan {plan.plan_id} starts from another state ({why}); replanning")
            self._rejected_plans.add(plan.plan_id)
            self._replan(f"plan start differs from perception: {why}")
            return
        self.expected = dict(self.perceived)
        self.index = 0
        self._check_camera_first()
        if self.plan.actions:
            self._next_action()
        else:
            self._verify_goal()

    def _check_camera_first(self) -> None:
        """Before the first action of the executor's first run: the camera check's grips in
        place go in front of the plan (``nodes.executor.camera_check``)."""
        plan = self.plan
        if self._camera_checked or plan is None or plan.scene is None or not plan.actions:
            return
        self._camera_checked = True
        table = self._table(plan)
        block = probe_block(self.expected, self.geo, table, self.cfg.pick_clearance,
                            self.cfg.camera_check_margin)
        if block is None:
            self._log("camera check skipped: no block has room for the fingers on all sides")
            return
        probes = probe_actions(block, self.expected[block])
        self.plan = dataclasses.replace(plan, actions=probes + tuple(plan.actions))
        self._probes = len(probes)
        self._log(f"camera check: block {block} to be gripped in place along both of its axes")

    def _table(self, plan: Plan) -> Workspace:
        """The table the fingers may stand on: the workspace and the plan's margin."""
        assert plan.scene is not None
        return plan.scene.workspace.grown(table_margin_of(plan.params))

    # --- observing ------------------------------------------------------------------------------
    def _observe(self, purpose: Purpose, near: bool = False) -> None:
        """Get out of the camera's view, then take a frame: from the park pose, or with
        ``near`` from the look pose beside the workspace (where the arm hides no block)."""
        self._begin_observing(purpose)
        steps = park_steps(self.cfg)
        if near and self.plan is not None and self.plan.scene is not None:
            steps = look_steps(self.cfg, self.plan.scene.workspace, self.commanded or self.tcp)
        self._start_runner(steps, After.LOOK)

    def _look_again_from_park(self) -> None:
        """Another frame, from the park pose (where the arm hides nothing), counting tries."""
        triggers = self._triggers
        self._observe(self._purpose)
        self._triggers = triggers

    def _begin_observing(self, purpose: Purpose) -> None:
        self._enter(State.OBSERVING)
        self._purpose = purpose
        self._triggers = 0
        self._trigger_ns = None
        self._pending_detection = None

    def _trigger(self) -> None:
        self._triggers += 1
        self._trigger_time = self._now
        self._trigger_ns = round(self._now * 1e9)
        self._frame_taken = False
        self._want_trigger = True

    def _move_on_while_looking(self) -> None:
        """The frame is taken: head for the next action's block at travel height while the
        detection comes (nothing is touched before the world is judged)."""
        self._frame_taken = False
        plan = self.plan
        if (not self.cfg.look_while_moving or plan is None or self.runner is not None
                or self._purpose is not Purpose.AFTER_ACTION
                or self.index >= len(plan.actions)):
            return
        action = plan.actions[self.index]
        start = self.expected.get(action.block)
        if start is not None:
            self._start_runner(hover_steps(action, start, self.geo, self.cfg,
                                           self._pick_opening(action, start), self._turn_period),
                               After.HOVERING)

    def _wait_for_detection(self, now: float) -> None:
        if self._frame_taken:
            self._move_on_while_looking()
            return
        if self._trigger_ns is None:
            return
        if now - self._trigger_time < self.cfg.detection_timeout_s:
            return
        if self._triggers >= self.cfg.detection_retries:
            self._fail(f"no detection after {self._triggers} camera triggers")
            return
        self._log(f"no detection {self.cfg.detection_timeout_s:.0f} s after the trigger; "
                  "looking again from the park pose")
        self._look_again_from_park()

    def _take_detection(self, detection: BlockSet) -> None:
        self.perceived = {b.id: b.pose for b in detection.blocks}
        plan = self.plan
        if plan is None:
            self._enter(State.IDLE)
            return
        if self.held is not None:  # something in the fingers: put it down first
            self._recover_held_block()
            return
        if plan.scene is not None and (self._bring_in_outside_block(plan)
                                       or self._separate_overlapping_blocks(plan)):
            return
        if self._purpose is Purpose.IDLE:  # a block found in the fingers is down: idle again
            self.expected = dict(self.perceived)
            self._enter(State.IDLE)
            if self._pending_plan is not None:
                self._adopt(self._pending_plan)
            return
        if self._purpose is Purpose.START:
            self._check_plan_start()
            return
        self._judge_world()

    def _judge_world(self) -> None:
        """After an action, a recovery or a stop: the world must be as expected."""
        plan = self.plan
        assert plan is not None
        probed = plan.actions[self.index - 1].block if 0 < self.index <= self._probes else None
        if probed is not None and probed in self.perceived:  # a re-grip: judged by the detector
            self.expected[probed] = self.perceived[probed]
        off, missing = deviations(self.perceived, self.expected, self.cfg.pos_tolerance,
                                  self.cfg.yaw_tolerance)
        if missing:
            if self._triggers < self.cfg.detection_retries:
                self._log(f"blocks {missing} not seen; looking again from the park pose")
                self._look_again_from_park()
                return
            self._fail(f"block(s) {missing} are no longer seen by the camera (taken away?); "
                       "every other block is left as it stands")
            return
        newcomers = sorted(set(self.perceived) - set(self.expected))
        if not (off or newcomers) and self._grasp_tries > GRASP_RETRIES:
            self._replan(f"the grasp of block {plan.actions[self.index].block} missed "
                         f"{self._grasp_tries} times")
            return
        if off or newcomers:
            why = "; ".join([d.describe() for d in off[:3]]
                            + [f"block {b} appeared" for b in newcomers[:3]])
            done = "the camera check" if 0 < self.index <= self._probes else \
                f"action {self.index - self._probes}"
            self._replan(f"after {done}: {why}")
            return
        self.expected = dict(self.perceived)
        if self._pending_plan is not None:
            pending, self._pending_plan = self._pending_plan, None
            self._adopt(pending)
            self._check_plan_start()
            return
        if self.index < len(plan.actions):
            self._next_action()
            return
        if self._purpose is not Purpose.GOAL:
            self._observe(Purpose.GOAL)  # the last look is from the park pose: the run ends there
            return
        self._verify_goal()

    def _verify_goal(self) -> None:
        assert self.plan is not None
        if self.plan.scene is None:
            self._finish("plan has no scene to verify against")
            return
        errors = self._goal_errors()
        off = [d for d in errors
               if d.position_error > self.cfg.pos_tolerance or d.yaw_error > self.cfg.yaw_tolerance]
        if off:
            if not self.plan.actions and self._accept_residual(
                    "the planner leaves them as they stand (an empty plan)"):
                return
            self._replan("goal not reached: " + "; ".join(d.describe() for d in off[:3]))
            return
        self._finish(f"every block verified at its goal ({len(errors)} blocks)")

    @property
    def _turn_period(self) -> float:
        """Placed this turn off its goal yaw, a block is as good as at it, its fingers where
        the planner checked them: a half turn for a cube, a full one when ``yaw_exact``."""
        plan = self.plan
        exact = plan is not None and plan.scene is not None and plan.scene.goal is not None \
            and plan.scene.goal.yaw_exact
        return 2 * math.pi if exact else GRASP_SYMMETRY

    def _goal_errors(self) -> list[Deviation]:
        """Every goal slot's perceived error, also kept in the metrics (worst position, yaw)."""
        assert self.plan is not None and self.plan.scene is not None
        errors = goal_errors(self.perceived, self.plan.scene)
        if errors:
            self.metrics["final_pos_err_max_m"] = max(d.position_error for d in errors)
            self.metrics["final_yaw_err_max_deg"] = math.degrees(
                max(d.yaw_error for d in errors))
        return errors

    def _accept_residual(self, why: str) -> bool:
        """Finish when every block is within the acceptance tolerance of its goal, the
        residual named in the detail; False (nothing changed) otherwise."""
        if self.plan is None or self.plan.scene is None or self.plan.scene.goal is None:
            return False
        errors = self._goal_errors()
        if not errors or any(d.position_error > self.cfg.accept_pos_tolerance
                             or d.yaw_error > self.cfg.accept_yaw_tolerance for d in errors):
            return False
        worst = max(errors, key=lambda d: (d.position_error / self.cfg.accept_pos_tolerance
                                           + d.yaw_error / self.cfg.accept_yaw_tolerance))
        self._finish(f"every block within the acceptance tolerance of its goal "
                     f"({len(errors)} blocks; worst {worst.describe()}); {why}")
        return True

    def _finish(self, detail: str) -> None:
        self._enter(State.DONE)
        self.detail = detail
        self._log(detail)

    # --- replanning -----------------------------------------------------------------------------
    def _replan(self, reason: str) -> None:
        if self._replans >= self.cfg.max_replans:
            self._fail(f"gave up after {self._replans} replans; last: {reason}")
            return
        self._replans += 1
        self._enter(State.REPLANNING)
        self.detail = reason
        self._log(f"replanning ({self._replans}/{self.cfg.max_replans}): {reason}")
        if self.plan is not None and self.plan.plan_id:
            self._rejected_plans.add(self.plan.plan_id)
        self._replan_sent_at = self._now
        self._want_replan = True

    def _wait_for_plan(self, now: float) -> None:
        if self._pending_plan is not None:
            pending, self._pending_plan = self._pending_plan, None
            self._adopt(pending)
            return
        if self._planner_wants_frame and self.runner is None:
            # a planner restarted since the last frame has none to plan a correction from
            self._planner_wants_frame = False
            self._log("the planner waits for a detection; looking again")
            self._observe(Purpose.RESUME, near=True)
            return
        if self._replan_sent_at is not None and now - self._replan_sent_at > \
                self.cfg.replan_timeout_s:
            if self._accept_residual("no correcting plan came"):
                return
            self._log("no new plan yet; asking again")
            self._replan_sent_at = now
            self._want_replan = True

    # --- acting ---------------------------------------------------------------------------------
    def _next_action(self) -> None:
        plan = self.plan
        assert plan is not None
        action = plan.actions[self.index]
        start = self.expected.get(action.block)
        if start is None:
            self._fail(f"action {self.index + 1} moves block {action.block}, which is not seen")
            return
        self._enter(State.RUNNING)
        if self.index < self._probes:
            self.detail = f"camera check: block {action.block} gripped in place along both " \
                          "of its axes"
        else:
            self.detail = f"action {self.index - self._probes + 1}/" \
                          f"{len(plan.actions) - self._probes}: {action.type} block {action.block}"
        self._log(self.detail)
        opening = self._pick_opening(action, start)
        if self.index < self._probes:
            steps = probe_steps(action.block, start, self.geo, self.cfg,
                                opening if opening is not None else self.geo.approach_opening)
        else:
            steps = action_steps(action, start, self.geo, self.cfg, opening, self._turn_period)
        self._picked_from = start
        self.expected[action.block] = expected_after(action, start, self.geo)
        if self._looks_after(self.index) and plan.scene is not None:
            end = self.expected[action.block]
            steps += look_steps(self.cfg, plan.scene.workspace,
                                ToolPose(end.x, end.y, self.cfg.travel_height, 0.0))
        self._start_runner(steps, After.ACTION_DONE)

    def _pick_opening(self, action: Action, start: Pose2D) -> float | None:
        """The fingers open wider than the plan asks (``pick_clearance``) to go down around a
        block whose neighbours leave room: a perception a centimetre off still grips it."""
        plan = self.plan
        if not isinstance(action, PickPlace) or plan is None or plan.scene is None:
            return None
        return self._wide_opening({**self.expected, action.block: start}, action.block,
                                  action.grasp, self._table(plan))

    def _wide_opening(self, around: dict[int, Pose2D], block: int, grasp: int,
                      table: Workspace) -> float | None:
        """The ``pick_clearance`` opening for ``block`` among ``around`` if its fingers clear
        every other block and stand on ``table``; None (the plan's opening) otherwise."""
        wide = dataclasses.replace(self.geo, approach_clearance=max(
            self.cfg.pick_clearance, self.geo.approach_clearance))
        if wide.approach_opening > GRIPPER_STROKE - 0.001:
            return None
        if not fingers_clear(around, block, wide, grasp, table):
            return None
        return wide.approach_opening

    def _looks_after(self, index: int) -> bool:
        """Whether the camera looks from the look pose after action ``index`` (the last one is
        looked at from the park pose)."""
        assert self.plan is not None
        return self.cfg.observe_every_action and index + 1 < len(self.plan.actions)

    # --- running scripts ------------------------------------------------------------------------
    def _start_runner(self, steps: list[Step], after: After) -> None:
        self._script_lag = 0.0
        self._last_run = None
        start = self.commanded or self.tcp
        assert start is not None
        self.runner = StepRunner(steps, start, self.cfg.convergence_tol,
                                 self.cfg.convergence_timeout_s, self.cfg.in_safe_box)
        self._after = after

    def _run(self, now: float) -> None:
        runner = self.runner
        assert runner is not None
        # Script time advances at most MAX_TICKS_PER_STEP ticks per tick: an executor held up
        # (a loaded machine) resumes its trajectory where it was, so consecutive setpoints
        # stay close in space, never a chord across a corner of the path.
        step = 0.0 if self._last_run is None else now - self._last_run
        self._script_lag += max(0.0, step - MAX_TICKS_PER_STEP / self.cfg.rate_hz)
        self._last_run = now
        lag = self._script_lag
        gaps = [(t - lag, g) for t, g in self._new_gaps]
        self._new_gaps = []
        measured_at = None if self.tcp_stamp is None else self.tcp_stamp - lag
        tick = runner.update(now - lag, self.tcp, measured_at, gaps)
        self.commanded = tick.setpoint
        self._out.setpoint = tick.setpoint
        self._out.gripper = tick.gripper
        fault = None if tick.error else self._supervise(runner, tick.gripper)
        if fault is not None and self.state is not State.STOPPING:
            self._on_grasp_fault(fault)
            return
        if tick.stalled and self._on_release_stall(tick.error):
            return
        if tick.blocked and self.state is State.RUNNING:
            self._on_blocked_descent(tick.error)
            return
        if tick.blocked and self.state is State.RECOVERING and self._setting_apart is not None:
            self._on_blocked_set_apart(tick.error)
            return
        if tick.error:
            if self.state is State.STOPPING:
                self.runner = None
                self._enter(State.FAILED)
                self.last_error = f"{self.last_error}; then {tick.error}"
                return
            self._stop_safely(tick.error, failed=True)
            return
        if not tick.done:
            return
        after, self.runner = self._after, None
        self._runner_done(after)

    def _on_blocked_descent(self, why: str) -> None:
        """The tool stopped above where it went down: something stands there (a block knocked
        under it). Back up and look from the look pose, with whatever the fingers hold: a held
        block is then set down at a free spot, and the run goes on from what the camera sees."""
        plan = self.plan
        self.metrics["blocked_descents"] = self.metrics.get("blocked_descents", 0.0) + 1.0
        self._log(f"{why}: something is in the way below; backing up and looking again")
        if self.held is None and plan is not None and self.index < len(plan.actions) \
                and self._picked_from is not None:
            self.expected[plan.actions[self.index].block] = self._picked_from  # not moved
        self._observe(Purpose.RECOVERY, near=True)

    def _on_blocked_set_apart(self, why: str) -> None:
        """Setting overlapping blocks apart, the tool stopped on the way down to one of them:
        the other lies on it. Back up, look, and set the other one apart first."""
        assert self._setting_apart is not None
        self._apart_blocked.add(self._setting_apart)
        self._log(f"{why}: block {self._setting_apart} lies under another; backing up to set "
                  "the other apart first")
        self._setting_apart = None
        self._observe(Purpose.RECOVERY, near=True)

    def _runner_done(self, after: After) -> None:
        if after is After.LOOK:
            self._trigger()
        elif after is After.ACTION_DONE:
            self._action_done()
        elif after is After.HOVERING:
            pending, self._pending_detection = self._pending_detection, None
            if pending is not None:
                self._take_detection(pending)
        elif after is After.RECOVERED:
            self.held = None
            self._setting_apart = None
            if self._stop_requested:
                self._stop_safely("stop requested", failed=False)
            else:
                purpose = self._look_after_recovery
                self._observe(purpose, near=purpose is Purpose.RECOVERY)
        elif after is After.STOPPED:
            self.held = None
            self._enter(State.FAILED if self.last_error else State.STOPPED)
            where = "stopped over the block it holds" if self._stopped_in_place else "parked"
            self._stopped_in_place = False
            self._log(f"arm {where}: {self.state.value}")

    def _action_done(self) -> None:
        plan = self.plan
        assert plan is not None
        if self.index < self._probes:
            self.metrics["camera_check_regrips"] = (
                self.metrics.get("camera_check_regrips", 0.0) + len(PROBE_GRASPS))
        else:
            self.metrics["actions_executed"] += 1
            kind = f"{plan.actions[self.index].type}_executed"  # pick_place_executed, ...
            self.metrics[kind] = self.metrics.get(kind, 0.0) + 1.0
        self._grasp_tries = 0
        self._release_stalls = 0
        self.held = None
        looked_from_here = self._looks_after(self.index) and plan.scene is not None
        self.index += 1
        if self._stop_requested:
            self._stop_safely("stop requested", failed=False)
        elif looked_from_here:  # the script ended at the look pose
            self._begin_observing(Purpose.AFTER_ACTION)
            self._trigger()
        elif self.index >= len(plan.actions):
            self._observe(Purpose.GOAL)
        elif self.cfg.observe_every_action:
            self._observe(Purpose.AFTER_ACTION, near=True)
        else:
            self._next_action()

    def _fail(self, reason: str) -> None:
        self._stop_safely(reason, failed=True)

    def _log(self, line: str) -> None:
        self._pending_log.append(line)
