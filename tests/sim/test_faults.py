"""Faults a real cell meets, made physically in the sim: what the gripper then reports."""

from __future__ import annotations

import math

import numpy as np
import pytest

from msgs_py import BlockPose, PickPlace, Pose2D
from msgs_py.cell import GripperGeometry
from nodes.executor.config import ExecutorConfig
from nodes.executor.primitives import action_steps, release_opening

from .arm_loop import play

CFG = ExecutorConfig()
GEO = GripperGeometry()
START, GOAL = Pose2D(0.60, -0.10, 0.2), Pose2D(0.80, 0.15, 0.0)


def carry_with(world_factory, fault, watch=None, **config):
    """Pick block 0 at START, carry it to GOAL; ``fault(world)`` when the carry begins, and
    ``watch(world)`` on every tick of the carry. Returns the world and the gripper reports
    (time, gap, requested, object) of the carry."""
    world = world_factory([(0, START.x, START.y, START.theta)], **config)
    world.step(24)
    reports, carrying = [], []

    def on_label(w, label):
        if label.endswith(": carry"):
            carrying.append(w.time_s)
            fault(w)

    def on_tick(w):
        if carrying:
            reports.append((w.time_s, *w.fingers.status()))
            if watch is not None:
                watch(w)

    play(world, action_steps(PickPlace(0, START, GOAL, 0), START, GEO, CFG), CFG, on_label,
         on_tick)
    return world, reports, carrying[0]


def test_without_a_fault_the_block_is_held_through_the_carry_and_placed(world_factory):
    world, reports, _ = carry_with(world_factory, lambda w: None)
    carry = [r for r in reports if r[3] != 0.0688]  # until the release command
    assert all(obj == 2 for _, _, _, obj in reports[:20])  # stopped on an object, closing
    end = world.block_poses()[0]
    assert end.pose.distance_to(GOAL) < 0.001 and carry


def test_finger_contacts_name_the_held_block_and_an_empty_gripper_says_so(world_factory):
    """The sim logs this when fingers stop opening: it must say what they touch."""
    said = []
    world, _, _ = carry_with(world_factory, lambda w: said.append(w.fingers.contacts()))
    for link in world.finger_joints:  # both fingers touch it
        assert f"finger link {link} - block 0 (link -1) " in said[0]
    assert world.fingers.contacts() == "no finger contact"  # released, risen


def test_a_drop_shows_in_the_gripper_report_within_a_tenth_of_a_second(world_factory):
    world, reports, t0 = carry_with(world_factory, lambda w: w.fingers.slippery_pads(0.0, 0.4))
    empty = next(t for t, gap, _, obj in reports if obj != 2 or gap < 0.0508 - 0.002)
    assert empty - t0 <= 0.1
    assert world.block_poses()[0].pose.distance_to(GOAL) > 0.1  # it fell on the way


def test_a_slip_leaves_the_block_in_the_fingers(world_factory):
    below_tcp = []  # how far the block's centre hangs below the TCP (m)

    def watch(w):
        below_tcp.append(w.tcp_pose()[0][2] - w.block_pose_3d(0)[0][2])

    # (the block then hangs 13 mm lower and meets the table early as it is lowered: a
    # protective stop, which the executor answers as in test_core; off here, to carry on)
    _, reports, _ = carry_with(world_factory, lambda w: w.fingers.slippery_pads(0.0, 0.05), watch,
                               tool_force_limit=0.0)
    carry = reports[:25]
    # the block slides down between the pads (more than a centimetre), but the fingers never
    # leave its width, and it is held again
    assert below_tcp[24] - below_tcp[0] > 0.01
    assert all(abs(gap - 0.0508) < 0.002 for _, gap, _, _ in carry)
    assert carry[-1][3] == 2


def test_a_block_taken_away_and_one_put_in(world_factory):
    world = world_factory([(0, 0.6, 0.0, 0.0), (1, 0.8, 0.0, 0.0)])
    world.remove_block(1)
    world.add_block(BlockPose(7, 0.7, 0.2, 0.3))
    world.step(48)
    assert sorted(b.id for b in world.block_poses()) == [0, 7]


def test_blocks_differ_from_one_another_seeded(world_factory):
    world = world_factory([(k, 0.5 + 0.06 * k, 0.0, 0.0) for k in range(5)], seed=3)
    again = world_factory([(k, 0.5 + 0.06 * k, 0.0, 0.0) for k in range(5)], seed=3)
    masses = [world.block_variation(k) for k in range(5)]
    assert masses == [again.block_variation(k) for k in range(5)]
    assert len({m for m, _ in masses}) == 5 and len({f for _, f in masses}) == 5


def test_a_gripper_command_takes_effect_after_its_latency(world_factory):
    world = world_factory([], gripper_latency_s=0.05)
    world.set_gripper(0.03)
    assert world.fingers.status()[1] == 0.085  # not there yet
    world.step(round(0.06 * 240))
    assert world.fingers.status()[1] == pytest.approx(0.03)


