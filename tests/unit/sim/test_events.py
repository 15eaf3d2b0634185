"""Event monitor logic: what counts as an unintended contact or a lost block, and how often."""

from __future__ import annotations

import math

import numpy as np

from msgs_py import Workspace
from nodes.sim.events import ContactKind, EventMonitor

S = 0.0508
UP = np.array([0.0, 0.0, 0.0, 1.0])
FINGER = (ContactKind.FINGER, 7)


def monitor() -> EventMonitor:
    return EventMonitor(Workspace(0.45, 0.95, -0.35, 0.35), (-0.3, 1.4, -0.9, 0.9), S)


def resting(x=0.7, y=0.0, quat=UP):
    return (np.array([x, y, S / 2]), quat, 0.0, 0.0)


def block(i):
    return (ContactKind.BLOCK, i)


def test_gripper_touching_the_manipulated_block_is_fine_any_other_counts_once():
    m = monitor()
    m.manipulated = 1
    blocks = {1: resting(), 2: resting(0.8)}
    m.update(0.0, [(FINGER, block(1))], blocks)
    assert m.unintended_contacts == 0
    for k in range(5):  # one long contact episode counts once
        m.update(0.01 * k, [(block(2), FINGER)], blocks)
    assert m.unintended_contacts == 1
    m.update(1.0, [], blocks)  # apart long enough ...
    events = m.update(1.01, [(FINGER, block(2))], blocks)  # ... a new episode
    assert m.unintended_contacts == 2
    assert events[0]["type"] == "unintended_contact" and events[0]["block"] == 2


def test_a_grip_that_began_on_the_manipulated_block_stays_intended_until_let_go():
    m = monitor()
    m.manipulated = 1
    blocks = {1: resting()}
    m.update(0.0, [(FINGER, block(1))], blocks)
    m.manipulated = None  # the executor died; the one back does not name the held block yet
    for k in range(1, 5):
        m.update(0.01 * k, [(FINGER, block(1))], blocks)
    assert m.unintended_contacts == 0
    m.update(1.0, [], blocks)  # let go, apart long enough: a new touch is judged anew
    m.update(1.01, [(FINGER, block(1))], blocks)
    assert m.unintended_contacts == 1


def test_blocks_touching_count_only_while_one_moves():
    m = monitor()
    still = {1: resting(), 2: resting(0.75)}
    m.update(0.0, [(block(1), block(2))], still)
    assert m.unintended_contacts == 0
    moving = dict(still)
    moving[1] = (still[1][0], UP, 0.05, 0.0)
    m.update(0.02, [(block(1), block(2))], moving)
    m.update(0.04, [(block(2), block(1))], moving)
    assert m.unintended_contacts == 1
    assert m.events[-1]["blocks"] == [1, 2]


def test_lost_blocks_off_table_out_of_workspace_tipped_each_once():
    m = monitor()
    tipped = np.array([math.sin(math.pi / 4), 0.0, 0.0, math.cos(math.pi / 4)])
    blocks = {1: (np.array([1.6, 0.0, -0.3]), UP, 1.0, 0.0), 2: resting(0.40),
              3: resting(quat=tipped), 4: resting(0.46), 5: (np.array([0.7, 0, 0.2]), UP, 0.3, 0)}
    m.update(0.0, [], blocks)
    m.update(0.1, [], blocks)
    reasons = {e["block"]: e["reason"] for e in m.events}
    assert reasons == {1: "off the table", 2: "out of the workspace", 3: "tipped over"}
    assert m.blocks_lost == 3
    summary = m.summary()
    assert summary["blocks_lost"] == 3 and summary["unintended_contacts"] == 0


def test_a_block_held_up_is_raised_not_lost_and_no_longer_raised_once_set_down():
    """A block still in the fingers when a run ends never rests on the table, so it is never
    lost; the summary names it as raised (the benchmark counts it as left held)."""
    m = monitor()
    held = (np.array([0.7, 0.0, 0.3]), UP, 0.0, 0.0)  # at rest in the fingers at the park pose
    m.update(0.0, [], {1: held, 2: resting()})
    m.update(1.0, [], {1: held, 2: resting()})
    assert m.blocks_lost == 0 and m.summary()["blocks_raised"] == [1]
    m.update(2.0, [], {1: resting(0.7), 2: resting()})
    assert m.summary()["blocks_raised"] == []
