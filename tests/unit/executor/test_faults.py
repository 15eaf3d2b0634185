"""Faults in mid-motion: grasp supervision, stalled releases, blocked descents, protective stops."""

from __future__ import annotations

import math

import pytest

from msgs_py import Pose2D
from msgs_py.status import ArmStatus, GripperStatus
from nodes.executor import faults
from nodes.executor.belief import Belief
from nodes.executor.core import ExecutorCore
from nodes.executor.decisions import Halt, Observe, Stop
from nodes.executor.player import Player
from nodes.executor.report import Report
from nodes.executor.states import Purpose, State, Tries
from nodes.executor.steps import StepFault, StepFaultKind
from nodes.executor.supervision import (
    COMMAND_IN_TRANSIT_S,
    PREVIOUS_IN_TRANSIT_S,
    FaultKind,
    GraspSupervisor,
)
from tests.unit.executor.world import (
    CFG,
    DT,
    GOAL,
    START,
    WS,
    Gripper,
    StallingGripper,
    World,
    step_is,
    supervised_run_at,
    two_action_plan,
)


def test_a_grip_on_nothing_is_noticed_looked_at_and_replanned():
    """A hand moved block 1 away just before the fingers closed: a miss. The arm stops, lets
    go, looks, and the planner gets the world as it is now."""
    core = ExecutorCore(CFG)
    world = World(core, START)
    gripper = Gripper(world)
    moved = Pose2D(0.60, -0.25, 0.3)
    core.on_plan(two_action_plan())
    world.run(lambda: core.state is State.RUNNING)
    world.blocks[1] = moved  # knocked away while the arm approaches
    world.on_replan = lambda: None
    world.run(lambda: core.state is State.REPLANNING)
    assert core.report.metrics["faults_missed"] == 1
    assert any("grasp missed" in line for line in world.logs)
    assert "block 1 off by" in core.report.detail
    assert gripper.holding is None and core.belief.held is None


def test_a_block_dropped_in_the_carry_is_noticed_at_once_and_the_arm_stops():
    core = ExecutorCore(CFG)
    world = World(core, START)
    gripper = Gripper(world)
    core.on_plan(two_action_plan())
    world.run(lambda: step_is(core, "carry"))
    carrying = world.setpoints[-1][2]
    gripper.drop()
    world.on_replan = lambda: None
    world.run(lambda: core.state is State.RECOVERING)
    assert core.report.metrics["faults_dropped"] == 1
    # noticed within a tick or two: the arm had not gone on more than a few centimetres
    assert world.setpoints[-1][2].distance_to(carrying) < 0.05
    world.run(lambda: core.state is State.REPLANNING)
    assert "block 1" in core.report.detail


def test_a_stray_close_while_approaching_is_undone_and_the_action_tried_again():
    core = ExecutorCore(CFG)
    world = World(core, START)
    gripper = Gripper(world)
    core.on_plan(two_action_plan())
    world.run(lambda: step_is(core, "travel above"))
    gripper.command(0.0)  # another program closes the gripper
    world.run(lambda: core.report.metrics["faults"] >= 1)
    assert core.report.metrics["faults_misfire"] == 1
    world.run(lambda: core.state is State.DONE)
    assert world.replan_requests == 0  # nothing had moved: the same action again
    assert world.blocks[1].distance_to(GOAL[1]) < 1e-3


def test_a_release_that_stalls_is_gripped_again_and_let_go():
    """The fingers stay on the block after a release: grip it again where it stands, open
    again, go on. Before, the run waited 3 s and stopped (then: open and rise, which carried
    the block off when the fingers still held it)."""
    core = ExecutorCore(CFG)
    world = World(core, START)
    StallingGripper(world, freed_by_grip=True)
    core.on_plan(two_action_plan())
    world.run(lambda: core.state in (State.DONE, State.FAILED))
    assert core.state is State.DONE, core.report.last_error
    assert core.report.metrics["faults_not_released"] == 1
    assert any("stopped opening at 50.8 mm" in line and "gripping block 1 again" in line
               for line in world.logs)
    assert world.replan_requests == 0
    assert world.blocks[1].distance_to(GOAL[1]) < 1e-3


def test_a_stray_open_command_while_carrying_drops_the_block_and_is_recovered():
    core = ExecutorCore(CFG)
    world = World(core, START)
    gripper = Gripper(world)
    core.on_plan(two_action_plan())
    world.run(lambda: step_is(core, "carry"))
    gripper.command(0.085)  # another program opens the gripper: the block falls
    world.on_replan = lambda: None
    world.run(lambda: core.state is State.REPLANNING)
    assert core.report.metrics["faults"] >= 1
    assert gripper.holding is None


def test_a_stray_close_while_carrying_is_undone_and_the_carry_goes_on():
    core = ExecutorCore(CFG)
    world = World(core, START)
    gripper = Gripper(world)
    core.on_plan(two_action_plan())
    world.run(lambda: step_is(core, "carry"))
    gripper.command(0.02)  # closes further on the held block: nothing happens to it
    world.run(lambda: core.state is State.DONE)
    assert core.report.metrics["faults_misfire"] == 1 and world.replan_requests == 0
    assert any("still held; command restored" in line for line in world.logs)


