"""The executor's closed loop, free of ROS: plan in, setpoints and requests out.

The node feeds ``ExecutorCore`` through ``ExecutorInputs`` (``nodes/executor/inputs.py``:
plans, detections, the measured TCP, the gripper's reports, the arm's safety mode, start and
stop) and calls ``tick(now)`` at the streaming rate; the core answers with the setpoint and
gripper command to publish and whether to trigger the camera or ask the planner for a new
plan. The loop: observe -> check the world is as expected -> run action k -> observe -> ...

The core holds the belief (``Belief``: the plan, the next action, the blocks expected and
perceived, what the fingers hold) and the state (``ExecutorState``; every change between
states, with its reason, is ``TRANSITIONS``). Each tick it plays the arm's script, or, at
rest, lets the state's handler decide (``_at_rest``); handlers live by concept
(``observe``, ``act``, ``recover``, ``faults``, ``replan``, ``stop``), take what they need
and answer with a typed ``Decision``, which the core dispatches through ``_handlers`` until
it names the next state and the script to play. A script's end (its ``Then``) and a tick's
fault are dispatched the same way.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from msgs_py import BlockSet, ExecutorStatus, Plan
from msgs_py.status import ArmStatus, GripperStatus
from msgs_py.status import ExecutorState as State
from nodes.executor import act, faults, observe, recover, replan, stop
from nodes.executor.belief import Belief
from nodes.executor.camera import Camera, count_detection
from nodes.executor.config import ExecutorConfig
from nodes.executor.decisions import (
    ActionDone,
    Decision,
    Enter,
    Finish,
    Halt,
    JudgeOnArrival,
    LookHere,
    LookOnTheWay,
    NextAction,
    Observe,
    Parked,
    Recovered,
    Replan,
    StartPlan,
    Stop,
    Stopped,
    TakeFrame,
    VerifyGoal,
)
from nodes.executor.faults import ArmHold
from nodes.executor.inputs import Inbox
from nodes.executor.ledger import activity_of
from nodes.executor.motion import ToolPose
from nodes.executor.player import Player
from nodes.executor.recovery import holds_block
from nodes.executor.replan import PlannerLink
from nodes.executor.report import Report, executor_status
from nodes.executor.states import PLANS_WAIT_IN, TRANSITIONS, Held, Outputs, Purpose, Tries
from nodes.executor.supervision import GraspFault, GraspSupervisor
from nodes.executor.visibility import View


class ExecutorCore:
    """The executor's loop: ``ExecutorInputs`` in, ``tick(now)`` -> ``Outputs``."""

    def __init__(self, cfg: ExecutorConfig) -> None:
        self.cfg = cfg
        self.state = State.IDLE
        self.belief = Belief(camera_checked=not cfg.camera_check)
        self.inbox = Inbox()
        self.player = Player(cfg)
        self.camera = Camera()
        self.planner = PlannerLink()
        self.tries = Tries()
        self.report = Report()
        self.guard = ArmHold()
        self.supervisor = GraspSupervisor(self.belief.geo.block_size)
        self._start_requested = cfg.auto_start
        self._stop_requested = False
        self._checked_fingers = False
        self._started_at: float | None = None
        self._now = 0.0
        self._out = Outputs()
        #: the camera as the node knows it, to look on the way (None: from the look pose)
        self.view: View | None = None
        #: what a state does on a tick with no script playing (idle: before the arm moves)
        self._at_rest: dict[State, Callable[[], Decision | None]] = {
            State.IDLE: self._idle,
            State.OBSERVING: lambda: observe.await_detection(
                self.camera, self.belief, cfg, self.report, self._now),
            State.REPLANNING: lambda: replan.await_plan(
                self.belief, self.planner, cfg, self.report, self._now),
        }
        #: who decides what each decision leads to
        self._handlers: dict[type, Callable[[Any], Decision | None]] = {
            Observe: lambda d: observe.observe(d, self.camera, self.belief, cfg, self._here),
            LookOnTheWay: lambda d: observe.look_on_the_way(
                self.camera, self.belief, cfg, self.view, self._here, self._now, self.report,
                self.inbox.arm_joints),
            LookHere: lambda d: observe.look_here(d, self.camera, self._now),
            NextAction: lambda d: act.next_action(self.belief, cfg, self.report),
            StartPlan: lambda d: replan.start_plan(d, self.belief, self.planner, self.tries, cfg,
                                                   self.report),
            VerifyGoal: lambda d: observe.verify_goal(self.belief, cfg, self.report),
            Replan: lambda d: replan.replan(d, self.belief, self.planner, cfg, self.report,
                                            self._now),
            Finish: lambda d: replan.finish(d, self.report),
            Stop: lambda d: stop.stop_safely(d, self.belief, self.supervisor, cfg, self.report,
                                             self._here, self.inbox),
        }
        #: what the end of a script leads to
        self._on_end: dict[type, Callable[[Any], Decision | None]] = {
            TakeFrame: lambda then: self.camera.trigger(self._now),
            ActionDone: lambda then: act.action_done(self.belief, cfg, self.report, self.tries,
                                                     self._stop_requested),
            JudgeOnArrival: lambda then: self._judge_arrived(),
            Parked: lambda then: None,
            Recovered: lambda then: recover.recovered(then, self.belief, self.tries,
                                                      self._stop_requested),
            Stopped: lambda then: stop.stopped(then, self.belief, self.report),
        }

    # --- inputs (ExecutorInputs) --------------------------------------------------------------
    def on_tcp(self, pose: ToolPose, stamp_s: float | None = None) -> None:
        self.inbox.on_tcp(pose, stamp_s)

    def on_arm_joints(self, q: Sequence[float], stamp_s: float | None = None) -> None:
        self.inbox.on_arm_joints(q, stamp_s)

    def on_finger_gap(self, gap: float, stamp_s: float | None = None) -> None:
        self.inbox.on_finger_gap(gap, stamp_s)

    def on_gripper(self, reading: GripperStatus) -> None:
        self.inbox.on_gripper(reading)

    def on_gripper_command_resent(self) -> None:
        """The fingers' last command went again (to a gripper node that came back): reports
        that do not echo it yet are in transit, not a stray command."""
        if self.supervisor.commanded is not None:
            self.supervisor.reassert(self._now)

    def on_arm_status(self, status: ArmStatus) -> None:
        """Handled by the next tick."""
        if self.guard.on_arm_status(status):
            self.report.count("protective_stops")

    def on_arm_lost(self, why: str | None) -> None:
        self.guard.on_arm_lost(why)  # ArmWatch's word, handled by the next tick

    def on_calibration(self, checked: bool | None) -> None:
        """The detector's word on its calibration: checked against the arm's placements
        recently (True: no camera check needed), or they disagree (False: a check before the
        next plan's first action); None says neither."""
        if checked is not None and self.cfg.camera_check:
            self.belief.camera_checked = checked

    def on_frame_taken(self, stamp_ns: int) -> None:
        if self.state is State.OBSERVING:
            self.camera.on_frame_taken(stamp_ns)

    def on_detection(self, detection: BlockSet) -> None:
        if self.state is not State.OBSERVING or not self.camera.accepts(detection):
            return
        count_detection(self.camera, detection.stamp_ns, self._now, self.report)
        if self.player.busy:  # moving on towards the next block: judged on arrival
            self.camera.arrived = detection
            return
        self._decide(self._judge_frame(detection))

    def on_plan(self, plan: Plan) -> None:
        current = self.belief.plan
        if current is not None and plan.plan_id and plan.plan_id == current.plan_id:
            return  # the same latched plan again
        if plan.plan_id in self.planner.rejected:
            return
        if self.state in PLANS_WAIT_IN:
            self.planner.pending = plan  # finish what the arm is doing first
            return
        if self.state is State.REPLANNING:
            self._decide(StartPlan(plan))
            return
        replan.adopt(plan, self.belief, self.planner, self.tries, self.report)
        if self.state in (State.DONE, State.FAILED):
            self.planner.replans = 0
            self._decide(Enter(State.IDLE))

    def on_planner_waiting(self, for_detection: bool, why: str = "") -> None:
        """A planner waiting for a frame (started after the last idle look, or restarted
        while a correcting plan is awaited) gets looks often (``replan.await_plan``)."""
        self.planner.hear(for_detection, why)

    def on_planner_failed(self, reason: str) -> None:
        """No plan for our replan request: what is left may be beyond the planner's reach
        (a block a degree off in the middle of a dense grid can be neither grasped nor
        pushed), and blocks within the acceptance tolerance of their goal then end the run."""
        if self.state is not State.REPLANNING:
            return
        accepted = replan.accept_residual(self.belief, self.cfg, self.report,
                                          f"the planner found no correction ({reason})")
        self._decide(accepted or Replan(f"the planner found no plan: {reason}"))

    def request_start(self) -> str:
        self._start_requested, self._stop_requested = True, False
        if self.state is State.STOPPED:
            self._decide(Enter(State.IDLE))
        return "starting" if self.belief.plan is not None else "waiting for a plan"

    def request_stop(self) -> str:
        self._stop_requested, self._start_requested = True, False
        if self.state in (State.RUNNING, State.OBSERVING, State.REPLANNING, State.RECOVERING):
            self._decide(Stop("stop requested", failed=False))
        elif self.state is State.IDLE:
            self._decide(Enter(State.STOPPED))
        return "stopping"

    # --- the loop -------------------------------------------------------------------------------
    def tick(self, now: float) -> Outputs:
        self._out = Outputs()
        self._now = now
        if self.inbox.tcp is None:
            return self._out  # the arm has not reported yet: nothing safe to stream
        if self._started_at is None and self.state is State.RUNNING:
            self._started_at = now
        if self.state is State.IDLE and not self.player.busy:
            self._decide(self._at_rest[State.IDLE]())  # the park it starts streams at once
        if self.state is State.OBSERVING:
            observe.trigger_when_due(self.camera, self.view, self.inbox, self.belief, self.report,
                                     now)
        if self.guard.engaged:
            self._arm_held()
        elif self.player.busy:
            self._play(now)
        elif self.state is not State.IDLE and self.state in self._at_rest:
            self._decide(self._at_rest[self.state]())  # a script it starts streams next tick
        readings = self.inbox.take_readings()
        if readings:  # judged while a script plays; otherwise only the latest counts
            self.supervisor.last = readings[-1]
        if self._started_at is not None:
            self.report.metrics["execution_time_s"] = now - self._started_at
        self.report.ledger.charge(now, activity_of(self.state, self.belief, self.player.step))
        # Requests made by input callbacks (a detection that calls for a replan, say) since the
        # last tick are handed on here: tick() is the only place outputs leave the core.
        self._out.log = self.report.take_log()
        self._out.trigger_camera, self.camera.want_trigger = self.camera.want_trigger, False
        self._out.request_replan, self.planner.want_replan = self.planner.want_replan, False
        return self._out

    def _play(self, now: float) -> None:
        """Stream the script's setpoint; act on its fault (a grasp fault is not one while
        stopping), or on its end."""
        inbox = self.inbox
        tick = self.player.advance(now, inbox.tcp, inbox.tcp_stamp, inbox.take_gaps(),
                                   inbox.gripper_reports)
        out = self._out
        out.setpoint, out.missed, out.gripper = tick.setpoint, tick.missed, tick.gripper
        fault = tick.fault
        if fault is None:
            fault, placement = faults.supervise(
                self.supervisor, self.belief, inbox.take_readings(), self.player.finished_steps,
                tick.gripper, now, self.state is State.RUNNING, self._here)
            if placement is not None:
                out.placement = placement
        if isinstance(fault, GraspFault):
            if self.state is not State.STOPPING:
                self._decide(faults.on_grasp_fault(fault, self.belief, self.supervisor,
                                                   self.tries, self.cfg, self.report, out, now))
                return
        elif fault is not None:
            self._decide(faults.on_step_fault(fault, self.state, self.belief, self.player,
                                              self.supervisor, self.tries, self.cfg,
                                              self.report))
            return
        if tick.done:
            then = self.player.finish()
            self._decide(self._on_end[type(then)](then))

    def _arm_held(self) -> None:
        """Held: stream nothing (a protective stop: ask for the unlock); free: go on from here."""
        if self.guard.reason is not None:
            self.guard.while_held(self._now, self.report, self._out)
            return
        protective, why = self.guard.protective, self.guard.take_cleared()
        self.player.commanded = self.inbox.tcp  # the arm stands here: the next script starts there
        if self.player.busy:  # else nothing was moving (a hand pressed on the tool): carry on
            self._decide(faults.after_arm_hold(
                why, protective, self.state, self.belief, self.player, self.tries,
                self.camera.purpose, self.inbox.tcp, self.cfg, self.report))

    def _decide(self, decision: Decision | None) -> None:
        """Follow ``decision`` through the handlers to the next state and script."""
        while decision is not None and not isinstance(decision, Enter | Halt):
            decision = self._handlers[type(decision)](decision)
        if decision is None:
            return
        self._enter(decision.state)
        if isinstance(decision, Halt):
            self.player.drop()
        elif decision.script is not None:
            self.player.start(decision.script, self._now, self.inbox.tcp)

    def _enter(self, state: State) -> None:
        """Change state, as ``TRANSITIONS`` allows (anything else is a bug: stop safely)."""
        if state is not self.state and state not in TRANSITIONS[self.state]:
            reason = f"internal error: no transition from {self.state.value} to {state.value}"
            self.report.log(reason)
            self.report.last_error = reason
            state = State.STOPPING if self.state is not State.STOPPING else State.FAILED
        self.state = state

    @property
    def _here(self) -> ToolPose | None:
        """Where the tool is meant to be: the last setpoint, or the measured TCP before one."""
        return self.player.commanded or self.inbox.tcp

    # --- idle, and frames ------------------------------------------------------------------------
    def _idle(self) -> Decision | None:
        """Start a run with a plan; set down a block found in the fingers with none going;
        without a plan (or with the planner waiting for a frame), look now and then."""
        b = self.belief
        if b.plan is not None and self._start_requested:
            if not self._checked_fingers:  # start (or resume) with empty fingers
                self._checked_fingers = True
                if b.held is None and self._fingers_hold_something():
                    self.report.log(f"the fingers hold something ({self._gap_mm}): parking "
                                    "with it, then looking which block it is")
                    b.held = Held(None)
            return Observe(Purpose.RESUME if b.index > 0 else Purpose.START)
        if b.held is None and b.scene is not None and self._fingers_hold_something():
            # an executor restarted mid-carry: take it beside the workspace (out of view at
            # the park pose, it would stay there), see which block is missing, set it down
            self.report.log(f"the fingers hold something ({self._gap_mm}) and no run is "
                            "going: looking which block it is, to set it down")
            b.held = Held(None)
            return Observe(Purpose.IDLE, near=True)
        if b.plan is None or self.planner.wants_frame:
            parked = (self.player.commanded is not None
                      and self.player.commanded.distance_to(self.cfg.park) <= 1e-6)
            return observe.look_while_idle(self.camera, self.cfg, parked,
                                           self._fingers_hold_something(),
                                           self.planner.wants_frame, self._now)
        return None

    @property
    def _gap_mm(self) -> str:
        return f"{self.inbox.finger_gap * 1e3:.1f} mm apart"

    def _fingers_hold_something(self) -> bool:
        if self.supervisor.last is not None:
            return self.supervisor.holds_something()
        return holds_block(self.inbox.finger_gap, self.belief.geo.block_size)

    def _judge_frame(self, detection: BlockSet) -> Decision | None:
        """A frame taken for ``camera.purpose``: deal with a held, outside or overlapping
        block first, then judge the world for that purpose."""
        b, camera = self.belief, self.camera
        b.perceived = {block.id: block.pose for block in detection.blocks}
        b.unverified -= set(b.perceived)
        if camera.on_the_way:
            covered = observe.covered_on_the_way(camera, b, detection, self.report)
            if covered is not None:
                return covered
        if b.plan is None:
            return Enter(State.IDLE)
        if b.held is not None:  # something in the fingers: put it down first
            return recover.held_block(b, camera.purpose, self.cfg, self.report, self._here)
        if b.scene is not None:
            fix = (recover.bring_in(b, self.tries, self.cfg, self.report, camera.purpose)
                   or recover.set_apart(b, self.tries, self.cfg, self.report, camera.purpose))
            if fix is not None:
                return fix
        if camera.purpose is Purpose.IDLE:  # a block found in the fingers is down: idle again
            b.expected = dict(b.perceived)
            if self.planner.pending is not None:
                replan.adopt(self.planner.pending, b, self.planner, self.tries, self.report)
            return Enter(State.IDLE)
        if camera.purpose is Purpose.START:
            return StartPlan()
        return observe.judge_world(b, camera, self.tries, self.cfg, self.report,
                                   self.planner.pending)

    def _judge_arrived(self) -> Decision | None:
        """Above the next block: judge the detection that came while the arm moved (none yet:
        wait for it at rest; on the way, the frame is taken now if its moment has not come)."""
        camera = self.camera
        arrived, camera.arrived = camera.arrived, None
        if arrived is not None:
            return self._judge_frame(arrived)
        camera.due(self._now, self.inbox.tcp, force=True)  # not passed on the way: now
        if camera.on_the_way and camera.trigger_ns is None:  # no frame was needed
            return observe.go_on(self.planner.pending)
        return None

    # --- status ---------------------------------------------------------------------------------
    def status(self) -> ExecutorStatus:
        return executor_status(self.state, self.belief, self.report, self.planner.replans)

    @property
    def plan(self) -> Plan | None:
        return self.belief.plan