def test_armed_faults_strike_at_their_moment(world_factory):
    """Armed drop: the block falls once lifted. Armed miss: the open fingers come down on
    nothing (the block was knocked aside) and close to zero."""
    world, reports, _ = carry_with(world_factory, lambda w: None)
    assert world.hand.armed is None
    world, reports, _ = carry_with(world_factory, lambda w: w.hand.arm_fault("drop"))
    assert any(gap < 0.0508 - 0.002 for _, gap, _, _ in reports[:10])
    assert any(e["type"] == "fault" and e["reason"] == "drop" for e in world.monitor.events)

    world = world_factory([(0, START.x, START.y, START.theta)])
    world.step(24)
    world.hand.arm_fault("miss")
    closed = []

    def after_grip(w, label):
        if label.endswith(": lift"):
            closed.append(w.fingers.status())

    play(world, action_steps(PickPlace(0, START, GOAL, 0), START, GEO, CFG), CFG, after_grip)
    gap, _, obj = closed[0]
    assert gap < 0.005 and obj == 3  # at the requested position: nothing in the fingers
    assert world.block_poses()[0].pose.distance_to(START) > 0.03



def test_a_missed_grasp_knocks_the_block_to_the_side_with_room_not_into_its_neighbour(
        world_factory):
    # grasp 0 closes along the block's x (yaw 0.2): the knock goes across it, along
    # +-(-sin, cos); a neighbour stands 60 mm away on one side, then on the other
    perp = (-math.sin(START.theta), math.cos(START.theta))
    for side in (1.0, -1.0):
        neighbour = (1, START.x + side * 0.060 * perp[0], START.y + side * 0.060 * perp[1],
                     START.theta)
        world = world_factory([(0, START.x, START.y, START.theta), neighbour])
        world.step(24)
        world.hand.arm_fault("miss")
        play(world, action_steps(PickPlace(0, START, GOAL, 0), START, GEO, CFG), CFG,
             lambda w, label: None)
        moved = {b.id: b.pose for b in world.block_poses()}[0]
        along = (moved.x - START.x) * perp[0] + (moved.y - START.y) * perp[1]
        assert -side * along > 0.03, (side, along)  # away from the neighbour
        for block in (0, 1):  # both still stand on their bottom face
            _, quat = world.block_pose_3d(block)
            up = np.asarray(world.client.getMatrixFromQuaternion(quat)).reshape(3, 3)[2, 2]
            assert up > 0.99


#: A placement whose release stalled in the cell (30 scenes at 4eb4bf7 seed 1, and the fault
#: runs' grasp_miss seed 1): block 0 to the grid's corner slot, yaw pi, grasp 1, with the
#: blocks of that scene where they stood, the sim seeded 1 and the pick 0.04 mm / 0.15 deg off
#: (the first draw that stalled in a scripted replay, when the wrist turned the block 162 deg
#: on the way; it now turns it 18 deg: ``primitives.hand_turn``).
STALL_BLOCKS = [(0, 0.6233659638277437, -0.04371800670018276, 2.8227276228023057),
                (1, 0.7071800636097995, 0.045285450668201804, 2.1179709813448837),
                (2, 0.8033157670817747, 0.021910542083280152, -2.9728923036503354),
                (3, 0.8175155410411592, -0.11222974256410882, -1.070794107067405),
                (4, 0.5509415704447808, -0.055221398585505475, -0.2928099627316548),
                (5, 0.603191043760322, 0.14276048142698844, -1.8635962660775154),
                (6, 0.5435534093053049, 0.0704302833950865, 0.10052678214643698),
                (7, 0.7460540726623188, 0.23795303438863746, 1.7373216168707326),
                (8, 0.8557018824402647, 0.053688629151727466, -1.5646438608571414)]
STALL_PICK = Pose2D(0.6233659638277437 + 3.7719066328017984e-05,
                    -0.04371800670018276 - 3.963145898739056e-05,
                    2.8227276228023057 + 0.0025616906017731284)
STALL_GOAL = Pose2D(0.6462, -0.0538, math.pi)


def test_the_placement_that_stalled_lets_go_at_once(world_factory):
    """The placement that stalled: the wrist turned the block 162 deg on the way to the
    corner slot, Bullet kept an anchored pad contact with its normal from before the turn,
    and as the fingers opened it pressed the pad back into the block; they stopped 2 mm
    open (the executor's "not released" fault). A cube needs at most a quarter turn: now
    the fingers open to the release opening, at once, and the block stands at its goal."""
    from nodes.bench.sim_play import play as play_steps

    world = world_factory(STALL_BLOCKS, seed=1)
    world.step(24)
    steps = action_steps(PickPlace(0, STALL_PICK, STALL_GOAL, 1), STALL_PICK, GEO, CFG)
    runner, error = play_steps(world, steps, CFG, limit_s=20.0)
    assert not error, f"{error}; {world.fingers.contacts()}"
    assert runner.finished and world.fingers.gap() > release_opening(GEO, CFG) - 0.001
    assert world.block_poses()[0].pose.distance_to(STALL_GOAL) < 0.001
