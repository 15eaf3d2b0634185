"""The live view's 3-D scene: the cell as Foxglove ``SceneUpdate`` entities, built from the
cell's own data (no rclpy here; ``densepack-view`` feeds it decoded messages).

Why a scene of our own beside the MarkerArrays the nodes publish: the view shows what the
cell *believes* (detected blocks, the goal it was given, the plan it runs, where the arm's
tool is) in one topic whose entities are named, so the Foxglove 3-D panel can toggle each
part, and the goal slots (which no node draws) are there too.

Frames: each entity is in the frame its message names (an empty ``frame_id`` is ``world``):
goal layouts and plans are ``world`` by contract; a detection or a TCP pose in another frame
is drawn in that frame (the app places it through TF, or not at all), never silently as if
it were ``world``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from foxglove.messages import (
    ArrowPrimitive,
    Color,
    CubePrimitive,
    LinePrimitive,
    LinePrimitiveLineType,
    Point3,
    Pose,
    Quaternion,
    SceneEntity,
    SceneUpdate,
    SpherePrimitive,
    TextPrimitive,
    Timestamp,
    Vector3,
)

from msgs_py import BlockSet, Goal, Plan, Scene
from msgs_py.poses import Pose2D

FRAME = "world"
#: Colours: detected blocks, goal slots (translucent floor tiles, and the outline of the cube
#: each slot wants), plan arrows per action kind (the plan drawing's own colours), the TCP.
BLOCK_COLOUR = Color(r=0.85, g=0.75, b=0.55, a=1.0)
GOAL_COLOUR = Color(r=0.2, g=0.7, b=0.3, a=0.35)
GOAL_OUTLINE_COLOUR = Color(r=0.05, g=0.55, b=0.15, a=1.0)
ACTION_COLOURS = {"pick_place": Color(r=0.30, g=0.45, b=0.69, a=0.9),
                  "push": Color(r=0.87, g=0.52, b=0.32, a=0.9)}
TCP_COLOUR = Color(r=0.9, g=0.1, b=0.1, a=1.0)
#: Height of the goal tiles and of the plan's arrows above the table (m): the tiles are
#: drawn flat on the table, the arrows just above the blocks so they are not hidden.
GOAL_TILE_M = 0.002
ARROW_LIFT_M = 0.01
#: Width of the goal slots' outlines (screen pixels).
OUTLINE_PX = 1.5


def _stamp(stamp_ns: int) -> Timestamp:
    return Timestamp(sec=stamp_ns // 10**9, nsec=stamp_ns % 10**9)


def _yaw_quaternion(yaw: float) -> Quaternion:
    return Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))


def _pose(x: float, y: float, z: float, yaw: float = 0.0) -> Pose:
    return Pose(position=Vector3(x=x, y=y, z=z), orientation=_yaw_quaternion(yaw))


def _entity(entity_id: str, stamp_ns: int, frame_id: str = FRAME,
            **primitives: list) -> SceneEntity:
    return SceneEntity(timestamp=_stamp(stamp_ns), frame_id=frame_id or FRAME, id=entity_id,
                       frame_locked=True, **primitives)


def block_entity(blocks: BlockSet, stamp_ns: int) -> SceneEntity:
    """One cube per detected block, its id written above it, in the detection's frame."""
    s = blocks.block_size
    cubes = [CubePrimitive(pose=_pose(b.pose.x, b.pose.y, s / 2, b.pose.theta),
                           size=Vector3(x=s, y=s, z=s), color=BLOCK_COLOUR)
             for b in blocks.blocks]
    texts = [TextPrimitive(pose=_pose(b.pose.x, b.pose.y, s + 0.02), billboard=True,
                           font_size=14.0, scale_invariant=True,
                           color=Color(r=0.1, g=0.1, b=0.1, a=1.0), text=str(b.id))
             for b in blocks.blocks]
    return _entity("blocks", stamp_ns, blocks.frame_id, cubes=cubes, texts=texts)


def slot_names(goal: Goal, block_ids: Iterable[int], block_size: float) -> list[str]:
    """What each slot is called: ``goal <id>`` for the block a labeled goal gives it (a
    labeled grid's slots follow the known block ids), else ``slot <k>``."""
    ids = sorted(set(block_ids))
    named = list(goal.assignment(ids, block_size)) if goal.labeled else []
    return [f"goal {named[k]}" if k < len(named) else f"slot {k}"
            for k in range(goal.n_slots)]


def cube_edges(side: float) -> list[Point3]:
    """The 12 edges of a cube standing on z = 0, centred on its pose, as line-list pairs."""
    h = side / 2
    corners = [(-h, -h), (h, -h), (h, h), (-h, h)]
    points: list[Point3] = []
    for k, (x, y) in enumerate(corners):
        nx, ny = corners[(k + 1) % 4]
        for z in (0.0, side):  # the bottom and the top square's edge
            points += [Point3(x=x, y=y, z=z), Point3(x=nx, y=ny, z=z)]
        points += [Point3(x=x, y=y, z=0.0), Point3(x=x, y=y, z=side)]  # an upright edge
    return points


