"""Codecs to and from common_interfaces messages are lossless and refuse malformed input."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st
from std_msgs.msg import String
from visualization_msgs.msg import Marker, MarkerArray

from msgs_py import BlockPose, BlockSet, ExecutorStatus, MessageError, PickPlace, Plan, Pose2D
from msgs_py.ros_codecs import (
    block_set_from_markers,
    block_set_to_markers,
    executor_status_from_string,
    plan_from_string,
    to_string_msg,
)


@st.composite
def block_sets(draw):
    ids = draw(st.lists(st.integers(0, 586), unique=True, max_size=25))
    n_seen = draw(st.integers(0, len(ids)))
    coord = st.floats(-2, 2, allow_nan=False)
    blocks = tuple(
        BlockPose(i, draw(coord), draw(coord), draw(st.floats(-math.pi, math.pi)))
        for i in ids[:n_seen]
    )
    reproj = {b.id: draw(st.floats(0, 5)) for b in blocks if draw(st.booleans())}
    return BlockSet(blocks, draw(st.integers(0, 2**62)), "world", 0.0508, tuple(ids[n_seen:]),
                    reproj)


@given(block_sets())
def test_block_sets_survive_a_marker_array(block_set):
    back = block_set_from_markers(block_set_to_markers(block_set))
    assert back.ids == block_set.ids
    assert back.missing == block_set.missing
    assert back.reprojection_px == block_set.reprojection_px
    assert (back.frame_id, back.block_size) == (block_set.frame_id, block_set.block_size)
    if block_set.blocks or block_set.missing:
        assert back.stamp_ns == block_set.stamp_ns
    for a, b in zip(back.blocks, block_set.blocks, strict=True):
        assert (a.x, a.y) == (b.x, b.y)  # positions travel as float64: bit-exact
        # yaw goes through a quaternion: exact to floating-point rounding
        assert abs(math.remainder(a.theta - b.theta, 2 * math.pi)) < 1e-12


def test_markers_have_the_design_shape():
    msg = block_set_to_markers(BlockSet((BlockPose(7, 0.6, 0.1, 0.5),), 1_500_000_000))
    (m,) = msg.markers
    assert (m.id, m.type, m.ns, m.header.frame_id) == (7, Marker.CUBE, "blocks", "world")
    assert m.header.stamp.sec == 1 and m.header.stamp.nanosec == 500_000_000
    assert m.pose.position.z == pytest.approx(0.0254) and m.scale.x == pytest.approx(0.0508)


def test_malformed_markers_are_refused():
    good = block_set_to_markers(BlockSet((BlockPose(1, 0.6, 0.1), BlockPose(2, 0.7, 0.1))))
    good.markers[1].pose.position.x = float("nan")
    with pytest.raises(MessageError, match=r"markers\[1\].pose.position.x"):
        block_set_from_markers(good)
    dup = block_set_to_markers(BlockSet((BlockPose(1, 0.6, 0.1),)))
    dup.markers.append(dup.markers[0])
    with pytest.raises(MessageError, match="duplicate"):
        block_set_from_markers(dup)
    mixed = block_set_to_markers(BlockSet((BlockPose(1, 0.6, 0.1), BlockPose(2, 0.7, 0.1))))
    mixed.markers[1].header.frame_id = "camera"
    with pytest.raises(MessageError, match="frame_id"):
        block_set_from_markers(mixed)


def test_foreign_namespaces_are_ignored():
    msg = MarkerArray(markers=[Marker(ns="plan", type=Marker.ARROW)])
    assert block_set_from_markers(msg).blocks == ()


def test_plan_and_status_survive_a_string():
    plan = Plan((PickPlace(2, Pose2D(0.5, 0.1), Pose2D(0.7, 0.0), 0),), plan_id="abc")
    assert plan_from_string(to_string_msg(plan)) == plan
    status = ExecutorStatus("running", "abc", 1, 1, 2)
    assert executor_status_from_string(to_string_msg(status)) == status


def test_garbage_strings_are_refused_by_name():
    with pytest.raises(MessageError, match="plan"):
        plan_from_string(String(data="{not json"))
    with pytest.raises(MessageError, match="executor_status"):
        executor_status_from_string(String(data=""))
