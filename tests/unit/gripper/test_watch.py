"""The gripper node's mapping and its grasp signal, made from the knuckle joint alone."""

from __future__ import annotations

import pytest

from msgs_py.cell import BLOCK_SIZE, GRIPPER_STROKE
from nodes.gripper.watch import KnuckleWatch
from nodes.robot import gripper_2f85 as g85


def test_gap_and_knuckle_map_onto_each_other_over_the_stroke():
    assert g85.gap_to_knuckle(GRIPPER_STROKE) == 0.0
    assert g85.gap_to_knuckle(0.0) == pytest.approx(g85.KNUCKLE_CLOSED)
    assert g85.gap_to_knuckle(0.2) == 0.0 and g85.gap_to_knuckle(-0.01) == g85.KNUCKLE_CLOSED
    for gap in (0.0, 0.01, BLOCK_SIZE, 0.085):
        assert g85.knuckle_to_gap(g85.gap_to_knuckle(gap)) == pytest.approx(gap)


def samples(watch: KnuckleWatch, gaps, t0: float, dt: float = 0.02):
    out = []
    for k, gap in enumerate(gaps):
        out.append(watch.on_position(g85.gap_to_knuckle(gap), t0 + k * dt))
    return out


def test_a_stall_short_of_a_closing_command_is_a_held_object():
    watch = KnuckleWatch()
    samples(watch, [0.085], 0.0)
    watch.on_command(g85.gap_to_knuckle(0.0), 0.02)
    closing = [0.085 - 0.003 * k for k in range(12)] + [BLOCK_SIZE] * 6
    statuses = samples(watch, closing, 0.04)
    assert statuses[3].object == "moving"
    assert statuses[-1].object == "stopped_closing" and statuses[-1].holds_object
    assert statuses[-1].gap == pytest.approx(BLOCK_SIZE)
    assert statuses[-1].requested_gap == pytest.approx(0.0)


def test_reaching_the_command_is_at_position_and_an_opening_stall_is_named():
    watch = KnuckleWatch()
    samples(watch, [BLOCK_SIZE], 0.0)
    watch.on_command(g85.gap_to_knuckle(0.07), 0.02)
    assert samples(watch, [0.06, 0.065, 0.07, 0.07], 0.04)[-1].object == "at_position"
    watch.on_command(g85.gap_to_knuckle(0.085), 0.2)
    stuck = samples(watch, [0.075] * 6, 0.22)
    assert stuck[-1].object == "stopped_opening"


def test_a_new_command_reads_as_moving_until_the_gripper_had_time_to_act():
    watch = KnuckleWatch()
    samples(watch, [0.085, 0.085], 0.0)
    watch.on_command(g85.gap_to_knuckle(0.0), 0.03)
    assert watch.on_position(g85.gap_to_knuckle(0.085), 0.04).object == "moving"


def test_a_gripper_that_never_moves_is_reported_once():
    watch = KnuckleWatch()
    samples(watch, [0.085], 0.0)
    watch.on_command(g85.gap_to_knuckle(0.0), 0.0)
    samples(watch, [0.085] * 30, 0.02)
    words = watch.never_moved(0.62)
    assert "did not move" in words and "activated" in words
    assert watch.never_moved(0.7) == ""


def test_before_any_command_the_status_reads_the_fingers_where_they_stand():
    """A node that has just (re)started reports at once (its lease holder with it), without
    claiming a command nobody sent."""
    watch = KnuckleWatch()
    first = samples(watch, [BLOCK_SIZE], 0.0)[0]
    assert first.gap == pytest.approx(BLOCK_SIZE)
    assert first.requested_gap == pytest.approx(BLOCK_SIZE)
    assert first.object == "at_position" and not first.holds_object
    watch.on_command(g85.gap_to_knuckle(0.085), 0.02)
    assert samples(watch, [BLOCK_SIZE], 0.03)[0].requested_gap == pytest.approx(0.085)
