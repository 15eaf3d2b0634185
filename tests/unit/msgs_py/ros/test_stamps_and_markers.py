"""Codecs to common_interfaces messages: stamps both ways, block sets as viewer markers."""

from __future__ import annotations

import math

import pytest
from builtin_interfaces.msg import Time
from hypothesis import given
from hypothesis import strategies as st
from visualization_msgs.msg import Marker

from msgs_py import BlockPose, BlockSet, MessageError
from msgs_py.ros import block_set_to_markers, ns_to_stamp, stamp_to_ns


@given(st.integers(-(2**31) * 10**9, (2**31 - 1) * 10**9 + 999_999_999))
def test_stamps_round_trip(stamp_ns):
    assert stamp_to_ns(ns_to_stamp(stamp_ns)) == stamp_ns


def test_stamps_time_cannot_hold_are_refused_by_name():
    with pytest.raises(MessageError, match="stamp_ns"):
        ns_to_stamp(2**63, "stamp_ns")
    with pytest.raises(MessageError, match="stamp"):
        ns_to_stamp(1.5)
    assert ns_to_stamp(1_500_000_000) == Time(sec=1, nanosec=500_000_000)


def test_markers_have_the_design_shape():
    msg = block_set_to_markers(BlockSet((BlockPose(7, 0.6, 0.1, 0.5),), 1_500_000_000,
                                        missing=(3,)))
    cube, hidden = msg.markers
    assert (cube.id, cube.type, cube.ns, cube.header.frame_id) == (7, Marker.CUBE, "blocks",
                                                                   "world")
    assert cube.header.stamp.sec == 1 and cube.header.stamp.nanosec == 500_000_000
    assert cube.pose.position.z == pytest.approx(0.0254)
    assert cube.scale.x == pytest.approx(0.0508)
    assert 2 * math.atan2(cube.pose.orientation.z, cube.pose.orientation.w) == pytest.approx(0.5)
    assert (hidden.id, hidden.action, hidden.ns) == (3, Marker.DELETE, "blocks")