def goal_entity(layout: Scene, stamp_ns: int, block_ids: Iterable[int] = ()) -> SceneEntity:
    """The goal's slots: a translucent tile on the table and the outline of the cube the
    slot wants (a block in place fills it), named by ``slot_names``."""
    s = layout.block_size
    cubes, lines, texts = [], [], []
    if layout.goal is not None:
        names = slot_names(layout.goal, block_ids, s)
        for slot, name in zip(layout.goal.slot_poses(s), names, strict=True):
            cubes.append(CubePrimitive(pose=_pose(slot.x, slot.y, GOAL_TILE_M / 2, slot.theta),
                                       size=Vector3(x=s, y=s, z=GOAL_TILE_M), color=GOAL_COLOUR))
            lines.append(LinePrimitive(type=LinePrimitiveLineType.LineList,
                                       pose=_pose(slot.x, slot.y, 0.0, slot.theta),
                                       thickness=OUTLINE_PX, scale_invariant=True,
                                       points=cube_edges(s), color=GOAL_OUTLINE_COLOUR))
            texts.append(TextPrimitive(pose=_pose(slot.x, slot.y, GOAL_TILE_M),
                                       billboard=True, font_size=12.0, scale_invariant=True,
                                       color=Color(r=0.1, g=0.45, b=0.15, a=1.0), text=name))
    return _entity("goal", stamp_ns, cubes=cubes, lines=lines, texts=texts)


def _arrow(a: Pose2D, b: Pose2D, z: float, colour: Color) -> ArrowPrimitive | None:
    dx, dy = b.x - a.x, b.y - a.y
    length = math.hypot(dx, dy)
    if length < 1e-4:  # a turn in place: nothing to point along
        return None
    head = min(0.03, 0.4 * length)
    return ArrowPrimitive(pose=_pose(a.x, a.y, z, math.atan2(dy, dx)),
                          shaft_length=length - head, shaft_diameter=0.006,
                          head_length=head, head_diameter=0.018, color=colour)


def plan_entity(plan: Plan, stamp_ns: int, done: int = 0) -> SceneEntity:
    """One arrow per action still to run (from ``done``, the executor's count), from where
    its block is to where it goes: blue pick-and-place, orange push."""
    z = (plan.scene.block_size if plan.scene is not None else 0.0508) + ARROW_LIFT_M
    arrows = [arrow for action in plan.actions[done:]
              if (arrow := _arrow(action.from_, action.to, z,
                                  ACTION_COLOURS.get(action.type, BLOCK_COLOUR))) is not None]
    return _entity("plan", stamp_ns, arrows=arrows)


def tool_z_axis(orientation_xyzw: Iterable[float]) -> tuple[float, float, float]:
    """The tool's z axis (where the fingers point) in ``world``: the rotation's third column."""
    qx, qy, qz, qw = orientation_xyzw
    return (2 * (qx * qz + qw * qy), 2 * (qy * qz - qw * qx), 1 - 2 * (qx * qx + qy * qy))


def pointing_quaternion(direction: Iterable[float]) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation taking +x onto the unit ``direction`` (an arrow points along
    its pose's +x): a yaw about z after a pitch about y."""
    dx, dy, dz = direction
    yaw, pitch = math.atan2(dy, dx), -math.asin(max(-1.0, min(1.0, dz)))
    cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(pitch / 2), math.sin(pitch / 2)
    return (-sy * sp, cy * sp, sy * cp, cy * cp)


def tcp_entity(position: Iterable[float], orientation_xyzw: Iterable[float],
               stamp_ns: int, frame_id: str = FRAME) -> SceneEntity:
    """The arm's tool centre point in ``frame_id`` (the pose message's): a sphere, and an
    arrow along the tool's z (the way the fingers point)."""
    x, y, z = position
    ax, ay, az, aw = pointing_quaternion(tool_z_axis(orientation_xyzw))
    arrow_q = Quaternion(x=ax, y=ay, z=az, w=aw)
    sphere = SpherePrimitive(pose=Pose(position=Vector3(x=x, y=y, z=z),
                                       orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)),
                             size=Vector3(x=0.02, y=0.02, z=0.02), color=TCP_COLOUR)
    arrow = ArrowPrimitive(pose=Pose(position=Vector3(x=x, y=y, z=z), orientation=arrow_q),
                           shaft_length=0.05, shaft_diameter=0.006, head_length=0.02,
                           head_diameter=0.014, color=TCP_COLOUR)
    return _entity("tcp", stamp_ns, frame_id, spheres=[sphere], arrows=[arrow])


def scene_update(entities: Iterable[SceneEntity | None]) -> SceneUpdate:
    """The entities known so far as one update (each replaces its namesake in the panel)."""
    return SceneUpdate(entities=[e for e in entities if e is not None])