def test_a_place_stopped_above_its_spot_backs_up_looks_and_sets_the_block_down_elsewhere():
    core, world = supervised_run_at("carry")
    # block 2 is knocked onto block 1's goal while block 1 is carried: the tool stops 4 cm up
    world.blocks[2] = GOAL[1]
    world.floor = lambda tool: 0.04 if math.hypot(tool.x - GOAL[1].x, tool.y - GOAL[1].y) < 0.03 \
        else 0.0
    world.run(lambda: world.replan_requests > 0 or core.state in (State.FAILED, State.STOPPED))
    assert core.state is State.REPLANNING, world.logs[-5:]
    assert any("something is in the way below" in line for line in world.logs)
    assert core.belief.held is None and core.report.metrics["blocked_descents"] == 1
    # set down where nothing stands, inside the workspace; the replan names the knocked block
    p = world.blocks[1]
    assert math.hypot(p.x - GOAL[1].x, p.y - GOAL[1].y) > 0.05
    assert WS.contains_square(p, 0.0508)
    assert "block 2" in core.report.detail


def test_a_protective_stop_on_the_way_down_is_unlocked_then_the_arm_backs_up_and_goes_on():
    core, world = supervised_run_at("descend")
    # a finger lands on a block knocked there: the arm's controller stops it where it is
    stopped_at = core.inbox.tcp
    core.on_arm_status(ArmStatus("protective_stop", "246 N on the robot"))
    for k in range(3):  # stopped: nothing streamed (it would be refused), one unlock asked
        out = core.tick(world.t_end + (k + 1) * DT)
        assert out.setpoint is None and out.unlock_arm is (k == 0)
    assert "protective stop: 246 N on the robot" in core.report.detail
    core.on_arm_status(ArmStatus("ready"))
    world.t_end += 3 * DT
    sent = len(world.setpoints)
    world.run(lambda: len(world.setpoints) > sent)
    first = world.setpoints[sent][2]
    assert core.state is State.OBSERVING
    assert first.distance_to(stopped_at) < 0.002  # from where the arm stopped, no jump
    assert any("protective stop: 246 N on the robot: something is in the way below" in line
               for line in world.logs)
    world.run(lambda: core.state in (State.DONE, State.FAILED, State.STOPPED))
    assert core.state is State.DONE and core.report.metrics["protective_stops"] == 1


def test_a_protective_stop_not_unlocked_is_asked_again_each_second():
    core = ExecutorCore(CFG)
    world = World(core, START)
    core.on_plan(two_action_plan())
    world.run(lambda: core.state is State.RUNNING)
    core.on_arm_status(ArmStatus("protective_stop", "30 N"))
    asks = [core.tick(world.t_end + k * DT).unlock_arm for k in range(1, 152)]
    assert sum(asks) == 3 and core.state is State.RUNNING


def test_a_held_block_that_stops_the_arm_on_the_table_is_let_go_there():
    core, world = supervised_run_at("lower (last cm)", holding=True)
    # it slid 10 mm down in the fingers: it meets the table 10 mm above the place height
    block = core.belief.held.block
    low = core.inbox.tcp.with_z(CFG.grasp_height + CFG.place_drop + 0.010)
    core.on_tcp(low)
    core.on_arm_status(ArmStatus("protective_stop", "35 N on the robot"))
    core.tick(world.t_end + DT)
    core.on_arm_status(ArmStatus("ready"))
    world.t_end += DT
    world.run(lambda: core.belief.held is None)
    assert any("stands on the table (it slid down in the fingers)" in line for line in world.logs)
    opened = world.setpoints[-1][2]  # where the fingers let go: where the arm stopped
    assert opened.distance_to(low) < 0.002
    # then a look, and the run goes on from what the camera sees (a replan)
    world.run(lambda: world.replan_requests > 0 or core.state in (State.FAILED, State.STOPPED))
    assert core.state is State.REPLANNING, world.logs[-5:]
    assert not any("setting block" in line for line in world.logs)  # not carried elsewhere
    stood = world.blocks[block]
    assert math.hypot(stood.x - opened.x, stood.y - opened.y) < 1e-6


@pytest.mark.parametrize("kind, state, setting_apart, expected", [
    (StepFaultKind.BLOCKED, State.RUNNING, None, Observe(Purpose.RECOVERY, near=True)),
    (StepFaultKind.BLOCKED, State.RECOVERING, 2, Observe(Purpose.RECOVERY, near=True)),
    (StepFaultKind.BLOCKED, State.RECOVERING, None, Stop("why", failed=True)),
    (StepFaultKind.NOT_CONVERGED, State.RUNNING, None, Stop("why", failed=True)),
    (StepFaultKind.REFUSED, State.OBSERVING, None, Stop("why", failed=True)),
    (StepFaultKind.STALLED, State.STOPPING, None, Halt(State.FAILED)),
    (StepFaultKind.GRIPPER_TIMEOUT, State.STOPPING, None, Halt(State.FAILED)),
])
def test_a_step_fault_leads_by_its_kind_and_the_state_to_one_answer(kind, state, setting_apart,
                                                                     expected):
    """A descent stopped above its end backs up and looks (setting blocks apart: the other
    block first); any other fault stops the run, and one while stopping ends it failed."""
    belief, tries, report = Belief(), Tries(setting_apart=setting_apart), Report()
    report.last_error = "an earlier error"
    decision = faults.on_step_fault(StepFault(kind, "why"), state, belief, Player(CFG),
                                    GraspSupervisor(0.0508), tries, CFG, report)
    assert decision == expected
    if isinstance(expected, Halt):
        assert report.last_error == "an earlier error; then why"
    if setting_apart is not None:
        assert tries.apart_blocked == {setting_apart} and tries.setting_apart is None


