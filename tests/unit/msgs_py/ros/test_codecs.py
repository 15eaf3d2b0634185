"""Codecs to and from densepack_interfaces: every record round-trips, malformed input is refused.

Needs the generated package (``pip install ros_ws/src/densepack_interfaces``, which the
README's commands do); no rclpy.init(), no DDS. Round trips also go through CDR bytes
(``rclpy.serialization``), as a message on the wire does.
"""

from __future__ import annotations

import math
import re

import pytest
from densepack_interfaces.action import Rearrange
from densepack_interfaces.msg import (
    BlockPoseArray,
    GoalSpec,
    Metric,
    PlanAction,
)
from densepack_interfaces.msg import (
    ExecutorStatus as ExecutorStatusMsg,
)
from densepack_interfaces.msg import GripperStatus as GripperStatusMsg
from densepack_interfaces.msg import (
    PlannerStatus as PlannerStatusMsg,
)
from densepack_interfaces.msg import SimEvent as SimEventMsg
from densepack_interfaces.msg import SimFault as SimFaultMsg
from densepack_interfaces.srv import PlanScene
from hypothesis import given
from hypothesis import strategies as st
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rclpy.serialization import deserialize_message, serialize_message

from msgs_py import (
    EXECUTOR_STATES,
    PLANNER_STATES,
    BlockPose,
    BlockSet,
    ExecutorStatus,
    Goal,
    GoalSlot,
    GridSpec,
    MessageError,
    PickPlace,
    Plan,
    PlannerStatus,
    Pose2D,
    Push,
    Scene,
    Workspace,
)
from msgs_py import ros as msg_codecs
from msgs_py.sim import ROBOT_PARTS, SIM_EVENT_TYPES, Disturbance, SimEvent, SimEvents
from msgs_py.status import ARM_STATES, GRIPPER_OBJECT_STATES, ArmStatus, GripperStatus
from msgs_py.tasks import (
    PLAN_ERRORS,
    REARRANGE_OUTCOMES,
    BlockError,
    PlanReply,
    PlanRequest,
    RearrangeFeedback,
    RearrangeResult,
)

S = 0.0508
WS = Workspace(0.45, 0.95, -0.35, 0.35)


def wire(msg):
    """The message after a trip through CDR bytes."""
    return deserialize_message(serialize_message(msg), type(msg))


def roundtrip(obj, encode, decode):
    msg = wire(encode(obj))
    back = decode(msg)
    assert back == obj
    assert encode(back) == msg  # and the message form is canonical
    return msg


# --- strategies -------------------------------------------------------------------------------
ids = st.integers(0, 2**31 - 1)
yaws = st.floats(-math.pi, math.pi, allow_nan=False).map(lambda t: Pose2D(0, 0, t).theta)
coords = st.floats(-5, 5, allow_nan=False, allow_infinity=False)
# ROS strings are UTF-8 C strings: no NUL, no lone surrogate (both refused on encode, see
# test_strings_ros_cannot_carry_are_refused_on_encode)
chars = st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00")
texts = st.text(chars, max_size=30)
counts = st.integers(0, 2**32 - 1)
metrics = st.dictionaries(texts, st.floats(allow_nan=False, allow_infinity=False), max_size=5)


@st.composite
def poses(draw):
    return Pose2D(draw(coords), draw(coords), draw(yaws))


