"""The plan as a ``visualization_msgs/MarkerArray`` for RViz (``/plan/markers``).

Namespaces: ``plan_start`` (start footprints, wood), ``plan_goal`` (goal footprints,
translucent green), ``plan_actions`` (one ARROW per action from its start to its end: blue
pick-and-place, orange push) and ``plan_labels`` (the action's number). The first marker is a
DELETEALL so a new plan replaces the old one entirely.
"""

from __future__ import annotations

from geometry_msgs.msg import Point
from visualization_msgs.msg import Marker, MarkerArray

from msgs_py import Plan, Push, Scene
from msgs_py.ros import yaw_to_quaternion_xyzw
from nodes.planner.unlabeled.goal_check import goal_slots

COLORS = {
    "start": (0.85, 0.68, 0.45, 0.9),
    "goal": (0.2, 0.7, 0.3, 0.35),
    "pick_place": (0.12, 0.47, 0.71, 1.0),
    "push": (1.0, 0.5, 0.05, 1.0),
}


def _marker(ns: str, marker_id: int, kind: int, frame_id: str, rgba) -> Marker:
    m = Marker()
    m.header.frame_id = frame_id
    m.ns, m.id, m.type, m.action = ns, marker_id, kind, Marker.ADD
    m.color.r, m.color.g, m.color.b, m.color.a = rgba
    m.pose.orientation.w = 1.0
    return m


def _cube(ns: str, marker_id: int, x: float, y: float, theta: float, s: float, frame_id: str,
          rgba, height: float) -> Marker:
    m = _marker(ns, marker_id, Marker.CUBE, frame_id, rgba)
    m.pose.position.x, m.pose.position.y, m.pose.position.z = x, y, 0.5 * height
    qx, qy, qz, qw = yaw_to_quaternion_xyzw(theta)
    m.pose.orientation.x, m.pose.orientation.y = qx, qy
    m.pose.orientation.z, m.pose.orientation.w = qz, qw
    m.scale.x = m.scale.y = s
    m.scale.z = height
    return m


def plan_markers(plan: Plan, scene: Scene, frame_id: str = "world") -> MarkerArray:
    s = scene.block_size
    clear = Marker()
    clear.header.frame_id = frame_id
    clear.action = Marker.DELETEALL
    markers = [clear]
    for b in scene.blocks:
        markers.append(_cube("plan_start", b.id, b.x, b.y, b.theta, s, frame_id,
                             COLORS["start"], s))
    for key, goal in goal_slots(scene):  # marker id: the block id, or the slot if unlabeled
        markers.append(_cube("plan_goal", key, goal.x, goal.y, goal.theta, s, frame_id,
                             COLORS["goal"], 0.2 * s))
    z = 1.2 * s
    for k, action in enumerate(plan.actions, start=1):
        kind = "push" if isinstance(action, Push) else "pick_place"
        arrow = _marker("plan_actions", k, Marker.ARROW, frame_id, COLORS[kind])
        arrow.points = [Point(x=action.from_.x, y=action.from_.y, z=z),
                        Point(x=action.to.x, y=action.to.y, z=z)]
        width = 0.008 if kind == "push" else 0.004
        arrow.scale.x, arrow.scale.y, arrow.scale.z = width, 2.5 * width, 3.0 * width
        arrow.text = f"{k}: {kind} block {action.block}"
        markers.append(arrow)
        label = _marker("plan_labels", k, Marker.TEXT_VIEW_FACING, frame_id, COLORS[kind])
        label.pose.position.x, label.pose.position.y = action.from_.x, action.from_.y
        label.pose.position.z = z + 0.02
        label.scale.z = 0.02
        label.text = str(k)
        markers.append(label)
    return MarkerArray(markers=markers)