def test_an_arm_not_started_yet_is_waited_for_without_an_unlock_or_a_stop_counted():
    """The arm node's first status says "stopped" until the robot program runs: the
    executor streams nothing and asks for no unlock; once ready, the plan is run."""
    core = ExecutorCore(CFG)
    world = World(core, START)
    core.on_arm_status(ArmStatus("stopped", "the robot program is not running"))
    core.on_plan(two_action_plan())
    ticks = iter(range(100))  # two seconds of ticks
    world.run(lambda: next(ticks, None) is None)
    assert world.setpoints == [] and "arm held: the robot program is not running" in (
        core.report.detail)
    assert any("waiting until the arm can move" in line for line in world.logs)
    assert not any("unlocking" in line for line in world.logs)
    core.on_arm_status(ArmStatus("ready"))
    world.run(lambda: core.state in (State.DONE, State.FAILED, State.STOPPED))
    assert core.state is State.DONE and core.report.metrics.get("protective_stops", 0) == 0


def test_an_arm_node_lost_mid_descent_holds_the_script_then_backs_up_from_where_it_stands():
    """The arm node killed on the way down (a chaos run): the script must not stream on, or
    the node back chases the setpoints sent meanwhile into the blocks below."""
    core, world = supervised_run_at("descend")
    stopped_at = core.inbox.tcp
    core.on_arm_lost("the arm node is silent (no /arm/tcp_pose for 0.5 s)")
    assert all(core.tick(world.t_end + (k + 1) * DT).setpoint is None for k in range(100))
    assert "the arm node is silent" in core.report.detail
    core.on_arm_status(ArmStatus("ready"))  # the node back says it can move: not enough
    assert core.tick(world.t_end + 101 * DT).setpoint is None
    core.on_arm_lost(None)  # and takes the executor's setpoints again
    world.t_end += 101 * DT
    sent = len(world.setpoints)
    world.run(lambda: len(world.setpoints) > sent)
    assert world.setpoints[sent][2].distance_to(stopped_at) < 0.002  # no jump down the path
    assert any("the arm node is silent" in line and "backing up and looking again" in line
               for line in world.logs)
    world.run(lambda: core.state in (State.DONE, State.FAILED, State.STOPPED))
    assert core.state is State.DONE and core.report.metrics.get("blocked_descents", 0) == 0


def test_a_hold_mid_motion_backs_up_and_looks_without_reading_it_as_contact():
    core, world = supervised_run_at("descend")
    core.on_arm_status(ArmStatus("no_joint_states", "joint states stale for 0.5 s"))
    assert all(core.tick(world.t_end + (k + 1) * DT).setpoint is None for k in range(3))
    core.on_arm_status(ArmStatus("ready"))
    world.t_end += 3 * DT
    world.run(lambda: core.state is State.OBSERVING)
    assert core.report.metrics.get("blocked_descents", 0) == 0
    assert any("arm held: joint states stale for 0.5 s: backing up and looking again" in line
               for line in world.logs)
    world.run(lambda: core.state in (State.DONE, State.FAILED, State.STOPPED))
    assert core.state is State.DONE and core.report.metrics.get("protective_stops", 0) == 0


def test_a_late_echo_of_the_executors_own_command_before_is_no_misfire():
    """The driver echoes a new command late (seen once in a default run): reports stamped
    after the transit allowance that still request the executor's previous opening are in
    transit (for PREVIOUS_IN_TRANSIT_S), not a stray command; any other request is one."""
    def reading(requested: float, at: float) -> GripperStatus:
        return GripperStatus(0.0828, requested, "stopped_opening", round(at * 1e9))
    sup = GraspSupervisor(0.0508)
    sup.commanding(0.0828, 1.0)
    sup.commanding(0.0588, 2.0)
    late = 2.0 + 0.5 * (COMMAND_IN_TRANSIT_S + PREVIOUS_IN_TRANSIT_S)
    assert late > 2.0 + COMMAND_IN_TRANSIT_S
    assert sup.on_reading(reading(0.0828, late)) is None
    assert sup.on_reading(reading(0.0588, late)) is None
    assert sup.on_reading(reading(0.0200, late)).kind is FaultKind.MISFIRE
    stale = 2.0 + PREVIOUS_IN_TRANSIT_S + 0.1
    assert sup.on_reading(reading(0.0828, stale)).kind is FaultKind.MISFIRE