@st.composite
def lattice_poses(draw, n, x0, y0, cols=4):
    """n footprints far enough apart never to overlap, inside WS (x from x0, y from y0)."""
    pitch = S * 1.6  # 81 mm: two rotated cubes 8 mm jittered towards each other still clear
    out = []
    for k in range(n):
        jitter = draw(st.floats(-0.004, 0.004))
        out.append(Pose2D(x0 + (k % cols) * pitch + jitter, y0 + (k // cols) * pitch,
                          draw(yaws)))
    return out


@st.composite
def goals(draw, n_blocks=None, labeled=None):
    labeled = draw(st.booleans()) if labeled is None else labeled
    if draw(st.booleans()):
        rows, cols = draw(st.integers(1, 3)), draw(st.integers(1, 3))
        grid = GridSpec(rows, cols, (0.8, draw(st.floats(0.1, 0.15))), draw(yaws),
                        draw(st.floats(0.0, 0.01)))
        return Goal(grid=grid, labeled=labeled, yaw_exact=draw(st.booleans()))
    n = draw(st.integers(1, 6))
    slot_poses = draw(lattice_poses(n, 0.7, 0.05, cols=3))
    block_ids = draw(st.lists(st.integers(0, 30), min_size=n, max_size=n, unique=True))
    slots = tuple(GoalSlot(p.x, p.y, p.theta, i if labeled else None)
                  for p, i in zip(slot_poses, block_ids, strict=True))
    return Goal(slots=slots, labeled=labeled, yaw_exact=draw(st.booleans()))


@st.composite
def scenes(draw, with_goal=None):
    goal = draw(goals()) if (draw(st.booleans()) if with_goal is None else with_goal) else None
    named = sorted({s.id for s in goal.slots if s.id is not None}) if goal else []
    n_slots = goal.n_slots if goal else 0
    n = draw(st.integers(max(len(named), n_slots, 1), 10))
    extra = draw(st.lists(st.integers(31, 600), min_size=n - len(named),
                          max_size=n - len(named), unique=True))
    block_ids = named + extra
    start = draw(lattice_poses(n, 0.5, -0.3, cols=3))
    blocks = tuple(BlockPose(i, p.x, p.y, p.theta) for i, p in zip(block_ids, start, strict=True))
    return Scene(WS, S, blocks, goal)


@st.composite
def actions(draw):
    block, start = draw(ids), draw(poses())
    if draw(st.booleans()):
        return PickPlace(block, start, draw(poses()), draw(st.sampled_from((0, 1))))
    angle = draw(st.floats(-math.pi, math.pi))
    distance = draw(st.floats(0.001, 0.3))
    end = Pose2D(start.x + math.cos(angle) * distance, start.y + math.sin(angle) * distance,
                 start.theta)
    return Push.between(block, start, end)


scalars = st.one_of(st.none(), st.booleans(), st.integers(-(2**63), 2**63 - 1),
                    st.floats(allow_nan=False, allow_infinity=False), texts)
lists = st.one_of(st.lists(st.booleans(), max_size=4), st.lists(st.integers(-5, 5), max_size=4),
                  st.lists(st.floats(-1e3, 1e3), max_size=4), st.lists(texts, max_size=4))
names = st.text(chars, min_size=1, max_size=20)
params = st.dictionaries(names, st.one_of(scalars, lists), max_size=8)


@st.composite
def plans(draw):
    return Plan(
        actions=tuple(draw(st.lists(actions(), max_size=6))),
        planner=draw(st.sampled_from(("pirs", "pebble_graphs", "assignment_pirs"))),
        params=draw(params),
        seed=draw(st.integers(-(2**63), 2**63 - 1)),
        planning_time_s=draw(st.floats(0, 1e4)),
        cost=draw(st.floats(-1e6, 1e6)),
        plan_id=draw(texts),
        scene=draw(st.one_of(st.none(), scenes(with_goal=True))),
    )


optional_blocks = st.one_of(st.none(), ids)


# --- round trips ------------------------------------------------------------------------------
@given(poses(), ids)
def test_poses_and_block_poses_round_trip_bit_exact(pose, block_id):
    roundtrip(pose, msg_codecs.pose_to_msg, msg_codecs.pose_from_msg)
    roundtrip(BlockPose(block_id, pose.x, pose.y, pose.theta), msg_codecs.block_pose_to_msg,
              msg_codecs.block_pose_from_msg)


@given(poses(), poses(), yaws, ids, st.integers(0, 2**31 * 10**9 - 1), st.booleans(),
       st.booleans())
def test_placements_round_trip(pose, picked, axis, block_id, stamp_ns, squared, pushed):
    from msgs_py.placement import Placement

    roundtrip(Placement(block_id, pose, picked, axis, stamp_ns, squared, pushed),
              msg_codecs.placement_to_msg, msg_codecs.placement_from_msg)


@given(st.sampled_from(["drop", "slip", "miss", "remove_block", "add_block", "camera_noise"]),
       ids, poses(), st.floats(0, 50))
def test_sim_faults_round_trip_and_refuse_what_they_lack(kind, block_id, pose, value):
    from msgs_py.sim import SimFault

    fault = SimFault(kind, block_id if kind in ("remove_block", "add_block") else None,
                     (pose.x, pose.y, pose.theta) if kind == "add_block" else None, value)
    roundtrip(fault, msg_codecs.sim_fault_to_msg, msg_codecs.sim_fault_from_msg)
    with pytest.raises(MessageError, match="kind"):
        msg_codecs.sim_fault_from_msg(SimFaultMsg())


@st.composite
def block_sets(draw):
    block_ids = draw(st.lists(st.integers(0, 586), unique=True, max_size=25))
    n_seen = draw(st.integers(0, len(block_ids)))
    blocks = tuple(BlockPose(i, draw(coords), draw(coords), draw(yaws))
                   for i in block_ids[:n_seen])
    reprojection = {b.id: draw(st.floats(0, 5)) for b in blocks if draw(st.booleans())}
    stamp_ns = draw(st.integers(0, 2**31 * 10**9 - 1))  # builtin_interfaces/Time: int32 s
    return BlockSet(blocks, stamp_ns, draw(st.sampled_from(("world", "cam"))),
                    draw(st.floats(0.01, 0.1)), tuple(block_ids[n_seen:]), reprojection)


@given(block_sets())
def test_block_sets_round_trip(block_set):
    msg = roundtrip(block_set, msg_codecs.block_set_to_msg, msg_codecs.block_set_from_msg)
    assert msg.header.frame_id == block_set.frame_id
    assert len(msg.reprojection_error_px) in (0, len(block_set.blocks))


@given(scenes())
def test_scenes_round_trip(scene):
    msg = roundtrip(scene, msg_codecs.scene_to_msg, msg_codecs.scene_from_msg)
    assert msg.header.frame_id == "world" and msg.has_goal == (scene.goal is not None)


@given(scenes(with_goal=True))
def test_goal_layouts_and_rearrange_goals_round_trip(scene):
    layout = scene.with_blocks(())
    roundtrip(layout, msg_codecs.goal_layout_to_msg, msg_codecs.goal_layout_from_msg)
    roundtrip(layout, msg_codecs.rearrange_goal_to_msg, msg_codecs.rearrange_goal_from_msg)
    roundtrip(scene.workspace, msg_codecs.workspace_to_msg, msg_codecs.workspace_from_msg)
    roundtrip(scene.goal, msg_codecs.goal_to_msg, msg_codecs.goal_from_msg)
    if scene.goal.grid is not None:
        roundtrip(scene.goal.grid, msg_codecs.grid_to_msg, msg_codecs.grid_from_msg)


def test_the_goal_kinds_of_the_design_survive():
    blocks = tuple(BlockPose(i, 0.5 + 0.08 * i, -0.2, 0.0) for i in range(4))
    labeled = Goal(slots=tuple(GoalSlot(0.6 + 0.06 * i, 0.1, 0.0, i) for i in range(4)))
    unlabeled = Goal(slots=tuple(GoalSlot(0.6 + 0.06 * i, 0.1) for i in range(3)), labeled=False)
    retrieval = Goal(slots=(GoalSlot(0.8, 0.25, 0.0, 2),), yaw_exact=True)
    grid = Goal(grid=GridSpec(2, 2, (0.7, 0.1), 0.2, 0.003))
    for goal in (labeled, unlabeled, retrieval, grid):
        scene = Scene(WS, S, blocks, goal)
        roundtrip(scene, msg_codecs.scene_to_msg, msg_codecs.scene_from_msg)
        roundtrip(scene.with_blocks(()), msg_codecs.goal_layout_to_msg,
                  msg_codecs.goal_layout_from_msg)
    msg = msg_codecs.goal_to_msg(unlabeled)
    assert not msg.labeled and {s.block_id for s in msg.slots} == {-1}
    grid_msg = msg_codecs.goal_to_msg(grid)
    assert grid_msg.form == GoalSpec.FORM_GRID and not grid_msg.slots


@given(actions())
def test_actions_round_trip(action):
    msg = roundtrip(action, msg_codecs.action_to_msg, msg_codecs.action_from_msg)
    assert msg.type == (PlanAction.PUSH if isinstance(action, Push) else PlanAction.PICK_PLACE)


@given(plans())
def test_plans_round_trip_with_typed_params(plan):
    msg = roundtrip(plan, msg_codecs.plan_to_msg, msg_codecs.plan_from_msg)
    assert [p.name for p in msg.params] == list(plan.params)


def test_plan_params_keep_their_ros_types():
    plan = Plan((), params={"n_samples": 80, "eps": 0.3, "shortcut": True, "method": "pirs",
                            "unlabeled.push_lengths": [0.5, 1.0], "none": None})
    types = {p.name: p.value.type for p in msg_codecs.plan_to_msg(plan).params}
    assert types == {"n_samples": ParameterType.PARAMETER_INTEGER,
                     "eps": ParameterType.PARAMETER_DOUBLE,
                     "shortcut": ParameterType.PARAMETER_BOOL,
                     "method": ParameterType.PARAMETER_STRING,
                     "unlabeled.push_lengths": ParameterType.PARAMETER_DOUBLE_ARRAY,
                     "none": ParameterType.PARAMETER_NOT_SET}
    back = msg_codecs.plan_from_msg(msg_codecs.plan_to_msg(plan)).params
    assert type(back["n_samples"]) is int and type(back["eps"]) is float


def test_a_real_planner_plan_round_trips():
    from nodes.planner.config import PlannerConfig
    from nodes.planner.unlabeled.config import UnlabeledConfig

    params = {**PlannerConfig().to_params(S), **UnlabeledConfig().to_params()}
    scene = Scene(WS, S, (BlockPose(0, 0.6, 0.0, 0.3),), Goal(slots=(GoalSlot(0.8, 0.1, 0.0, 0),)))
    plan = Plan((PickPlace(0, Pose2D(0.6, 0.0, 0.3), Pose2D(0.8, 0.1, 0.0), 1),),
                "pirs", params, 4, 0.36, 1.2, "cef50f893db6", scene)
    roundtrip(plan, msg_codecs.plan_to_msg, msg_codecs.plan_from_msg)


@given(st.sampled_from(EXECUTOR_STATES), texts, counts, counts, optional_blocks, texts, texts,
       metrics)
def test_executor_status_round_trips(state, plan_id, k, n, block, error, detail, figures):
    status = ExecutorStatus(state, plan_id, k, n, block, error, detail, figures)
    roundtrip(status, msg_codecs.executor_status_to_msg, msg_codecs.executor_status_from_msg)


@given(st.sampled_from(PLANNER_STATES), texts, counts, st.floats(0, 1e4), texts,
       optional_blocks, metrics)
def test_planner_status_round_trips(state, plan_id, n, seconds, error, block, figures):
    status = PlannerStatus(state, plan_id, n, seconds, error, block, figures)
    roundtrip(status, msg_codecs.planner_status_to_msg, msg_codecs.planner_status_from_msg)


def test_status_stamps_are_written():
    msg = msg_codecs.executor_status_to_msg(ExecutorStatus("idle"), stamp_ns=3_000_000_007)
    assert (msg.stamp.sec, msg.stamp.nanosec) == (3, 7)


@given(scenes(with_goal=True), params)
def test_plan_requests_round_trip(scene, overrides):
    roundtrip(PlanRequest(scene, overrides),
              msg_codecs.plan_request_to_msg, msg_codecs.plan_request_from_msg)


@given(plans(), st.sampled_from(PLAN_ERRORS[1:]), optional_blocks, texts, texts)
def test_plan_replies_round_trip(plan, error, block, field, message):
    roundtrip(PlanReply.planned(plan, message),
              msg_codecs.plan_reply_to_msg, msg_codecs.plan_reply_from_msg)
    refusal = PlanReply.refused(error, message, block, field)
    msg = roundtrip(refusal, msg_codecs.plan_reply_to_msg, msg_codecs.plan_reply_from_msg)
    assert not msg.success and msg.plan == msg_codecs.plan_to_msg(Plan(())).__class__()


@given(st.sampled_from(EXECUTOR_STATES), counts, counts, optional_blocks, counts, texts)
def test_rearrange_feedback_round_trips(state, k, n, block, corrections, detail):
    feedback = RearrangeFeedback(state, k, n, block, corrections, detail)
    roundtrip(feedback,
              msg_codecs.rearrange_feedback_to_msg, msg_codecs.rearrange_feedback_from_msg)


@st.composite
def block_errors(draw):
    found = draw(st.booleans())
    if not found:
        return BlockError(draw(ids), 0.0, 0.0, False)
    return BlockError(draw(ids), draw(st.floats(0, 1)), draw(st.floats(0, math.pi)))


@given(st.sampled_from(REARRANGE_OUTCOMES), texts,
       st.lists(block_errors(), max_size=6, unique_by=lambda e: e.block_id), metrics)
def test_rearrange_results_round_trip(outcome, detail, errors, figures):
    result = RearrangeResult(outcome, detail, tuple(errors), figures)
    roundtrip(result, msg_codecs.rearrange_result_to_msg, msg_codecs.rearrange_result_from_msg)


stamps = st.integers(0, (2**31 - 1) * 10**9)


@st.composite
def sim_events(draw):
    kind = draw(st.sampled_from(SIM_EVENT_TYPES))
    time_s, block = draw(st.floats(0, 1e5)), draw(ids)
    if kind == "block_contact":
        return SimEvent(kind, time_s, block, other_block=draw(ids),
                        manipulated=draw(optional_blocks))
    if kind == "unintended_contact":
        return SimEvent(kind, time_s, block, robot=draw(st.sampled_from(ROBOT_PARTS)),
                        manipulated=draw(optional_blocks))
    return SimEvent(kind, time_s, block, reason=draw(st.text(chars, min_size=1, max_size=20)))


@given(st.lists(sim_events(), max_size=6), counts, counts, stamps,
       st.lists(st.integers(0, 2**31 - 1), max_size=4))
def test_sim_events_round_trip_and_keep_the_monitors_form(events, contacts, lost, stamp, raised):
    record = SimEvents(contacts, lost, tuple(events), stamp, tuple(raised))
    roundtrip(record, msg_codecs.sim_events_to_msg, msg_codecs.sim_events_from_msg)
    assert SimEvents.from_summary(record.to_dict(), stamp) == record


node_names = st.lists(st.text(chars, min_size=1, max_size=20), max_size=8, unique=True)


@given(st.floats(0, 0.085), st.floats(0, 0.085), st.sampled_from(GRIPPER_OBJECT_STATES), stamps,
       texts, counts, node_names)
def test_gripper_status_round_trips(gap, requested, state, stamp, holder, refused, named):
    roundtrip(GripperStatus(gap, requested, state, stamp, holder, refused, tuple(named)),
              msg_codecs.gripper_status_to_msg, msg_codecs.gripper_status_from_msg)


@given(st.sampled_from(ARM_STATES), texts, st.floats(0, 1), st.booleans(), st.integers(0, 255),
       st.integers(-128, 127), st.floats(0, 1e5), counts, stamps, texts, counts, node_names)
def test_arm_status_round_trips_with_its_lease(state, reason, slider, program, safety, mode,
                                                stream, rejected, stamp, holder, refused, named):
    roundtrip(ArmStatus(state, reason, slider, program, safety, mode, stream, rejected, stamp,
                        holder, refused, tuple(named)),
              msg_codecs.arm_status_to_msg, msg_codecs.arm_status_from_msg)
    no_stream = wire(msg_codecs.arm_status_to_msg(ArmStatus(state, lease_holder=holder)))
    assert math.isnan(no_stream.stream_time)  # NaN on the wire: no stream
    assert msg_codecs.arm_status_from_msg(no_stream) == ArmStatus(state, lease_holder=holder)


def test_lease_fields_are_checked_both_ways():
    with pytest.raises(MessageError, match="refused_commands"):
        ArmStatus("ready", refused_commands=-1)
    with pytest.raises(MessageError, match="refused_commanders"):
        GripperStatus(0.05, 0.0, "moving", refused_commanders=["/tool"])  # a list: mutable
    with pytest.raises(MessageError) as err:
        msg_codecs.arm_status_to_msg(ArmStatus("ready", refused_commanders=("/a", "/b\x00")))
    assert err.value.field == "refused_commanders[1]"
    with pytest.raises(MessageError) as err:
        msg_codecs.gripper_status_to_msg(GripperStatus(0.05, 0.0, "moving",
                                                       refused_commands=2**32))
    assert err.value.field == "refused_commands"


@given(ids, st.floats(-0.1, 0.1), st.floats(-0.1, 0.1))
def test_disturbances_round_trip(block, dx, dy):
    roundtrip(Disturbance(block, dx, dy),
              msg_codecs.disturbance_to_msg, msg_codecs.disturbance_from_msg)


def test_malformed_sim_messages_are_refused_by_field():
    msg = msg_codecs.sim_events_to_msg(SimEvents(1, 0, (SimEvent("unintended_contact", 2.0, 3,
                                                         robot="finger"),)))
    msg.events[0].type = 9
    refused(msg_codecs.sim_events_from_msg, msg, "events[0].type")
    msg.events[0].type = SimEventMsg.TYPE_BLOCK_LOST  # a lost block has a reason, no robot
    refused(msg_codecs.sim_events_from_msg, msg, "events[0].robot")
    status = msg_codecs.gripper_status_to_msg(GripperStatus(0.05, 0.0, "stopped_closing"))
    status.object = 7
    refused(msg_codecs.gripper_status_from_msg, status, "object")
    status.object, status.gap = GripperStatusMsg.OBJECT_MOVING, math.nan
    refused(msg_codecs.gripper_status_from_msg, status, "gap")
    nudge = msg_codecs.disturbance_to_msg(Disturbance(1, 0.01, 0.0))
    nudge.block = -2
    refused(msg_codecs.disturbance_from_msg, nudge, "block")
    with pytest.raises(MessageError, match=re.escape("events[0]")):
        SimEvents.from_summary({"unintended_contacts": 0, "blocks_lost": 0,
                                "events": [{"t": 1.0, "type": "teleport", "block": 1}]})


def test_dispatch_covers_every_record():
    scene = Scene(WS, S, (BlockPose(0, 0.6, 0.0, 0.3),), Goal(slots=(GoalSlot(0.8, 0.1, 0.0, 0),)))
    records = [Pose2D(1, 2, 0.5), BlockPose(3, 0.1, 0.2), BlockSet((BlockPose(1, 0, 0),)), WS,
               GridSpec(2, 2, (0.7, 0.0)), scene.goal, PickPlace(0, Pose2D(0, 0), Pose2D(1, 1)),
               Push.between(0, Pose2D(0, 0), Pose2D(0.1, 0)), Plan((), scene=scene), scene,
               ExecutorStatus("running"), PlannerStatus("planned"), PlanRequest(scene),
               PlanReply.refused("busy", "planning"), RearrangeFeedback("observing"),
               RearrangeResult("canceled"), BlockError(1, 0.001, 0.01),
               GripperStatus(0.05, 0.0, "stopped_closing", 7, "/executor", 3, ("/tool",)),
               ArmStatus("ready", stream_time=2.5, lease_holder="/executor"),
               Disturbance(2, 0.01, -0.01),
               SimEvent("block_lost", 3.5, 4, reason="tipped over"),
               SimEvents(0, 1, (SimEvent("block_lost", 3.5, 4, reason="tipped over"),), 9, (2,))]
    for record in records:
        assert msg_codecs.from_msg(wire(msg_codecs.to_msg(record))) == record
    with pytest.raises(TypeError):
        msg_codecs.to_msg(object())


def test_every_vocabulary_word_has_a_constant_and_back():
    def constants(cls, prefix):
        return {n for n in dir(type(cls)) if n.startswith(prefix) and not n.endswith("UNKNOWN")}

    assert constants(ExecutorStatusMsg, "STATE_") == {f"STATE_{s.upper()}" for s in EXECUTOR_STATES}
    assert constants(PlannerStatusMsg, "STATE_") == {f"STATE_{s.upper()}" for s in PLANNER_STATES}
    assert constants(Rearrange.Result, "OUTCOME_") == {
        f"OUTCOME_{s.upper()}" for s in REARRANGE_OUTCOMES}
    assert constants(PlanScene.Response, "ERROR_") == {f"ERROR_{s.upper()}" for s in PLAN_ERRORS}
    assert constants(SimEventMsg, "TYPE_") == {f"TYPE_{s.upper()}" for s in SIM_EVENT_TYPES}
    assert constants(GripperStatusMsg, "OBJECT_") == {
        f"OBJECT_{s.upper()}" for s in GRIPPER_OBJECT_STATES}


# --- refusals ---------------------------------------------------------------------------------
def refused(decode, msg, field):
    with pytest.raises(MessageError) as err:
        decode(msg)
    assert err.value.field == field, str(err.value)
    return err.value


def a_scene():
    blocks = (BlockPose(0, 0.55, -0.2, 0.0), BlockPose(1, 0.65, -0.2, 0.0))
    slots = (GoalSlot(0.8, 0.1, 0.0, 0), GoalSlot(0.8, 0.2, 0.0, 1))
    return Scene(WS, S, blocks, Goal(slots=slots))


def test_nan_anywhere_is_refused_by_field():
    msg = msg_codecs.scene_to_msg(a_scene())
    msg.blocks[1].pose.theta = math.nan
    refused(msg_codecs.scene_from_msg, msg, "blocks[1].pose.theta")
    msg = msg_codecs.plan_request_to_msg(PlanRequest(a_scene()))
    msg.scene.goal.slots[0].pose.y = math.inf
    refused(msg_codecs.plan_request_from_msg, msg, "scene.goal.slots[0].pose.y")
    msg = msg_codecs.executor_status_to_msg(ExecutorStatus("running", metrics={"t": 1.0}))
    msg.metrics[0].value = math.nan
    refused(msg_codecs.executor_status_from_msg, msg, "metrics[0].value")
    msg = msg_codecs.plan_to_msg(Plan((), params={"eps": 0.3}))
    msg.params[0].value.double_value = math.nan
    refused(msg_codecs.plan_from_msg, msg, "params[0].value.double_value")
    with pytest.raises(MessageError, match=re.escape("blocks[0].pose.x")):
        msg_codecs.block_set_to_msg(BlockSet((BlockPose(0, math.nan, 0.0),)))


def test_unknown_states_outcomes_and_codes_are_refused():
    msg = msg_codecs.executor_status_to_msg(ExecutorStatus("done"))
    msg.state = 0
    refused(msg_codecs.executor_status_from_msg, msg, "state")
    msg.state = 42
    refused(msg_codecs.executor_status_from_msg, msg, "state")
    msg = msg_codecs.planner_status_to_msg(PlannerStatus("planned"))
    msg.state = PlannerStatusMsg.STATE_UNKNOWN
    refused(msg_codecs.planner_status_from_msg, msg, "state")
    result = msg_codecs.rearrange_result_to_msg(RearrangeResult("succeeded"))
    result.outcome = Rearrange.Result.OUTCOME_UNKNOWN
    refused(msg_codecs.rearrange_result_from_msg, result, "outcome")
    feedback = Rearrange.Feedback(state=77)
    refused(msg_codecs.rearrange_feedback_from_msg, feedback, "state")
    reply = msg_codecs.plan_reply_to_msg(PlanReply.refused("no_plan", "walled in", 3))
    reply.error_code = 99
    refused(msg_codecs.plan_reply_from_msg, reply, "error_code")


def test_bad_action_types_and_mixed_fields_are_refused():
    plan = Plan((PickPlace(0, Pose2D(0.6, 0), Pose2D(0.7, 0)),
                 Push.between(1, Pose2D(0.6, 0.1), Pose2D(0.65, 0.1))))
    msg = msg_codecs.plan_to_msg(plan)
    msg.actions[1].type = 0
    refused(msg_codecs.plan_from_msg, msg, "actions[1].type")
    msg = msg_codecs.plan_to_msg(plan)
    msg.actions[0].grasp = 2
    refused(msg_codecs.plan_from_msg, msg, "actions[0].grasp")
    msg = msg_codecs.plan_to_msg(plan)
    msg.actions[0].distance = 0.1
    refused(msg_codecs.plan_from_msg, msg, "actions[0].distance")
    msg = msg_codecs.plan_to_msg(plan)
    msg.actions[1].grasp = 1
    refused(msg_codecs.plan_from_msg, msg, "actions[1].grasp")
    msg = msg_codecs.plan_to_msg(plan)
    msg.actions[1].to_pose.x += 0.01  # no longer from + direction * distance
    refused(msg_codecs.plan_from_msg, msg, "actions[1].to_pose")
    msg = msg_codecs.plan_to_msg(plan)
    msg.actions[1].to_pose.theta += 0.1
    refused(msg_codecs.plan_from_msg, msg, "actions[1].to_pose.theta")
    msg = msg_codecs.plan_to_msg(plan)
    msg.actions[1].direction_x, msg.actions[1].direction_y = 0.5, 0.5
    refused(msg_codecs.plan_from_msg, msg, "actions[1].direction_x")
    msg = msg_codecs.plan_to_msg(plan)
    msg.actions[0].block = -1
    refused(msg_codecs.plan_from_msg, msg, "actions[0].block")


def test_duplicate_and_unknown_ids_are_refused():
    msg = msg_codecs.scene_to_msg(a_scene())
    msg.blocks[1].id = 0
    refused(msg_codecs.scene_from_msg, msg, "blocks[1].id")
    msg = msg_codecs.scene_to_msg(a_scene())
    msg.goal.slots[1].block_id = 0
    err = refused(msg_codecs.scene_from_msg, msg, "goal.slots[1].block_id")
    assert "goal.slots[0]" in err.reason
    msg = msg_codecs.scene_to_msg(a_scene())
    msg.goal.slots[1].block_id = 9
    refused(msg_codecs.scene_from_msg, msg, "goal.slots[1].block_id")
    msg = msg_codecs.block_set_to_msg(
        BlockSet((BlockPose(4, 0, 0), BlockPose(5, 0.1, 0)), missing=(6,)))
    msg.blocks[1].id = 4
    refused(msg_codecs.block_set_from_msg, msg, "blocks[1].id")
    msg = msg_codecs.block_set_to_msg(BlockSet((BlockPose(4, 0, 0),), missing=(6,)))
    msg.missing_ids = [6, 4]
    refused(msg_codecs.block_set_from_msg, msg, "missing_ids[1]")
    msg.missing_ids = [6, 6]
    refused(msg_codecs.block_set_from_msg, msg, "missing_ids[1]")
    msg.missing_ids = [6]
    msg.occluded_ids = [7, 4]
    refused(msg_codecs.block_set_from_msg, msg, "occluded_ids[1]")
    msg.occluded_ids = [7, 6]
    refused(msg_codecs.block_set_from_msg, msg, "occluded_ids[1]")
    msg.occluded_ids = [7]
    assert msg_codecs.block_set_from_msg(msg).occluded == (7,)
    result = msg_codecs.rearrange_result_to_msg(
        RearrangeResult("succeeded", block_errors=(BlockError(1, 0, 0), BlockError(2, 0, 0))))
    result.block_errors[1].block_id = 1
    refused(msg_codecs.rearrange_result_from_msg, result, "block_errors[1].block_id")
    status = msg_codecs.executor_status_to_msg(
        ExecutorStatus("running", metrics={"a": 1.0, "b": 2.0}))
    status.metrics = [Metric(name="a", value=1.0), Metric(name="a", value=2.0)]
    refused(msg_codecs.executor_status_from_msg, status, "metrics[1].name")
    plan = msg_codecs.plan_to_msg(Plan((), params={"eps": 0.3, "seed": 1}))
    plan.params[1].name = "eps"
    refused(msg_codecs.plan_from_msg, plan, "params[1].name")


def test_scene_rules_name_the_message_field():
    msg = msg_codecs.scene_to_msg(a_scene())
    msg.blocks[1].pose.x = 0.56  # overlaps block 0
    refused(msg_codecs.scene_from_msg, msg, "blocks[1]")
    msg = msg_codecs.goal_layout_to_msg(a_scene().with_blocks(()))
    msg.goal.slots[1].pose.y = 0.12  # overlaps slot 0
    refused(msg_codecs.goal_layout_from_msg, msg, "goal.slots[1]")
    msg = msg_codecs.rearrange_goal_to_msg(a_scene().with_blocks(()))
    msg.layout.goal.slots[0].pose.x = 2.0  # off the workspace
    refused(msg_codecs.rearrange_goal_from_msg, msg, "layout.goal.slots[0]")
    msg = msg_codecs.rearrange_goal_to_msg(a_scene().with_blocks(()))
    msg.layout.workspace.y_max = -0.5
    refused(msg_codecs.rearrange_goal_from_msg, msg, "layout.workspace.y_max")
    msg = msg_codecs.rearrange_goal_to_msg(a_scene().with_blocks(()))
    msg.layout.block_size = 0.0
    refused(msg_codecs.rearrange_goal_from_msg, msg, "layout.block_size")
    msg = msg_codecs.rearrange_goal_to_msg(a_scene().with_blocks(()))
    msg.layout.goal.slots[0].block_id = -1  # labeled goal, slot without a block
    refused(msg_codecs.rearrange_goal_from_msg, msg, "layout.goal.slots[0].block_id")
    msg = msg_codecs.goal_layout_to_msg(a_scene().with_blocks(()))
    msg.header.frame_id = "camera_optical_frame"
    refused(msg_codecs.goal_layout_from_msg, msg, "header.frame_id")
    msg.header.frame_id = ""  # empty reads as world
    assert msg_codecs.goal_layout_from_msg(msg) == a_scene().with_blocks(())


def test_goal_forms_must_be_consistent():
    msg = msg_codecs.goal_to_msg(a_scene().goal)
    msg.form = 0
    refused(msg_codecs.goal_from_msg, msg, "goal.form")
    msg = msg_codecs.goal_to_msg(a_scene().goal)
    msg.grid.rows = 2
    refused(msg_codecs.goal_from_msg, msg, "goal.grid")
    msg = msg_codecs.goal_to_msg(Goal(grid=GridSpec(2, 2, (0.7, 0.0))))
    msg.slots = msg_codecs.goal_to_msg(a_scene().goal).slots
    refused(msg_codecs.goal_from_msg, msg, "goal.slots")
    msg = msg_codecs.goal_to_msg(Goal(grid=GridSpec(2, 2, (0.7, 0.0))))
    msg.grid.cols = 0
    refused(msg_codecs.goal_from_msg, msg, "goal.grid.cols")
    msg = msg_codecs.goal_to_msg(a_scene().goal)
    msg.slots = []
    refused(msg_codecs.goal_from_msg, msg, "goal.slots")
    msg = msg_codecs.scene_to_msg(a_scene().with_goal(None))
    msg.goal.form = GoalSpec.FORM_SLOTS
    refused(msg_codecs.scene_from_msg, msg, "goal")
    request = msg_codecs.plan_request_to_msg(PlanRequest(a_scene()))
    request.scene.has_goal = False
    request.scene.goal = GoalSpec()
    refused(msg_codecs.plan_request_from_msg, request, "scene.has_goal")


def test_detections_check_their_reprojection_errors():
    block_set = BlockSet((BlockPose(1, 0, 0), BlockPose(2, 0.1, 0)), reprojection_px={2: 0.4})
    msg = msg_codecs.block_set_to_msg(block_set)
    assert list(msg.reprojection_error_px) == [BlockPoseArray.UNKNOWN_ERROR, 0.4]
    msg.reprojection_error_px = [0.4]
    refused(msg_codecs.block_set_from_msg, msg, "reprojection_error_px")
    msg.reprojection_error_px = [0.4, -3.0]
    refused(msg_codecs.block_set_from_msg, msg, "reprojection_error_px[1]")
    with pytest.raises(MessageError, match=re.escape("reprojection_px[9]")):
        msg_codecs.block_set_to_msg(BlockSet((BlockPose(1, 0, 0),), reprojection_px={9: 0.1}))


def test_plan_params_that_ros_cannot_hold_are_refused():
    with pytest.raises(MessageError, match=re.escape("params.mixed")):
        msg_codecs.plan_to_msg(Plan((), params={"mixed": [1, 2.5]}))
    with pytest.raises(MessageError, match=re.escape("params.nested")):
        msg_codecs.plan_to_msg(Plan((), params={"nested": [[1.0]]}))
    with pytest.raises(MessageError, match=re.escape("overrides.budget_s")):
        PlanRequest(a_scene(), {"budget_s": math.nan})
    msg = msg_codecs.plan_to_msg(Plan(()))
    msg.params = [Parameter(name="blob", value=ParameterValue(
        type=ParameterType.PARAMETER_BYTE_ARRAY))]
    refused(msg_codecs.plan_from_msg, msg, "params[0].value.type")
    msg.params = [Parameter(name="", value=ParameterValue(type=ParameterType.PARAMETER_BOOL))]
    refused(msg_codecs.plan_from_msg, msg, "params[0].name")


def test_replies_and_results_must_be_consistent():
    reply = msg_codecs.plan_reply_to_msg(PlanReply.planned(Plan(())))
    reply.error_code = PlanScene.Response.ERROR_NO_PLAN
    refused(msg_codecs.plan_reply_from_msg, reply, "success")
    refusal = PlanReply.refused("invalid_scene", "overlap", 3, "scene.blocks[3]")
    reply = msg_codecs.plan_reply_to_msg(refusal)
    reply.plan.plan_id = "stale"
    refused(msg_codecs.plan_reply_from_msg, reply, "plan")
    result = msg_codecs.rearrange_result_to_msg(
        RearrangeResult("failed", block_errors=(BlockError(4, 0.0, 0.0, found=False),)))
    result.block_errors[0].position_error_m = 0.01
    refused(msg_codecs.rearrange_result_from_msg, result, "block_errors[0].position_error_m")
    result.block_errors[0].found, result.block_errors[0].yaw_error_rad = True, -0.1
    refused(msg_codecs.rearrange_result_from_msg, result, "block_errors[0].yaw_error_rad")


def test_values_out_of_the_message_range_are_refused_on_encode():
    with pytest.raises(MessageError, match=re.escape("blocks[0].id")):
        msg_codecs.scene_to_msg(Scene(WS, S, (BlockPose(2**31, 0.6, 0.0),)))
    with pytest.raises(MessageError, match=re.escape("action_index")):
        msg_codecs.rearrange_feedback_to_msg(RearrangeFeedback("running", action_index=2**32))
    with pytest.raises(MessageError, match=re.escape("seed")):
        msg_codecs.plan_to_msg(Plan((), seed=2**63))
    with pytest.raises(MessageError, match=re.escape("blocks")):
        msg_codecs.goal_layout_to_msg(a_scene())


def test_strings_ros_cannot_carry_are_refused_on_encode():
    with pytest.raises(MessageError, match="detail"):
        msg_codecs.executor_status_to_msg(ExecutorStatus("idle", detail="a\x00b"))
    with pytest.raises(MessageError, match="plan_id"):
        msg_codecs.plan_to_msg(Plan((), plan_id="\x00"))
    with pytest.raises(MessageError, match=re.escape("params.names[1]")):
        msg_codecs.plan_to_msg(Plan((), params={"names": ["a", "b\x00"]}))
    with pytest.raises(MessageError, match="last_error"):
        msg_codecs.planner_status_to_msg(PlannerStatus("failed", last_error="\ud800"))
