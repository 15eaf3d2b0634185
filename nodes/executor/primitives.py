"""Plan actions as step scripts, the way the paper's cell moves the real arm (Section IV).

Travel happens above the blocks at ``travel_height``; the tool goes straight down over its
target, acts, and comes straight back up. Geometry comes from the plan's own ``params``
(docs/contracts.md), so the executor always does what the planner checked:

* pick-and-place: open to ``block_size + 2 * approach_clearance``, descend centred on the
  block, close (force-limited), lift, carry, descend, release, lift.
* push: close to ``push_opening`` so both fingertips touch the rear face, descend just
  behind the block (``push_contact_depth`` of free travel), push slowly along the line, back
  off, lift.

The block's *perceived* pose replaces the plan's ``from``: the grasp is centred on where
the block really is, and a push is shortened or lengthened so the block ends where the
plan wanted it along the push line.
"""

from __future__ import annotations

import math

from msgs_py import PickPlace, Pose2D, Push, Workspace
from msgs_py.cell import GripperGeometry
from nodes.executor.config import ExecutorConfig
from nodes.executor.motion import ToolPose, equivalent_yaw_near
from nodes.executor.steps import Activity, Grip, Move, Rise, Step, of_block

#: A two-finger grasp is the same under a half turn: a cube placed a half turn from its goal
#: yaw has its fingers where the planner checked them (a quarter turn would not).
GRASP_SYMMETRY = math.pi
#: A released block's faces stand this far (m) from the pads when the tool may rise.
PADS_OFF_M = 0.002


def tool_yaw(closing_axis_yaw: float, cfg: ExecutorConfig) -> float:
    """The tool yaw for a closing axis: of yaw + k*pi, the one nearest the park yaw.

    A two-finger grasp is the same under a half turn, so every tool yaw can stay within a
    quarter turn of one neutral yaw. Choosing relative to the *current* yaw instead lets the
    wrist wander action after action until the IK must change branch (a joint at its limit),
    and the arm then leaves the straight line for a joint-space swing.
    """
    return equivalent_yaw_near(closing_axis_yaw, cfg.park.yaw)


def hand_turn(start: Pose2D, to: Pose2D, turn_period: float = GRASP_SYMMETRY) -> float:
    """How far the wrist turns a carried block: the least turn that sets it down at
    ``to.theta`` give or take whole ``turn_period``s (a half turn for a cube: its goal and
    the planner's finger clearance cannot tell them apart; a full one when the goal is
    ``yaw_exact``)."""
    return math.remainder(to.theta - start.theta, turn_period)


def pick_place_steps(
    action: PickPlace, start: Pose2D, geo: GripperGeometry, cfg: ExecutorConfig,
    pick_opening: float | None = None, turn_period: float = GRASP_SYMMETRY,
) -> list[Step]:
    """Steps for ``action`` with the block perceived at ``start``; the fingers open to
    ``pick_opening`` to go down around it (default: the plan's approach opening) and to the
    plan's approach opening to let it go.

    The wrist turns the block by the least turn the goal allows (at most 90 deg for a cube),
    the pick and place yaws centred on the park yaw. Each yaw on its own nearest the park
    yaw made turns up to 180 deg in the hand: slower, a larger yaw error at release, and in
    the sim the turn left stale anchored pad contacts that locked the fingers on release."""
    approach, contact = _pick_place_parts(action, start, geo, cfg, pick_opening, turn_period)
    return approach + contact


def _pick_place_parts(
    action: PickPlace, start: Pose2D, geo: GripperGeometry, cfg: ExecutorConfig,
    pick_opening: float | None, turn_period: float,
) -> tuple[list[Step], list[Step]]:
    """``pick_place_steps`` in two: up to above the block at travel height, and the rest."""
    opening = geo.approach_opening if pick_opening is None else pick_opening
    turn = hand_turn(start, action.to, turn_period)
    pick_yaw = equivalent_yaw_near(start.theta + action.grasp * math.pi / 2,
                                   cfg.park.yaw - turn / 2)
    place_yaw = pick_yaw + turn
    pick = ToolPose(start.x, start.y, cfg.travel_height, pick_yaw)
    place = ToolPose(action.to.x, action.to.y, cfg.travel_height, place_yaw)
    tag, of = f"block {action.block}", of_block(action.block)
    r = cfg.blend_radius
    approach: list[Step] = [
        *rise_then_shape(opening, cfg, tag, action.block),
        Move(pick, cfg.travel_limits, f"{tag}: travel above", converge=False, **of),
    ]
    descend, last_cm = settle_onto(pick, cfg.grasp_height, cfg, f"{tag}: descend", action.block)
    contact: list[Step] = [
        Grip(opening, cfg.gripper_settle_s, f"{tag}: fingers open", **of),
        descend,
        *close_in(opening, geo, cfg, tag, action.block),
        last_cm,
        Grip(cfg.grip_command, cfg.gripper_settle_s, f"{tag}: grip", holds=action.block, **of),
        Move(pick, cfg.vertical_limits, f"{tag}: lift", blend=r, **of),
        Move(place, cfg.travel_limits, f"{tag}: carry", converge=False, **of),
        *settle_onto(place, cfg.grasp_height + cfg.place_drop, cfg, f"{tag}: lower",
                     action.block),
        Grip(release_opening(geo, cfg), cfg.gripper_settle_s, f"{tag}: release",
             off_at=fingers_off(geo, cfg), **of),
        Move(place, cfg.vertical_limits, f"{tag}: retreat", converge=False, blend=r, **of),
    ]
    return approach, contact


