"""Faults in mid-motion, and what the executor does about each.

A tick's fault is a typed value: a ``GraspFault`` (the fingers are not as the script
expects: ``nodes.executor.supervision``) or a ``StepFault`` (the script cannot go on:
``nodes.executor.steps``). A grasp fault stops the motion by braking along its path, lets
go of what the fingers hold and looks again; a stalled release grips the block again and
opens again; a descent stopped above its end (something below) backs up and looks; any
other step fault stops the run safely. A protective stop of the arm's controller is
unlocked, and the run goes on from where the arm stands, as after a descent stopped by
something below.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from msgs_py.placement import Placement
from msgs_py.status import ArmStatus, GripperStatus
from msgs_py.status import ExecutorState as State
from nodes.executor.belief import Belief
from nodes.executor.config import ExecutorConfig
from nodes.executor.decisions import (
    Decision,
    Enter,
    Halt,
    Observe,
    Recovered,
    Script,
    Stop,
    Stopped,
    Then,
)
from nodes.executor.motion import ToolPose
from nodes.executor.player import Player
from nodes.executor.primitives import park_steps
from nodes.executor.recovery import let_go_steps
from nodes.executor.report import Report
from nodes.executor.states import Held, Outputs, Purpose, Tries
from nodes.executor.steps import Grip, Move, Step, StepFault, StepFaultKind, of_block
from nodes.executor.stop import failed_while_stopping, stop_in_place
from nodes.executor.supervision import Expect, FaultKind, GraspFault, GraspSupervisor

#: Openings that may stall before an action finishes, each tried again after gripping the block
#: again where it stands; one more stops the run there.
MAX_RELEASE_STALLS = 2
#: With nothing held, a stalled opening is tried again after lifting the tool this far (m).
UNLOAD_LIFT_M = 0.003
#: A protective stop not unlocked this long after asking is asked again (s).
UNLOCK_RETRY_S = 1.0
#: A held block that stops the arm with the tool below grasp height + this many block sizes
#: stands on the table (on another block the tool would stand a whole block higher).
ON_THE_TABLE = 0.75


# --- grasp supervision ---------------------------------------------------------------------------
def supervise(supervisor: GraspSupervisor, belief: Belief, readings: Sequence[GripperStatus],
              finished: Sequence[Step], gripper: float | None, now: float, placing: bool,
              tool: ToolPose | None) -> tuple[GraspFault | None, Placement | None]:
    """Tell the supervisor what the script did to the fingers (the ``finished`` steps, the
    ``gripper`` command sent now), judge the readings since the last tick: a fault, and the
    block set down (``placing``: by a plan action, reported for perception to be checked
    against the arm). With no gripper status (a gripper that reports only its finger
    joints), a grip is taken to hold its block and a release to let go."""
    supervisor.block_size = belief.geo.block_size
    fault, placement = None, None
    for reading in readings:  # taken before this tick's command
        if fault is None and (supervisor.expect is not Expect.NOTHING
                              or supervisor.commanded is not None):
            fault = supervisor.on_reading(reading)
        else:
            supervisor.last = reading
    last = supervisor.last
    for step in finished:
        if isinstance(step, Move) and step.pushes and placing:
            placement = pushed(belief, step, now) or placement
        if not isinstance(step, Grip) or not step.wait:
            continue
        if step.holds is not None:
            fault = fault or (None if last is None else supervisor.after_grip(last))
            if fault is None:
                supervisor.expect_hold(step.holds)
                belief.held = Held(step.holds, belief.picked_from, step.squares)
        else:  # a release, or the fingers opened before a descent
            if last is not None and belief.held is not None:
                fault = fault or supervisor.after_release(last)
            if fault is None:
                supervisor.expect_open()
                placement = released(belief, now, placing, tool) or placement
    if gripper is not None:
        supervisor.commanding(gripper, now)
    return fault, placement


def pushed(belief: Belief, stroke: Move, now: float) -> Placement | None:
    """A push's stroke ended: its block stands where the plan pushes it (reported so that
    the detector judges whether the arm covers it there, not where it stood before)."""
    block = stroke.block
    where = None if block is None else belief.expected.get(block)
    if block is None or where is None:
        return None
    before = belief.picked_from or where
    return Placement(block, where, before, stroke.target.yaw, round(now * 1e9), pushed=True)


def released(belief: Belief, now: float, placing: bool, tool: ToolPose | None
             ) -> Placement | None:
    """The fingers let go of a held block: it stands where the arm set it down. Only a plan
    action's (or the camera check's) release is reported: a recovery picks blocks knocked,
    tilted or leaning on another, whose perceived pick pose says nothing about the camera."""
    held, placement = belief.held, None
    if held is not None and held.block is not None and held.picked_from is not None and placing:
        where = belief.expected.get(held.block)
        if where is not None and tool is not None:
            placement = Placement(held.block, where, held.picked_from, tool.yaw,
                                  round(now * 1e9), held.squared)
    belief.held = None
    return placement


def on_grasp_fault(fault: GraspFault, belief: Belief, supervisor: GraspSupervisor,
                   tries: Tries, cfg: ExecutorConfig, report: Report, out: Outputs,
                   now: float) -> Decision | None:
    """Stop the motion, let go of whatever the fingers hold, look again (a stray command
    that left a held block held is only undone: None, the script goes on)."""
    report.count_fault(fault.kind)
    if fault.kind is FaultKind.MISFIRE and supervisor.commanded is not None:
        out.gripper = supervisor.commanded  # ours again, at once
        if supervisor.expect is Expect.HOLD and supervisor.holds_block():
            supervisor.reassert(now)
            report.log(f"{fault.describe()}: the block is still held; command restored")
            return None
    report.log(f"{fault.describe()}: stopping, letting go, looking again")
    report.detail = fault.describe()
    block = belief.held.block if belief.held is not None else None
    if fault.kind in (FaultKind.MISSED, FaultKind.MISFIRE):
        tries.grasps += 1
    action = belief.current
    if block is not None:
        belief.expected.pop(block, None)  # it is wherever it fell: the camera will tell
    elif action is not None:
        if fault.holding_something or belief.picked_from is None:
            belief.expected.pop(action.block, None)  # let go of where the fingers were: look
        else:
            belief.expected[action.block] = belief.picked_from  # untouched: still there
    belief.held = None
    supervisor.stop_judging()
    return Enter(State.RECOVERING, Script(let_go_steps(belief.geo, cfg, "recover"),
                                          Recovered(Purpose.RECOVERY), brake=True))


# --- a script that cannot go on ----------------------------------------------------------------
def on_step_fault(fault: StepFault, state: State, belief: Belief, player: Player,
                  supervisor: GraspSupervisor, tries: Tries, cfg: ExecutorConfig,
                  report: Report) -> Decision | None:
    """The script cannot go on: a stalled release is tried again (None: the script goes on),
    a blocked descent backs up and looks, anything else stops the run safely."""
    if fault.kind is StepFaultKind.STALLED and state in (State.RUNNING, State.RECOVERING):
        return on_release_stall(fault.message, belief, player, supervisor, tries, cfg, report)
    if fault.kind is StepFaultKind.BLOCKED and state is State.RUNNING:
        return blocked_descent(fault.message, belief, report)
    if (fault.kind is StepFaultKind.BLOCKED and state is State.RECOVERING
            and tries.setting_apart is not None):
        return blocked_set_apart(fault.message, tries, report)
    if state is State.STOPPING:
        return failed_while_stopping(fault.message, report)
    return Stop(fault.message, failed=True)


def on_release_stall(why: str, belief: Belief, player: Player, supervisor: GraspSupervisor,
                     tries: Tries, cfg: ExecutorConfig, report: Report) -> Decision | None:
    """The fingers stopped opening short of the opening, still pressing on the block they
    had just let go. Seen in the cell and reproduced in the scripted sim: the block turns
    a degree or two about one pad as the fingers part, and the simulated contact then
    presses that pad into it (43 N). Gripping it again where it stands squares it between
    the pads, and the next opening lets go cleanly (the same repro): None, the script goes
    on. Rising with a block the fingers will not let go would carry it off (at 4eb4bf7 it
    ended 0.28 m away): after MAX_RELEASE_STALLS the run stops there."""
    report.count_fault(FaultKind.NOT_RELEASED)
    if tries.release_stalls == 0:
        tries.stall_z = player.nominal.z
    tries.release_stalls += 1
    if tries.release_stalls > MAX_RELEASE_STALLS:
        return stop_in_place(why, belief, player.nominal, tries.stall_z, supervisor, cfg, report)
    held = belief.held.block if belief.held is not None else None
    if held is None:  # nothing to grip: lift off whatever presses and open again
        report.log(f"{why}: lifting {UNLOAD_LIFT_M * 1e3:.0f} mm and opening again")
        up = player.nominal.with_z(player.nominal.z + UNLOAD_LIFT_M)
        player.retry([Move(up, cfg.approach_limits, "unload the fingers")])
        return None
    report.log(f"{why}: gripping block {held} again where it stands and opening again")
    supervisor.stop_judging()
    player.retry([Grip(cfg.grip_command, cfg.gripper_settle_s, f"block {held}: grip again",
                       holds=held, **of_block(held))])
    return None


def blocked_descent(why: str, belief: Belief, report: Report) -> Observe:
    """The tool stopped above where it went down: something stands there (a block knocked
    under it). Back up and look from the look pose, with whatever the fingers hold: a held
    block is then set down at a free spot, and the run goes on from what the camera sees."""
    report.count("blocked_descents")
    report.log(f"{why}: something is in the way below; backing up and looking again")
    _not_moved_yet(belief)
    return Observe(Purpose.RECOVERY, near=True)


def _not_moved_yet(belief: Belief) -> None:
    """Stopped before the block was lifted: it still stands where it was picked from."""
    action = belief.current
    if belief.held is None and action is not None and belief.picked_from is not None:
        belief.expected[action.block] = belief.picked_from


def blocked_set_apart(why: str, tries: Tries, report: Report) -> Observe:
    """Setting overlapping blocks apart, the tool stopped on the way down to one of them:
    the other lies on it. Back up, look, and set the other one apart first."""
    assert tries.setting_apart is not None
    tries.apart_blocked.add(tries.setting_apart)
    report.log(f"{why}: block {tries.setting_apart} lies under another; backing up to set "
               "the other apart first")
    tries.setting_apart = None
    return Observe(Purpose.RECOVERY, near=True)


# --- the arm held ------------------------------------------------------------------------------
@dataclass
class ArmHold:
    """The arm node says the arm cannot move. A protective stop the executor unlocks; any
    other hold (the program stopped, joint states lost, the arm not yet started) it waits
    out. Why the arm is held (while it lasts), why it was (once it can move, until handled),
    and when the unlock was asked for."""

    reason: str | None = None
    protective: bool = False
    cleared: str | None = None
    unlock_asked_at: float | None = None
    lost: bool = False  #: the hold is the arm node's absence (``ArmWatch``), not its status

    @property
    def engaged(self) -> bool:
        """A hold lasts, or one that ended is still to be handled."""
        return self.reason is not None or self.cleared is not None

    def on_arm_status(self, status: ArmStatus) -> bool:
        """The arm can move, or it is held and why; True when a protective stop began."""
        if status.ready or status.state == "paused":  # paused: setpoints are still taken
            if self.reason is not None and not self.lost:
                self.cleared, self.reason = self._described(), None
            return False
        self.lost = False
        began = status.protective_stop and not (self.reason is not None and self.protective)
        if began or self.reason is None:
            self.unlock_asked_at = None
        self.protective = status.protective_stop
        self.reason = status.reason or status.state.replace("_", " ")
        return began

    def on_arm_lost(self, why: str | None) -> None:
        """The arm node is gone or does not take the executor's setpoints yet (``why``), or
        it takes them again (None): held, as for a hold its status names."""
        if why is not None:
            if self.reason is None:
                self.unlock_asked_at = None  # a new hold: said once
            if self.reason is None or self.lost:
                self.protective, self.lost, self.reason = False, True, why
            return
        if self.lost:
            self.cleared, self.reason, self.lost = self._described(), None, False

    def _described(self) -> str:
        return f"protective stop: {self.reason}" if self.protective else (
            f"arm held: {self.reason}")

    def while_held(self, now: float, report: Report, out: Outputs) -> None:
        """Stream nothing (the arm refuses setpoints); for a protective stop, ask for the
        unlock (again every UNLOCK_RETRY_S)."""
        asked = self.unlock_asked_at
        if self.protective and (asked is None or now - asked >= UNLOCK_RETRY_S):
            if asked is None:
                report.log(f"{self._described()}; unlocking the arm")
            out.unlock_arm = True
        elif asked is None:
            report.log(f"{self._described()}; waiting until the arm can move")
        if asked is None or (self.protective and now - asked >= UNLOCK_RETRY_S):
            self.unlock_asked_at = now
        report.detail = self._described()

    def take_cleared(self) -> str:
        """The arm can move again: why it had been held, now handled."""
        why, self.cleared = self.cleared or "", None
        return why


def held_on_the_table(state: State, belief: Belief, tcp: ToolPose | None,
                      cfg: ExecutorConfig) -> bool:
    """A held block stopped the arm this low: it stands on the table. (On another block
    the tool would stand a block higher: above grasp height + a block.)"""
    return (belief.held is not None and tcp is not None
            and state in (State.RUNNING, State.RECOVERING)
            and tcp.z < cfg.grasp_height + ON_THE_TABLE * belief.geo.block_size)


def let_go_on_the_table(why: str, state: State, then: Then | None, belief: Belief,
                        cfg: ExecutorConfig, report: Report) -> Enter:
    """The held block met the table above its place height: it slid down in the fingers
    (a slip). Pressing on would push it up through the pads; another spot would be met
    the same way. It stands on the table here: let go, rise, look, go on from there (a
    recovery under way goes on to judge what it was to judge)."""
    assert belief.held is not None
    block = belief.held.block
    report.log(f"{why}: block {block} stands on the table (it slid down in the fingers); "
               "letting go here and looking again")
    if block is not None:
        belief.expected.pop(block, None)  # where it stands now: the camera will tell
    look_for = Purpose.RECOVERY
    if state is not State.RUNNING and isinstance(then, Recovered):
        look_for = then.look_for
    return Enter(State.RECOVERING, Script(let_go_steps(belief.geo, cfg, "recover"),
                                          Recovered(look_for)))


def after_arm_hold(why: str, protective: bool, state: State, belief: Belief, player: Player,
                   tries: Tries, look_for: Purpose, tcp: ToolPose | None, cfg: ExecutorConfig,
                   report: Report) -> Decision:
    """The arm can move again, with a script under way: drop it and go on from where the arm
    stands. A protective stop is read as contact, as a descent stopped by something below:
    back up, look, and plan from what the camera sees (a held block that stopped the arm on
    the table is let go there). Any other hold says nothing of what is below: back up and
    look. A stop under way parks. With no run going (a park, or a block found in the fingers
    carried out to be looked at), the script is dropped and the idle loop decides afresh:
    a look for a recovery would judge a plan never started."""
    if state is State.IDLE:
        report.log(f"{why}: deciding again from where the arm stands")
        return Halt(State.IDLE)
    if state is State.STOPPING:
        in_place = isinstance(player.then, Stopped) and player.then.in_place
        return Enter(State.STOPPING, Script(park_steps(cfg), Stopped(in_place)))
    if protective:
        if held_on_the_table(state, belief, tcp, cfg):
            return let_go_on_the_table(why, state, player.then, belief, cfg, report)
        if state is State.RECOVERING and tries.setting_apart is not None:
            return blocked_set_apart(why, tries, report)
        if state is State.RUNNING:
            return blocked_descent(why, belief, report)
    elif state is State.RUNNING:
        _not_moved_yet(belief)
    report.log(f"{why}: backing up and looking again")
    return Observe(look_for if state is State.OBSERVING else Purpose.RECOVERY, near=True)
