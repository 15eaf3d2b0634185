"""The bag tools' type knowledge: rosbags' typestore learns densepack_interfaces from the
installed .msg files and agrees with the generated Python classes, byte for byte."""

from __future__ import annotations

import json

import pytest
from densepack_interfaces.msg import BlockPose, BlockPoseArray, ExecutorStatus, Metric
from rclpy.qos import DurabilityPolicy, ReliabilityPolicy
from rclpy.serialization import deserialize_message, serialize_message

from nodes.common.qos import CAMERA, LATCHED, RELIABLE
from nodes.tools import bags

OWN = bags.interface_share_dir("densepack_interfaces")
OWN_TYPES = sorted(f"densepack_interfaces/msg/{p.stem}" for p in (OWN / "msg").glob("*.msg"))


def test_the_ament_index_finds_the_installed_definitions():
    assert (OWN / "msg" / "ExecutorStatus.msg").is_file()
    assert len(OWN_TYPES) >= 20
    with pytest.raises(LookupError, match="no_such_interfaces"):
        bags.interface_share_dir("no_such_interfaces")


@pytest.mark.parametrize("type_name", OWN_TYPES)
def test_every_own_type_has_the_hash_rosidl_generated(type_name):
    """The type description hash (RIHS01) is over the whole definition: equal hashes mean the
    typestore holds the very types the cell publishes (what rosbag2 writes into a bag)."""
    generated = json.loads((OWN / "msg" / f"{type_name.split('/')[-1]}.json").read_text())
    expected = next(h["hash_string"] for h in generated["type_hashes"]
                    if h["type_name"] == type_name)
    assert bags.typestore().hash_rihs01(type_name) == expected


def test_rosbags_and_rclpy_read_each_others_bytes():
    msg = ExecutorStatus(state=ExecutorStatus.STATE_RUNNING, plan_id="p1", action_index=3,
                         action_total=11, block=7, detail="action 3/11",
                         metrics=[Metric(name="time_push_s", value=4.25)])
    raw = serialize_message(msg)
    store = bags.typestore()
    decoded = store.deserialize_cdr(raw, "densepack_interfaces/msg/ExecutorStatus")
    assert (decoded.plan_id, decoded.action_index, decoded.block) == ("p1", 3, 7)
    assert decoded.metrics[0].name == "time_push_s" and decoded.metrics[0].value == 4.25
    again = store.serialize_cdr(decoded, "densepack_interfaces/msg/ExecutorStatus")
    assert len(again) == len(raw)  # the same layout (padding bytes may differ)
    assert deserialize_message(bytes(again), ExecutorStatus) == msg


def test_message_definitions_carry_their_dependencies_for_foxglove():
    text = bags.message_definition("densepack_interfaces/BlockPoseArray")
    assert "std_msgs/Header header" in text.split("=" * 80)[0].splitlines()
    for used in ("MSG: std_msgs/Header", "MSG: densepack_interfaces/BlockPose",
                 "MSG: densepack_interfaces/PlanarPose"):
        assert used in text
    assert serialize_message(BlockPoseArray(blocks=[BlockPose(id=2)]))  # the class exists


def constant_names(definition: str, field: str) -> dict[int, str]:
    """The names the Foxglove apps give ``field``'s values: the constants of one type written
    directly before it in the message's own part of the definition (the apps' rule)."""
    run: dict[int, str] = {}
    run_type = None
    for line in definition.split("=" * 80)[0].splitlines():
        words = line.split("#")[0].replace("=", " = ").split()
        if not words:
            continue
        if run_type is not None and words[0] != run_type:
            run, run_type = {}, None
        if len(words) >= 4 and words[2] == "=":
            run[int(words[3])], run_type = words[1], words[0]
        elif words[1] == field:
            return run
        else:
            run = {}
    raise AssertionError(f"no field {field} in the definition")


def test_the_executor_state_has_its_constant_names_in_the_view():
    """The definitions are the installed .msg files as written (rosbag2 stores those): the
    typestore's rendering lists every constant first, and the app then shows the state as a
    bare number."""
    text = bags.message_definition("densepack_interfaces/msg/ExecutorStatus")
    assert constant_names(text, "state")[ExecutorStatus.STATE_RUNNING] == "STATE_RUNNING"
    assert len(constant_names(text, "state")) == 10
    assert constant_names(text, "block") == {-1: "NO_BLOCK"}
    marker = bags.message_definition("visualization_msgs/MarkerArray")
    marker_part = marker.split("MSG: visualization_msgs/Marker\n")[1].split("=" * 80)[0]
    assert marker_part == bags.msg_source("visualization_msgs/msg/Marker")  # a dependency's
    assert "int32 CUBE=1" in marker_part and "MSG: std_msgs/Header" in marker  # own file too
    assert bags.msg_source("densepack_interfaces/msg/NoSuchType") is None


def test_qos_is_matched_on_record_and_kept_on_replay():
    assert bags.subscription_qos([LATCHED]).durability == DurabilityPolicy.TRANSIENT_LOCAL
    mixed = bags.subscription_qos([LATCHED, RELIABLE])
    assert mixed.durability == DurabilityPolicy.VOLATILE  # a latched sub misses volatile pubs
    from rclpy.qos import qos_profile_sensor_data

    assert (bags.subscription_qos([CAMERA, qos_profile_sensor_data]).reliability
            == ReliabilityPolicy.BEST_EFFORT)
    latched = bags.replay_qos([bags.to_bag_qos(LATCHED)])
    assert latched.durability == DurabilityPolicy.TRANSIENT_LOCAL and latched.depth == 1
    plain = bags.replay_qos([bags.to_bag_qos(CAMERA)])
    assert plain.durability == DurabilityPolicy.VOLATILE
    assert plain.reliability == ReliabilityPolicy.RELIABLE
    assert bags.replay_qos([]).reliability == ReliabilityPolicy.RELIABLE


def test_hidden_topics_are_action_internals():
    assert bags.is_hidden("/rearrange/_action/feedback")
    assert not bags.is_hidden("/camera/image_raw/compressed")