def rise_then_shape(opening: float, cfg: ExecutorConfig, tag: str, block: int) -> list[Step]:
    """Up to travel height, then the fingers to ``opening`` while the tool travels on.

    The rise is waited for (no blend into the travel): an action starts where the last one
    let its block go, the arm still coming up behind its setpoints, and fingers shaped for
    the next block there close on the block just released (a push's narrow opening gripped
    it and carried it off, 25-block seeds 1 and 5) or open into its neighbours."""
    of = of_block(block)
    return [
        Rise(cfg.travel_height, cfg.vertical_limits, f"{tag}: rise", **of),
        Grip(opening, 0.0, f"{tag}: shape the fingers", wait=False, **of),
    ]


def close_in(opening: float, geo: GripperGeometry, cfg: ExecutorConfig, tag: str,
             block: int) -> list[Step]:
    """Bring the fingers in to the release opening while the tool takes the last cm of its
    descent onto a block to pick, so the grip closes the last millimetres only: the fingers
    close at the 2F-85's 0.15 m/s, and from a wide pick opening that took 0.2 s at every
    pick. Only where the fingertips are beside the block by then (below its top even with
    the arm a whole approach distance behind its setpoints): coming in above it, a finger
    could land on a block standing a little off."""
    inside = release_opening(geo, cfg)
    if inside >= opening or cfg.grasp_height + 2.0 * cfg.approach_distance >= geo.block_size:
        return []
    return [Grip(inside, 0.0, f"{tag}: fingers in", wait=False, **of_block(block))]


def release_opening(geo: GripperGeometry, cfg: ExecutorConfig) -> float:
    """The opening that lets a set-down block go: ``release_clearance`` beside it (at most
    the plan's approach clearance). The plan checks the fingers open to the approach
    opening at the place pose, and may leave the outer face of one a hair from a placed
    neighbour (a set-down short of a push line); opening less keeps it millimetres off."""
    return geo.block_size + 2.0 * min(cfg.release_clearance, geo.approach_clearance)


def fingers_off(geo: GripperGeometry, cfg: ExecutorConfig) -> float:
    """The gap at which a release has let its block go: the pads PADS_OFF_M off its faces
    (at most halfway to the release opening). The tool rises from there while the fingers
    open on: the 2F-85 slows down into its last millimetre, and waiting for the release
    opening itself kept the tool at every place 0.1 s longer."""
    return geo.block_size + min(2.0 * PADS_OFF_M, (release_opening(geo, cfg) - geo.block_size) / 2)


def settle_onto(above: ToolPose, z: float, cfg: ExecutorConfig, label: str,
                block: int | None = None) -> list[Step]:
    """Straight down from ``above`` to height ``z``: fast, then the last approach_distance
    at approach_speed (contact happens slowly); the end is waited for. ``block``: the block
    the descent handles (None: none)."""
    of = of_block(block) if block is not None else {}
    return [
        Move(above.with_z(z + cfg.approach_distance), cfg.vertical_limits, label,
             converge=False, **of),
        Move(above.with_z(z), cfg.approach_limits, f"{label} (last cm)", onto=above.z, **of),
    ]


def push_geometry(action: Push, start: Pose2D, geo: GripperGeometry) -> tuple[float, float]:
    """(push distance from the perceived start, TCP offset behind the block centre)."""
    dx, dy = action.direction
    distance = (action.to.x - start.x) * dx + (action.to.y - start.y) * dy
    behind = geo.block_size / 2 + geo.push_contact_depth + geo.finger_width / 2
    return distance, behind


def push_steps(
    action: Push, start: Pose2D, geo: GripperGeometry, cfg: ExecutorConfig
) -> list[Step]:
    """Steps for a two-fingertip push of ``action`` with the block perceived at ``start``."""
    approach, contact = _push_parts(action, start, geo, cfg)
    return approach + contact


