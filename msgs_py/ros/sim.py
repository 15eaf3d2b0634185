"""Codecs of the simulator's side channels: armed faults, disturbances, the events it saw
(contacts, losses), and placements (where the executor put a block, for the sim's squaring).
"""

from __future__ import annotations

from densepack_interfaces import msg as ifc

from msgs_py.errors import MessageError
from msgs_py.placement import Placement
from msgs_py.poses import Pose2D
from msgs_py.ros.fields import (
    UINT32_MAX,
    block_id_at,
    code_from,
    code_to,
    constants_of,
    field_paths,
    float_at,
    int_at,
    optional_block_from,
    optional_block_to,
    set_world_header,
    text_at,
)
from msgs_py.ros.scene import pose_from_msg, pose_to_msg
from msgs_py.ros.stamps import ns_to_stamp, stamp_to_ns
from msgs_py.sim import SIM_EVENT_TYPES, SIM_FAULT_KINDS, Disturbance, SimEvent, SimEvents, SimFault

SIM_EVENT_CODES = constants_of(ifc.SimEvent, "TYPE_", SIM_EVENT_TYPES)
SIM_FAULT_CODES = constants_of(ifc.SimFault, "KIND_", SIM_FAULT_KINDS)


def sim_fault_to_msg(fault: SimFault) -> ifc.SimFault:
    msg = ifc.SimFault(kind=code_to("kind", SIM_FAULT_CODES, fault.kind),
                       value=float_at("value", fault.value))
    msg.block = optional_block_to("block", fault.block)
    if fault.pose is not None:
        msg.pose = pose_to_msg(Pose2D(*fault.pose))
    return msg


def sim_fault_from_msg(msg: ifc.SimFault) -> SimFault:
    kind = code_from("kind", SIM_FAULT_CODES, msg.kind)
    block = optional_block_from("block", msg.block)
    pose = pose_from_msg(msg.pose) if kind == "add_block" else None
    return SimFault(kind, block, None if pose is None else (pose.x, pose.y, pose.theta),
                    float_at("value", msg.value))


def placement_to_msg(placement: Placement) -> ifc.Placement:
    msg = ifc.Placement(block=block_id_at("block", placement.block),
                        pose=pose_to_msg(placement.pose),
                        picked_from=pose_to_msg(placement.picked_from, "picked_from"),
                        closing_axis_yaw=float_at("closing_axis_yaw", placement.closing_axis_yaw),
                        squared=bool(placement.squared), pushed=bool(placement.pushed))
    msg.header.stamp = ns_to_stamp(placement.stamp_ns, "stamp_ns")
    msg.header.frame_id = "world"
    return msg


def placement_from_msg(msg: ifc.Placement) -> Placement:
    if msg.header.frame_id not in ("", "world"):
        raise MessageError("header.frame_id", msg.header.frame_id, "placements are in world")
    return Placement(int(msg.block), pose_from_msg(msg.pose),
                     pose_from_msg(msg.picked_from, "picked_from"),
                     float_at("closing_axis_yaw", msg.closing_axis_yaw),
                     stamp_to_ns(msg.header.stamp), bool(msg.squared), bool(msg.pushed))


def sim_event_to_msg(event: SimEvent, where: str = "event") -> ifc.SimEvent:
    return ifc.SimEvent(
        time_s=float_at(f"{where}.time_s", event.time_s),
        type=code_to(f"{where}.type", SIM_EVENT_CODES, event.type),
        block=block_id_at(f"{where}.block", event.block),
        other_block=optional_block_to(f"{where}.other_block", event.other_block),
        manipulated=optional_block_to(f"{where}.manipulated", event.manipulated),
        robot=text_at(f"{where}.robot", event.robot),
        reason=text_at(f"{where}.reason", event.reason),
    )


def sim_event_from_msg(msg: ifc.SimEvent, where: str = "event") -> SimEvent:
    kind = code_from(f"{where}.type", SIM_EVENT_CODES, msg.type)
    time_s = float_at(f"{where}.time_s", msg.time_s)
    block = block_id_at(f"{where}.block", msg.block)
    other = optional_block_from(f"{where}.other_block", msg.other_block)
    manipulated = optional_block_from(f"{where}.manipulated", msg.manipulated)
    with field_paths(where):
        return SimEvent(kind, time_s, block, other, manipulated, msg.robot, msg.reason)


def sim_events_to_msg(events: SimEvents) -> ifc.SimEvents:
    msg = ifc.SimEvents(
        unintended_contacts=int_at("unintended_contacts", events.unintended_contacts, 0,
                                 UINT32_MAX),
        blocks_lost=int_at("blocks_lost", events.blocks_lost, 0, UINT32_MAX),
        events=[sim_event_to_msg(e, f"events[{k}]") for k, e in enumerate(events.events)],
        blocks_raised=[block_id_at(f"blocks_raised[{k}]", b) for k, b in enumerate(events.raised)])
    set_world_header(msg, events.stamp_ns)
    return msg


def sim_events_from_msg(msg: ifc.SimEvents) -> SimEvents:
    events = tuple(sim_event_from_msg(e, f"events[{k}]") for k, e in enumerate(msg.events))
    raised = tuple(block_id_at(f"blocks_raised[{k}]", b) for k, b in enumerate(msg.blocks_raised))
    return SimEvents(int(msg.unintended_contacts), int(msg.blocks_lost), events,
                     stamp_to_ns(msg.header.stamp), raised)


def disturbance_to_msg(disturbance: Disturbance) -> ifc.Disturbance:
    return ifc.Disturbance(block=block_id_at("block", disturbance.block),
                           dx=float_at("dx", disturbance.dx), dy=float_at("dy", disturbance.dy))


def disturbance_from_msg(msg: ifc.Disturbance) -> Disturbance:
    return Disturbance(block_id_at("block", msg.block), float_at("dx", msg.dx),
                       float_at("dy", msg.dy))