def _push_parts(action: Push, start: Pose2D, geo: GripperGeometry, cfg: ExecutorConfig
                ) -> tuple[list[Step], list[Step]]:
    """``push_steps`` in two: up to behind the block at travel height, and the rest."""
    dx, dy = action.direction
    distance, behind = push_geometry(action, start, geo)
    yaw = tool_yaw(math.atan2(dy, dx) + math.pi / 2, cfg)
    contact = ToolPose(start.x - dx * behind, start.y - dy * behind, cfg.push_height, yaw)
    travel = distance + geo.push_contact_depth
    end = contact.offset(dx * travel, dy * travel)
    back = end.offset(-dx * cfg.push_backoff, -dy * cfg.push_backoff)
    tag, of = f"block {action.block}", of_block(action.block)
    approach: list[Step] = [
        *rise_then_shape(geo.push_opening, cfg, tag, action.block),
        Move(contact.with_z(cfg.travel_height), cfg.travel_limits, f"{tag}: travel behind",
             converge=False, **of),
    ]
    pushing: list[Step] = [
        # the fingers must be at the push opening before they go down beside the blocks
        Grip(geo.push_opening, cfg.gripper_settle_s, f"{tag}: fingers closed", **of),
        *settle_onto(contact.with_z(cfg.travel_height), cfg.push_height, cfg,
                     f"{tag}: descend behind", action.block),
        Move(end, cfg.push_limits, f"{tag}: push", pushes=True, **of),
        # converged: the arm, a servo delay and a stream behind the setpoints, has its fingers
        # off the block before the action ends and the status stops naming the block (else
        # the sim counted the pushed block touched after its push, 9 scenes in 10)
        Move(back, cfg.push_limits, f"{tag}: back off", **of),
        Move(back.with_z(cfg.travel_height), cfg.vertical_limits, f"{tag}: retreat",
             converge=False, blend=cfg.blend_radius, **of),
    ]
    return approach, pushing


def park_steps(cfg: ExecutorConfig) -> list[Step]:
    """Up to travel height and to the park pose, out of the camera's view."""
    return [
        Rise(cfg.travel_height, cfg.vertical_limits, "park: rise", blend=cfg.blend_radius,
             activity=Activity.LOOK),
        Move(cfg.park, cfg.travel_limits, "park", activity=Activity.LOOK),
    ]


def look_pose(cfg: ExecutorConfig, workspace: Workspace, near: ToolPose) -> ToolPose:
    """Where the arm waits while the camera looks: ``look_offset`` outside the workspace's
    robot-side edge, level with ``near`` (clamped to the workspace's y range).

    The UR's base stands at the origin, on the -x side of the workspace, and its links lie
    between the base and the TCP, so with the TCP there no part of the arm stands between
    the overhead camera and a block in the workspace.
    """
    y = min(max(near.y, workspace.y_min), workspace.y_max)
    return ToolPose(workspace.x_min - cfg.look_offset, y, cfg.look_height, cfg.park.yaw)


def look_steps(cfg: ExecutorConfig, workspace: Workspace, near: ToolPose) -> list[Step]:
    """From above the workspace (at ``near``) to the look pose, stopping there."""
    return [
        Rise(cfg.travel_height, cfg.vertical_limits, "look: rise", blend=cfg.blend_radius,
             activity=Activity.LOOK),
        Move(look_pose(cfg, workspace, near), cfg.travel_limits, "look", activity=Activity.LOOK),
    ]


def hover_steps(action: PickPlace | Push, start: Pose2D, geo: GripperGeometry,
                cfg: ExecutorConfig, pick_opening: float | None = None,
                turn_period: float = GRASP_SYMMETRY) -> list[Step]:
    """The first moves of ``action``, up to above its block at travel height: safe to make
    before the world is judged (nothing is touched), so they overlap the camera's wait."""
    if isinstance(action, PickPlace):
        return _pick_place_parts(action, start, geo, cfg, pick_opening, turn_period)[0]
    return _push_parts(action, start, geo, cfg)[0]


def action_steps(
    action: PickPlace | Push, start: Pose2D, geo: GripperGeometry, cfg: ExecutorConfig,
    pick_opening: float | None = None, turn_period: float = GRASP_SYMMETRY,
) -> list[Step]:
    if isinstance(action, PickPlace):
        return pick_place_steps(action, start, geo, cfg, pick_opening, turn_period)
    return push_steps(action, start, geo, cfg)


def expected_after(action: PickPlace | Push, start: Pose2D, geo: GripperGeometry) -> Pose2D:
    """Where the block should stand after ``action`` started from the perceived ``start``."""
    if isinstance(action, PickPlace):
        return action.to
    distance, _ = push_geometry(action, start, geo)
    dx, dy = action.direction
    return Pose2D(start.x + dx * distance, start.y + dy * distance, action.to.theta)
